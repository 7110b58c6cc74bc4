//! The symmetric line sweep as one flow of stages on the team
//! ([`parallel::Flow`]) rather than a loop per colour:
//!
//! ```text
//! warp forward (from x = 0), weft forward, weft backward, warp backward
//! ```
//!
//! seven stages with two colours a family (the backward weft sweep skips
//! the colour the forward one ended with). Within a family's run of
//! stages a pack waits only for the packs near it ([`near`])
//! in the run's earlier stages: those whose lines it reads, and those
//! that read the lines it writes. The first stage of a run waits for
//! every stage before it, as each line of one family crosses every line
//! of the other. Bit for bit the sweeps one after another.

use super::grid_matrix::Vec3f;
use super::lanes::ZERO_VEC;
use super::lines::{Entry, LineFamily, LineScratch};
use crate::parallel::{self, Disjoint};
use std::ops::Range;

/// The packs of colour `colour` whose lines pack `pack` reads, or which
/// read the lines it writes: those with a line within the sweep's reach
/// of one of its own (in its own colour, itself; none, an empty range at
/// the colour's start).
fn near(family: &LineFamily, pack: usize, colour: usize) -> Range<usize> {
    let (reach, lines) = family.reach();
    let (mut lo, mut hi) = (usize::MAX, 0);
    for line in family.lines_in(pack) {
        for other in line.saturating_sub(reach)..(line + reach + 1).min(lines) {
            let (p, c) = family.pack_of(other);
            if c == colour {
                (lo, hi) = (lo.min(p), hi.max(p + 1));
            }
        }
    }
    if lo > hi {
        let none = family.packs(colour).start;
        none..none
    } else {
        lo..hi
    }
}

/// Most stages a symmetric sweep has: four sweeps of at most three
/// colours (`LineFamily::new`'s reach is at most 2).
const MAX_STAGES: usize = 12;

/// `x` (zero on entry) becomes the symmetric sweep of `b`: `warp`
/// forward, `weft` forward, `weft` backward, `warp` backward.
pub fn symmetric_sweep(
    warp: &LineFamily,
    weft: &LineFamily,
    b: &[Vec3f],
    x: &mut [Vec3f],
    scratch: &mut LineScratch,
) {
    let families = [warp, weft];
    // The stages in order: family, colour, and whether it reads x.
    let mut stages = [(0, 0, false); MAX_STAGES];
    let mut counts = [0; MAX_STAGES];
    let mut n = 0;
    let sweeps = [
        (0, true, Entry::Zero),
        (1, true, Entry::Any),
        (1, false, Entry::AfterReverse),
        (0, false, Entry::Any),
    ];
    for (f, forward, entry) in sweeps {
        for (colour, coupled) in families[f].order(forward, entry) {
            stages[n] = (f, colour, coupled);
            counts[n] = families[f].packs(colour).len();
            n += 1;
        }
    }
    let (stages, counts) = (&stages[..n], &counts[..n]);
    // Each pack's own buffer: the two families' packs share the space,
    // never at once (a family's first stage waits for all before it).
    let buffers = warp.buffers().1.max(weft.buffers().1);
    scratch.packs.resize(buffers, ZERO_VEC);
    let spread = stages.iter().all(|&(f, c, _)| families[f].spread(c));
    let run_start = |k: usize| {
        (0..k)
            .rev()
            .take_while(|&j| stages[j].0 == stages[k].0)
            .last()
            .unwrap_or(k)
    };
    let packs = Disjoint::new(&mut scratch.packs);
    let shared = Disjoint::new(x);
    parallel::in_stages(
        &mut scratch.flow,
        counts,
        if spread { 0 } else { usize::MAX },
        |k, i, wait| {
            let (f, colour, _) = stages[k];
            let family = families[f];
            let pack = family.packs(colour).start + i;
            let start = run_start(k);
            if start == k {
                for (j, &count) in counts[..k].iter().enumerate() {
                    wait(j, 0..count);
                }
                return;
            }
            for (j, &(_, other, _)) in stages.iter().enumerate().take(k).skip(start) {
                let first = family.packs(other).start;
                let near = near(family, pack, other);
                wait(j, near.start - first..near.end - first);
            }
        },
        |k, i| {
            let (f, colour, coupled) = stages[k];
            let family = families[f];
            let pack = family.packs(colour).start + i;
            let len = family.buffers().0;
            // SAFETY: a pack's buffer is its own; the other family's
            // packs, which share the space, are all done before this
            // family's run starts, or start after it ends (above).
            #[allow(unsafe_code)]
            let out = unsafe { packs.slice(pack * len..(pack + 1) * len) };
            family.relax_pack(pack, b, &shared, coupled, out);
        },
    );
}

