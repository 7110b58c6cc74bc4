//! Values folded up the tree, one per node (a leaf's from its
//! primitives, an inner node's from its children's): on one thread, or on
//! the team with the same value at every node.

use super::tree::{Bvh, Cut};
use crate::parallel;

/// Fewest nodes worth folding on the team ([`Bvh::fold_up_shared`]). At
/// sphere-drape-30's 1,023 the shared cone fold cost more than it saved
/// (self-collision stage 0.177–0.179 s alone, 0.180–0.182 s shared, two
/// threads); at sphere-drape-100's 14,627 it takes the fold off the serial
/// path (docs/benchmarks.md 1af).
const FOLD_SHARED_MIN: usize = 1024;
/// Depth at which a shared fold cuts the tree: at most 32 subtrees, as
/// many as [`parallel::each`] hands out at once, and more than one a
/// thread, so a thread slow to start leaves its share to the others.
const CUT_DEPTH: u32 = 5;

impl Bvh {
    /// One value per node, computed bottom-up: `leaf(primitives)` at a
    /// leaf, `merge(left, right)` at an inner node; `out[k]` is node `k`'s.
    pub fn fold_up<T: Clone + Default>(
        &self,
        out: &mut Vec<T>,
        leaf: impl FnMut(&[u32]) -> T,
        merge: impl FnMut(&T, &T) -> T,
    ) {
        out.clear();
        out.resize(self.nodes.len(), T::default());
        self.fold_subtree(0, out, leaf, merge);
    }

    /// [`Bvh::fold_up`] on the team: the subtrees below the top levels
    /// each on one thread, then the nodes above them. Every node merges
    /// the same two values either way, so `out` is bit for bit the same
    /// whatever the thread count.
    pub fn fold_up_shared<T: Clone + Default + Send + Sync>(
        &self,
        out: &mut Vec<T>,
        leaf: impl Fn(&[u32]) -> T + Sync,
        merge: impl Fn(&T, &T) -> T + Sync,
    ) {
        if !parallel::sharing() || self.nodes.len() < FOLD_SHARED_MIN {
            return self.fold_up(out, leaf, merge);
        }
        out.clear();
        out.resize(self.nodes.len(), T::default());
        // The tree's topology never changes: cut once.
        let (roots, top) = self.cut.get_or_init(|| self.cut_at(CUT_DEPTH));
        // The subtrees' nodes are disjoint runs of `out`, in order.
        let (mut rest, mut at) = (out.as_mut_slice(), 0);
        let parts = roots.iter().map(|&(root, end)| {
            let (_, tail) = std::mem::take(&mut rest).split_at_mut(root - at);
            let (mine, tail) = tail.split_at_mut(end - root);
            (rest, at) = (tail, end);
            (root, mine)
        });
        parallel::each(parts, |(root, part)| {
            self.fold_subtree(root, part, &leaf, &merge);
        });
        for &k in top.iter().rev() {
            out[k] = merge(&out[k + 1], &out[self.nodes[k].start as usize]);
        }
    }

    /// Folds the subtree of node `root` into `out`, its nodes
    /// `root..root + out.len()` (depth-first order keeps a subtree's nodes
    /// together, children after their parent).
    fn fold_subtree<T>(
        &self,
        root: usize,
        out: &mut [T],
        mut leaf: impl FnMut(&[u32]) -> T,
        mut merge: impl FnMut(&T, &T) -> T,
    ) {
        for k in (0..out.len()).rev() {
            let n = &self.nodes[root + k];
            out[k] = if n.count > 0 {
                leaf(self.leaf(n))
            } else {
                merge(&out[k + 1], &out[n.start as usize - root])
            };
        }
    }

    /// The tree cut at `depth` (or at a leaf above it) into subtrees:
    /// their `(root, end)` node ranges, and the inner nodes above them,
    /// each list in depth-first order.
    fn cut_at(&self, depth: u32) -> Cut {
        let (mut roots, mut top) = (Vec::new(), Vec::new());
        let mut stack = vec![(0, 0)];
        while let Some((k, d)) = stack.pop() {
            let n = &self.nodes[k];
            if n.count > 0 || d == depth {
                roots.push((k, self.end(k)));
            } else {
                top.push(k);
                stack.push((n.start as usize, d + 1));
                stack.push((k + 1, d + 1));
            }
        }
        (roots, top)
    }

    /// One past the last node of node `k`'s subtree: the end of its
    /// rightmost leaf.
    fn end(&self, mut k: usize) -> usize {
        loop {
            let n = &self.nodes[k];
            if n.count > 0 {
                return k + 1;
            }
            k = n.start as usize;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tree::tests::random_boxes;
    use super::*;
    use rand::{SeedableRng, rngs::StdRng};

    /// The shared fold hands every node the values the serial fold does:
    /// an order-sensitive merge (a hash of the left then the right value)
    /// gives the same value at every node, on one thread and on two.
    #[test]
    fn a_shared_fold_is_the_serial_fold() {
        let mut rng = StdRng::seed_from_u64(5);
        let bvh = Bvh::build(&random_boxes(&mut rng, 3000));
        assert!(bvh.nodes.len() >= FOLD_SHARED_MIN);
        let leaf = |p: &[u32]| {
            p.iter()
                .fold(7u64, |h, &i| h.wrapping_mul(31) ^ u64::from(i))
        };
        let merge = |a: &u64, b: &u64| a.wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(17) ^ b;
        let mut serial = Vec::new();
        bvh.fold_up(&mut serial, leaf, merge);
        for threads in [1, 2, 3] {
            let mut shared = Vec::new();
            parallel::with_threads(threads, || bvh.fold_up_shared(&mut shared, leaf, merge));
            assert_eq!(shared, serial, "{threads} threads");
        }
    }
}
