//! Filtering candidate lists without a branch per candidate.

/// Appends the items marked to keep, in order, without a branch per item:
/// each is written past the kept ones and the length moves on by whether
/// it is kept. PERF: whether a candidate is kept (about one in eight of
/// a plan's) follows no pattern a branch predictor learns, and a
/// mispredicted branch costs more than the box test
/// (docs/benchmarks.md 1r). `#[inline]`: called from other modules'
/// hot loops, out of line it cost sphere-drape-30's self-collision 6 %.
#[inline]
pub fn extend_kept<T: Copy + Default>(
    out: &mut Vec<T>,
    items: impl ExactSizeIterator<Item = (T, bool)>,
) {
    let mut n = out.len();
    out.resize(n + items.len(), T::default());
    for (item, keep) in items {
        out[n] = item;
        n += usize::from(keep);
    }
    out.truncate(n);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kept items follow what was there, in their order; the rest
    /// leave no trace.
    #[test]
    fn keeps_the_marked_items_in_order_after_the_old_ones() {
        let mut out = vec![7u32];
        extend_kept(&mut out, (0..10u32).map(|k| (k, k % 3 == 1)));
        assert_eq!(out, [7, 1, 4, 7]);
        extend_kept(&mut out, std::iter::empty());
        extend_kept(&mut out, [(9, false)].into_iter());
        assert_eq!(out, [7, 1, 4, 7]);
    }
}