#[cfg(test)]
mod tests {
    use super::super::grid_matrix::{Block, GridMatrix};
    use super::super::lines::Direction;
    use super::*;
    use crate::parallel::with_threads;

    /// A symmetric grid matrix with the cloth's stencil (bending's reach
    /// of two along the lines, shear's diagonals), diagonally dominant.
    fn cloth_like(nu: usize, nv: usize) -> GridMatrix {
        let offsets: Vec<(i32, i32)> = (-2..=2)
            .flat_map(|dj| (-2..=2).map(move |di| (di, dj)))
            .filter(|&(di, dj): &(i32, i32)| di.abs() + dj.abs() <= 2)
            .collect();
        let mut a = GridMatrix::new(nu, nv, offsets);
        for p in 0..nu * nv {
            let (i, j) = (p % nu, p / nu);
            for k in 0..a.offsets().len() {
                let Some(q) = a.neighbour(i, j, k) else {
                    continue;
                };
                let (di, dj) = a.offsets()[k];
                // Symmetric: the block of (p, q) depends on the pair only.
                let s = ((p.min(q) * 7 + p.max(q) * 3) % 11) as f32 * 0.01;
                a.row_mut(p)[k] = if (di, dj) == (0, 0) {
                    Block::from_diagonal(&Vec3f::new(9.0, 8.0, 7.0))
                } else {
                    Block::new(-0.4 - s, s, 0.0, s, -0.3, 0.05, 0.0, 0.05, -0.2 + s)
                };
            }
        }
        a
    }

    /// Near packs: on a 40-line family of two colours, a pack's own and
    /// the other colour's beside it; in a colour with no lines (two lines,
    /// three colours), an empty range at that colour's start.
    #[test]
    fn near_packs_are_those_beside_and_none_is_empty_at_its_colour() {
        let family = LineFamily::new(Direction::V, &cloth_like(40, 36), 1);
        // Colour 0 holds lines 0, 2, ..., 38 in packs of four; pack 1 is
        // lines 8-14, beside lines 7-15 of colour 1 (its packs 0 and 1).
        let (first0, first1) = (family.packs(0).start, family.packs(1).start);
        assert_eq!(near(&family, first0 + 1, 0), first0 + 1..first0 + 2);
        assert_eq!(near(&family, first0 + 1, 1), first1..first1 + 2);
        let narrow = LineFamily::new(Direction::V, &cloth_like(2, 12), 2);
        let empty = narrow.packs(2).start;
        assert!(narrow.packs(2).is_empty());
        assert_eq!(near(&narrow, 0, 2), empty..empty);
    }

    /// The flow gives the four sweeps' `x` bit for bit, with two colours
    /// a family and with three, on teams of one to three threads.
    #[test]
    fn the_flow_gives_the_four_sweeps_bit_for_bit() {
        let (nu, nv) = (40, 36);
        let a = cloth_like(nu, nv);
        let b: Vec<Vec3f> = (0..nu * nv)
            .map(|k| Vec3f::new((k as f32 * 0.37).sin(), 1.0, (k % 5) as f32 - 2.0))
            .collect();
        for reach in [1, 2] {
            let warp = LineFamily::new(Direction::U, &a, reach);
            let weft = LineFamily::new(Direction::V, &a, reach);
            assert!((0..reach + 1).all(|c| warp.spread(c) && weft.spread(c)));
            let mut s = LineScratch::default();
            let mut want = vec![Vec3f::zeros(); nu * nv];
            with_threads(1, || {
                warp.sweep(&b, &mut want, true, Entry::Zero, &mut s);
                weft.sweep(&b, &mut want, true, Entry::Any, &mut s);
                weft.sweep(&b, &mut want, false, Entry::AfterReverse, &mut s);
                warp.sweep(&b, &mut want, false, Entry::Any, &mut s);
            });
            for threads in [1, 2, 3] {
                with_threads(threads, || {
                    for _ in 0..40 {
                        let mut x = vec![Vec3f::zeros(); nu * nv];
                        symmetric_sweep(&warp, &weft, &b, &mut x, &mut s);
                        let same = x.iter().zip(&want).all(|(u, v)| {
                            u.iter()
                                .zip(v.iter())
                                .all(|(p, q)| p.to_bits() == q.to_bits())
                        });
                        assert!(same, "reach {reach}, {threads} threads");
                    }
                });
            }
        }
    }
}
