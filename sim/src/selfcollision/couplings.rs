//! Layers of cloth within the thickness of each other, held apart inside
//! the implicit solve: the response's first line, before the corrections
//! after it (`super::response`).
//!
//! Every pair of features (a vertex and a triangle, or two edges whose
//! closest points lie inside both) closer than the thickness at the
//! step's start becomes a [`Coupling`]: a one-sided spring of
//! `solver::coupling` along the pair's direction `n` there, on the four
//! particles with the weights `c` of the pair's closest points,
//!
//! ```text
//! E = 1/2 s (thickness - n · Σ c_k x_k)²,
//! ```
//!
//! so the solve itself moves the layers apart and the cloth's springs
//! share the work with it. Corrected only after the solve, the whole
//! overlap was taken from the particles of the pair while their
//! neighbours stayed behind: cloth wound tight on a spinning sphere
//! stretched 4–6 % (docs/benchmarks.md, section 1l).
//!
//! Grid neighbours are left to the cloth's own shear and bending forces,
//! as in the response.

use super::ccd::{Kind, closest};
use super::plan::Plan;
use super::topology::ClothMesh;
use crate::math::{Real, Vec3};
use crate::parallel;
use crate::solver::Coupling;

/// The couplings' stiffness in units of the pair's own inertia over a
/// step: `s = KAPPA m / h²`, with `m = 1 / Σ c_k² / m_k` the mass of the
/// pair's relative motion along `n`. In the solve a coupling then adds at
/// most `KAPPA` times that inertia, so it is never an outlier the
/// preconditioner (which sees only its diagonal blocks) must chase for
/// long, at any resolution or step; and a pressure of ten times the
/// cloth's weight sinks layers by `10 g h² / KAPPA` (0.1 mm at 1/240 s).
/// Measured (three start heights 0.1 µm apart each): cloth wound on a
/// spinning sphere (rotating-sphere with self-collision) stretched
/// 5.6 / 4.1 / 4.0 % with the response after the solve alone; 7.5 / 3.5 /
/// 4.9 % with `KAPPA` 1, 3.2 / 4.7 / 3.3 % with 4, 2.5 / 1.9 / 3.6 % with
/// 16, 1.9 / 1.5 / 2.2 % with 64; sphere-drape-30 with self-collision
/// took 3,080 CG iterations without couplings, 3,440 with 1, 4,310 with
/// 4, 5,390 with 16, 6,550 with 64.
pub const KAPPA: Real = 16.0;

/// Pairs a piece of the couplings' search takes: closest points of a
/// few hundred pairs are some microseconds, worth a core of their own,
/// and the pieces are many enough that both cores finish together (with
/// a thousand, one core waited on the other's last piece: sphere-drape-30
/// on two threads, self-collision 0.219 -> 0.205 s with this and the
/// plan's smaller filter pieces, docs/benchmarks.md 1r).
const PIECE: usize = 256;

/// The pairs' buffers and the couplings found per piece, reused across
/// steps.
#[derive(Debug, Clone, Default)]
pub struct Layers {
    vf: Vec<(u32, u32)>,
    ee: Vec<(u32, u32)>,
    pieces: Vec<Vec<Coupling>>,
}

