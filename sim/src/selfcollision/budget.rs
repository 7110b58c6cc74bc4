//! How many candidate pairs one gather may hold: the bound on the memory a
//! step's self-collision can take, whatever the scene.
//!
//! Candidate pairs are those whose boxes over the step's motion overlap.
//! A drape holds a few per particle (0.4–2.9 on the example scenes, 50 at
//! the crumpled start of the stress suite), but a cloth thrown across
//! itself by many spacings in one step holds hundreds (a 60² silk under
//! 950 m/s² wrapping a small sphere at 1/30 s: 1.26 million pairs, 350 a
//! particle, per query and dozens of queries a step), and the count grows
//! as the square of the motion over the spacing: at the service's largest
//! cloth, tens of gigabytes. A gather that passes [`PAIRS_PER_PARTICLE`]
//! a particle stops adding pairs and says so; the step then holds the
//! cloth still (`response`), and the driver redoes it in halves, whose
//! motions are shorter.
//!
//! Whether a gather passed the budget does not depend on the thread
//! count: its pieces add what they found to one tally, a piece stops only
//! once the tally is over the budget (so the whole gather is), and a
//! gather that never stops sums every pair.

use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// Candidate pairs a gather may hold per particle (8 bytes each).
pub const PAIRS_PER_PARTICLE: usize = 128;

/// The budget's floor, pairs: small cloths never reach it.
const FLOOR: usize = 1 << 16;

/// Pairs a piece finds before it adds them to the tally.
const FLUSH: usize = 4096;

/// The budget of a cloth of `particles`.
pub fn of_particles(particles: usize) -> usize {
    particles.saturating_mul(PAIRS_PER_PARTICLE).max(FLOOR)
}

/// One gather's count of pairs, shared by its pieces.
#[derive(Debug)]
pub struct Tally {
    total: AtomicUsize,
    budget: usize,
}

impl Tally {
    /// A gather that may hold `budget` pairs.
    pub fn new(budget: usize) -> Self {
        Self {
            total: AtomicUsize::new(0),
            budget,
        }
    }

    /// A piece's counter.
    pub fn counter(&self) -> Counter<'_> {
        Counter {
            tally: self,
            unflushed: 0,
            over: false,
        }
    }

    /// Whether every pair was gathered (the pieces' counters dropped).
    pub fn complete(&self) -> bool {
        self.total.load(Relaxed) <= self.budget
    }
}

/// A piece's count, added to its tally every [`FLUSH`] pairs and when
/// dropped.
#[derive(Debug)]
pub struct Counter<'a> {
    tally: &'a Tally,
    unflushed: usize,
    over: bool,
}

impl Counter<'_> {
    /// Counts `n` pairs found; returns whether the piece should stop.
    #[inline]
    pub fn add(&mut self, n: usize) -> bool {
        self.unflushed += n;
        if self.unflushed >= FLUSH {
            self.flush();
        }
        self.over
    }

    /// Whether the gather is over its budget, as far as this piece knows
    /// (checked against the tally).
    pub fn over(&mut self) -> bool {
        self.over = self.over || self.tally.total.load(Relaxed) > self.tally.budget;
        self.over
    }

    fn flush(&mut self) {
        let n = std::mem::take(&mut self.unflushed);
        let total = self.tally.total.fetch_add(n, Relaxed) + n;
        self.over = self.over || total > self.tally.budget;
    }
}

