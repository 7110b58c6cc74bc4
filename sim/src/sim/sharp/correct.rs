//! The sharp-feature stage's correction after the solve: sweeps that move
//! pairs apart, then the freeze that ends every remaining meeting.

use super::stage::{HARD, Point, SharpStage};
use crate::collision::{Obstacles, StepFrame};
use crate::math::{Real, Vec3};
use crate::selfcollision::{Kind, Moving, closest};

/// Rounds of freezing before the stage gives up on pairs with pinned
/// particles (which neither move nor freeze).
const FREEZE_ROUNDS: usize = 64;
/// The continuous test's distance, as a share of the kept distance.
const PAD: Real = 0.1;
/// A shortfall below this share of the kept distance is left alone (a
/// chord resting against an edge lacks round-off every step).
const SLACK: Real = 1e-3;

impl SharpStage {
    /// Which way and how far a pair's cloth must move: `(n, c, short)`
    /// with `n` the direction from the feature to the cloth, `c` the
    /// weights of the pair's closest points and `short` the distance
    /// along `n` it lacks at the step's end; `None` if it lacks less than
    /// [`SLACK`] of `keep`.
    ///
    /// A pair that does not meet during the step (the continuous test) is
    /// on the side it started on, so its end closest points give the
    /// direction: a chord wrapping round an edge is pushed out where it
    /// ends, not back where it came from. A pair that meets takes the
    /// direction it had when it met (or at the start, if it met touching).
    pub(super) fn shortfall(kind: Kind, m: &Moving, keep: Real) -> Option<(Vec3, [Real; 4], Real)> {
        let (n, c, along) = match m.first_contact(kind, PAD * keep) {
            None => {
                let end = closest(kind, &m.at(1.0));
                let g = end.gap.norm();
                if g <= 0.0 {
                    return None;
                }
                (end.gap / g, end.c, g)
            }
            Some((_, met)) => {
                let g = met.gap.norm();
                let n = if g > 1e-3 * PAD * keep {
                    met.gap / g
                } else {
                    let start = closest(kind, &m.x).gap;
                    start.try_normalize(0.0)?
                };
                let end: Vec3 = (0..4).map(|k| (m.x[k] + m.d[k]) * met.c[k]).sum();
                (n, met.c, n.dot(&end))
            }
        };
        let short = keep - along;
        (short > SLACK * keep).then_some((n, c, short))
    }

    /// One sweep over every pair; returns how many were corrected.
    pub(super) fn sweep(&mut self, x0: &[Vec3], w: &[Real], h: Real) -> usize {
        let mut hits = 0;
        for kind in [Kind::VertexFace, Kind::EdgeEdge] {
            let count = match kind {
                Kind::VertexFace => self.vf.len(),
                Kind::EdgeEdge => self.ee.len(),
            };
            for p in 0..count {
                let (a, b) = match kind {
                    Kind::VertexFace => self.vf[p],
                    Kind::EdgeEdge => self.ee[p],
                };
                let (points, keep) = self.pair(kind, a, b);
                let m = self.moving(x0, &points);
                let Some((n, c, short)) = Self::shortfall(kind, &m, HARD * keep) else {
                    continue;
                };
                // Only the cloth moves: `Δx_k = c_k w_k J n`, with `J` so
                // that the pair moves apart by `short`, but no particle by
                // more than that (the cap of `selfcollision`'s impulses).
                let mut weight = 0.0;
                let mut reach: Real = 0.0;
                for (q, ck) in points.iter().zip(c) {
                    if let Point::Cloth(k) = q {
                        weight += ck * ck * w[*k as usize];
                        reach = reach.max(ck.abs() * w[*k as usize]);
                    }
                }
                if weight <= 0.0 {
                    continue;
                }
                let j = short / weight.max(reach);
                // The approach over the step, stopped: velocity.
                let approach = -n.dot(&(0..4).map(|k| m.d[k] * c[k]).sum::<Vec3>());
                let stop = (approach / short).clamp(0.0, 1.0) / h;
                for (q, ck) in points.iter().zip(c) {
                    if let Point::Cloth(k) = *q {
                        let dx = n * (ck * w[k as usize] * j);
                        self.end[k as usize] += dx;
                        self.velocity[k as usize] += dx * stop;
                    }
                }
                hits += 1;
            }
        }
        hits
    }

    /// Freezes the cloth particles of pairs that still meet to their
    /// obstacle's motion until none does; returns how many were frozen.
    pub(super) fn freeze(
        &mut self,
        obstacles: &Obstacles,
        frame: &StepFrame<'_>,
        x0: &[Vec3],
    ) -> usize {
        self.frozen.clear();
        self.frozen.resize(x0.len(), false);
        let mut count = 0;
        for _ in 0..FREEZE_ROUNDS {
            let mut grew = false;
            for kind in [Kind::VertexFace, Kind::EdgeEdge] {
                let list = match kind {
                    Kind::VertexFace => std::mem::take(&mut self.vf),
                    Kind::EdgeEdge => std::mem::take(&mut self.ee),
                };
                for &(a, b) in &list {
                    let (points, keep) = self.pair(kind, a, b);
                    let m = self.moving(x0, &points);
                    if m.first_contact(kind, PAD * keep).is_none() {
                        continue;
                    }
                    let corner = points.iter().find_map(|p| match p {
                        Point::Corner(k) => Some(*k as usize),
                        Point::Cloth(_) => None,
                    });
                    let Some(corner) = corner else { continue };
                    let t = &obstacles.colliders()[self.owner[corner] as usize].trajectory;
                    let (p0, p1) = (t.pose(frame.time), t.pose(frame.time + frame.h));
                    for p in &points {
                        let Point::Cloth(k) = *p else { continue };
                        let k = k as usize;
                        if self.frozen[k] || frame.pinned[k] {
                            continue;
                        }
                        let local = p0.inverse_transform_point(&x0[k].into());
                        self.end[k] = p1.transform_point(&local).coords;
                        self.frozen[k] = true;
                        count += 1;
                        grew = true;
                    }
                }
                match kind {
                    Kind::VertexFace => self.vf = list,
                    Kind::EdgeEdge => self.ee = list,
                }
            }
            if !grew {
                break;
            }
        }
        count
    }
}