impl Layers {
    /// Appends to `out` a coupling for every pair of `mesh` closer than
    /// `thickness` at `x0`, in the hierarchy's fixed order (the `plan`'s
    /// pairs if it holds), for a step of `h` of particles of masses
    /// `mass`.
    pub fn couple(
        &mut self,
        (mesh, plan): (&mut ClothMesh, &Plan),
        x0: &[Vec3],
        thickness: Real,
        mass: &[Real],
        h: Real,
        out: &mut Vec<Coupling>,
    ) {
        if !plan.pairs(mesh, (x0, x0), thickness, &mut self.vf, &mut self.ee) {
            mesh.refit(x0, x0, thickness);
            if !mesh.feature_pairs(&mut self.vf, &mut self.ee) {
                // Over the budget (`super::budget`): no couplings; the
                // response after the solve, over the same budget, holds
                // the cloth still and the step is redone in halves.
                self.vf.clear();
                self.ee.clear();
            }
        }
        // Pieces of fixed length, on the team, joined in order: the same
        // couplings whatever the number of threads.
        let mesh = &*mesh;
        let first = self.vf.len().div_ceil(PIECE);
        let pieces = first + self.ee.len().div_ceil(PIECE);
        self.pieces.resize_with(pieces, Vec::new);
        let (vf, ee) = (&self.vf, &self.ee);
        parallel::each(self.pieces.iter_mut().enumerate(), |(k, piece)| {
            piece.clear();
            let (kind, list, k) = if k < first {
                (Kind::VertexFace, vf, k)
            } else {
                (Kind::EdgeEdge, ee, k - first)
            };
            let end = ((k + 1) * PIECE).min(list.len());
            for &(a, b) in &list[k * PIECE..end] {
                let idx = mesh.particles(kind, a, b);
                if mesh.grid_neighbours(kind, &idx) {
                    continue;
                }
                let cl = closest(kind, &idx.map(|k| x0[k]));
                // An edge pair closest at an end is a vertex near a
                // triangle's edge: the vertex-face pairs hold it.
                if kind == Kind::EdgeEdge && cl.c.contains(&0.0) {
                    continue;
                }
                let g = cl.gap.norm();
                if g >= thickness || g <= 1e-12 * thickness {
                    continue;
                }
                let inverse_mass: Real = (0..4).map(|k| cl.c[k] * cl.c[k] / mass[idx[k]]).sum();
                piece.push(Coupling {
                    particles: idx.map(|k| k as u32),
                    weights: cl.c,
                    normal: cl.gap / g,
                    target: thickness,
                    stiffness: KAPPA / (inverse_mass * h * h),
                });
            }
        });
        for piece in &self.pieces[..pieces] {
            out.extend_from_slice(piece);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip folded flat onto itself at half the thickness: every
    /// particle of the upper layer away from the fold is held by its
    /// vertex–triangle pair below, pushed up (`n` along `+z`, the vertex
    /// weighing `+1`), toward the thickness; pairs across the fold (grid
    /// neighbours) are not coupled.
    #[test]
    fn a_folded_strip_couples_its_layers_upward() {
        let (nu, nv) = (12, 3);
        let grid = crate::testing::flat_grid(nu, nv, [1.1, 0.2]);
        let mut mesh = ClothMesh::new(&grid);
        let thickness = 0.01;
        let half = nu / 2;
        let x0: Vec<Vec3> = (0..nu * nv)
            .map(|k| {
                let (i, j) = (k % nu, k / nu);
                // Columns past the middle come back over the first half.
                let (u, z) = if i < half {
                    (i as Real, 0.0)
                } else {
                    ((nu - 1 - i) as Real, 0.5 * thickness)
                };
                Vec3::new(0.1 * u, 0.1 * j as Real, z)
            })
            .collect();
        let mut out = Vec::new();
        let h = 0.01;
        let plan = Plan::default();
        Layers::default().couple((&mut mesh, &plan), &x0, thickness, &grid.mass, h, &mut out);
        assert!(!out.is_empty());
        let mut upper = std::collections::BTreeSet::new();
        for c in &out {
            assert_eq!(c.target, thickness);
            // `KAPPA` times the pair's inertia over the step.
            let inverse: Real = (0..4)
                .map(|k| c.weights[k].powi(2) / grid.mass[c.particles[k] as usize])
                .sum();
            assert!((c.stiffness * inverse * h * h / KAPPA - 1.0).abs() < 1e-12);
            let sum: Real = c.weights.iter().sum();
            assert!(sum.abs() < 1e-12, "the pair's weights balance");
            // Every coupling pushes the upper layer up, the lower down.
            for (k, &p) in c.particles.iter().enumerate() {
                let up = x0[p as usize].z > 0.0;
                let push = c.weights[k] * c.normal.z;
                assert!(push == 0.0 || (push > 0.0) == up, "{c:?}");
                if push > 0.0 && c.weights[k] == 1.0 {
                    upper.insert(p);
                }
            }
            let cols = c.particles.map(|p| p as usize % nu);
            let (lo, hi) = (
                cols.iter().fold(nu, |a, &b| a.min(b)),
                cols.iter().fold(0, |a, &b| a.max(b)),
            );
            assert!(hi - lo > 1, "no grid neighbours");
        }
        // The upper layer's vertices not next to the fold (column `half`,
        // over column `half - 1`) are all held.
        let want: usize = (half + 1..nu).count() * nv;
        assert_eq!(upper.len(), want, "{upper:?}");
    }
}