impl Drop for Counter<'_> {
    fn drop(&mut self) {
        self.flush();
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Hold, SelfCollision, topology::ClothMesh};
    use super::*;
    use crate::math::{Real, Vec3};
    use crate::solver::ClothState;
    use rand::{RngExt, SeedableRng, rngs::StdRng};

    /// Pieces that add up to the budget complete; one pair more does not,
    /// and a piece stops once the tally passes the budget, not before.
    #[test]
    fn a_gather_completes_exactly_up_to_its_budget() {
        let budget = 3 * FLUSH;
        for (found, complete) in [(budget, true), (budget + 1, false)] {
            let tally = Tally::new(budget);
            let mut stopped_early = false;
            std::thread::scope(|s| {
                for k in 0..3 {
                    let tally = &tally;
                    let h = s.spawn(move || {
                        let mut c = tally.counter();
                        let mine = found / 3 + usize::from(k < found % 3);
                        (0..mine).any(|_| c.add(1))
                    });
                    stopped_early |= h.join().unwrap_or(true);
                }
            });
            assert_eq!(tally.complete(), complete, "{found} pairs");
            if complete {
                assert!(!stopped_early);
            }
        }
        assert_eq!(of_particles(10), FLOOR);
        assert_eq!(of_particles(1 << 20), PAIRS_PER_PARTICLE << 20);
    }

    /// A 12² cloth whose particles each move up to five spacings at
    /// random: the motion that crowds a gather.
    fn thrown() -> (crate::cloth::Grid, Vec<Vec3>) {
        let grid = crate::testing::flat_grid(12, 12, [1.0, 1.0]);
        let mut rng = StdRng::seed_from_u64(7);
        let reach = 5.0 / 11.0;
        let moved = (0..grid.len())
            .map(|_| Vec3::from_fn(|_, _| reach * rng.random_range(-1.0..1.0)))
            .collect();
        (grid, moved)
    }

    /// A gather completes with exactly its pairs in budget and the same
    /// lists as without a budget; with one pair fewer it says it did not,
    /// and holds no more than the budget and a piece's flush a thread.
    #[test]
    fn a_gather_stops_past_its_budget() {
        let (grid, moved) = thrown();
        let x1: Vec<Vec3> = grid.rest.iter().zip(&moved).map(|(x, d)| x + d).collect();
        let mut mesh = ClothMesh::new(&grid);
        mesh.refit(&grid.rest, &x1, 0.01);
        let (mut vf, mut ee) = (Vec::new(), Vec::new());
        mesh.pair_budget = usize::MAX;
        assert!(mesh.feature_pairs(&mut vf, &mut ee));
        let all = vf.len() + ee.len();
        assert!(all > 4 * FLUSH, "{all} pairs: not crowded");
        let (mut vf2, mut ee2) = (Vec::new(), Vec::new());
        mesh.pair_budget = all;
        assert!(mesh.feature_pairs(&mut vf2, &mut ee2));
        assert_eq!((vf, ee), (vf2, ee2));
        let (mut vf3, mut ee3) = (Vec::new(), Vec::new());
        mesh.pair_budget = all - 1;
        assert!(!mesh.feature_pairs(&mut vf3, &mut ee3));
        mesh.pair_budget = all / 4;
        assert!(!mesh.feature_pairs(&mut vf3, &mut ee3));
        let held = vf3.len() + ee3.len();
        let most = all / 4 + crate::parallel::threads() * (FLUSH + 64);
        assert!(held <= most, "{held} pairs held, budget {}", all / 4);
    }

    /// Over its budget, a resolution tests no pair: the cloth is held
    /// where the step began and the report says why.
    #[test]
    fn a_crowded_step_holds_the_cloth_still() {
        let (grid, moved) = thrown();
        let h: Real = 0.01;
        let mut sc = SelfCollision::new(&grid, 0.005);
        sc.mesh.pair_budget = 1000;
        let x0 = grid.rest.clone();
        let mut state = ClothState {
            time: 0.0,
            x: x0.iter().zip(&moved).map(|(x, d)| x + d).collect(),
            v: moved.iter().map(|d| d / h).collect(),
        };
        let mut motion = moved.clone();
        let held = vec![Hold::Free; grid.len()];
        let report = sc.resolve(&x0, &grid.mass, &held, h, &mut state, &mut motion);
        assert!(report.over_budget && report.failsafe);
        assert_eq!(state.x, x0);
        assert!(motion.iter().all(|d| *d == Vec3::zeros()));
    }
}
