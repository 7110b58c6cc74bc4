//! The error rule's check along the cloth's rigid translations: a lower
//! bound of the error that the rule's two estimates cannot see, and the
//! coarse correction that removes it.
//!
//! Both estimates of `mod.rs` know only the modes CG's Krylov space has
//! found. A rigid translation of the free particles is barely stretched,
//! so under a block-diagonal or line preconditioner its eigenvalue is
//! about `m / (m + h² k)`: for a very stiff, light cloth (stretch and
//! shear 10⁹, 0.1 kg/m², 1/120 s) about 10⁻⁹, which tens of iterations
//! do not find. After such a cloth struck a sphere the solves stopped
//! with the whole cloth's velocity 7, later 67 m/s off, the step terms
//! estimating under a 700th of the error; the next step's warm start
//! carried it on, and the cloth flew off at 8,000 m/s²
//! (docs/benchmarks.md, 1ae).
//!
//! The residual's net force tells. For `Z` the filtered translations
//! `S [e_x e_y e_z]` and `E = Zᵀ (A + R) Z`, `A⁻¹ ⪰ Z E⁻¹ Zᵀ` (the
//! A-orthogonal projection on `Z`'s span), so
//!
//! ```text
//! |e|²_A = rᵀ (A + R)⁻¹ r ≥ (Zᵀ r)ᵀ E⁻¹ (Zᵀ r),   Zᵀ r = Σ_i r_i
//! ```
//!
//! (the residual is filtered already). When a stop is due and this bound
//! alone breaks the rule's bound, the solve takes the Galerkin correction
//! `dv += Z E⁻¹ Zᵀ r` — the best translation in the energy norm, after
//! which `Zᵀ r = 0` — and restarts CG from there, under the balancing
//! preconditioner of [`Translation::apply`] for the rest of the solve
//! (restarted under `P` alone, CG let the translations' error grow back
//! and was corrected and restarted every few iterations, up to the
//! iteration cap). Where the preconditioner handles translations, the
//! check never fires: on sphere-drape-30 the bound is at most a fortieth
//! of what it would need.

use super::super::bsr::BlockCsr;
use super::super::constraints::Filter;
use super::super::coupling::{self, Remote};
use super::super::precond::Preconditioner;
use crate::math::{Mat3, Real, Vec3};
use crate::parallel;

/// `E⁻¹` of one solve, built at its first check (`A`, the couplings and
/// the filters do not change within a solve), and the balancing
/// preconditioner a solve switches to once it has corrected along the
/// translations.
#[derive(Debug, Clone, Default)]
pub struct Translation {
    inverse: Option<Mat3>,
    /// `(A + R) Z` row by row, while the solve deflates.
    az: Vec<Mat3>,
    deflating: bool,
    scratch: Vec<Vec3>,
}

impl Translation {
    /// Forgets the last solve's operator.
    pub fn clear(&mut self) {
        self.inverse = None;
        self.deflating = false;
    }

    /// The correction `E⁻¹ Zᵀ r` if the lower bound `(Zᵀ r)ᵀ E⁻¹ (Zᵀ r)`
    /// of `|e|²_A` exceeds `allowed`; `None` if the stop may stand. `a`,
    /// `remote` and `filter` are the solve's (`super::Problem`). A
    /// correction also turns on [`Self::apply`] for the rest of the solve.
    pub fn correction(
        &mut self,
        (a, remote, filter): (&BlockCsr, &[Remote], &[Filter]),
        r: &[Vec3],
        allowed: Real,
    ) -> Option<Vec3> {
        let net = net(r);
        if net == Vec3::zeros() {
            return None;
        }
        let inverse = *self
            .inverse
            .get_or_insert_with(|| pseudo_inverse(&operator(a, remote, filter)));
        let c = inverse * net;
        if net.dot(&c) <= allowed {
            return None;
        }
        if !self.deflating {
            self.deflating = true;
            rows(a, remote, filter, &mut self.az);
        }
        Some(c)
    }

    /// Whether the solve has switched to [`Self::apply`].
    pub fn deflating(&self) -> bool {
        self.deflating
    }

    /// The balancing preconditioner (Mandel's BNN; Tang et al. 2009,
    /// "Comparison of two-level preconditioners derived from deflation,
    /// domain decomposition and multigrid methods"):
    ///
    /// ```text
    /// s = (I − Q A) P⁻¹ (I − A Q) r + Q r,   Q = Z E⁻¹ Zᵀ
    /// ```
    ///
    /// SPD whenever `P` is. The translations' eigenvalue becomes 1 and
    /// the others are those of the deflated `P⁻¹A`, whose effective
    /// condition is no worse than `P⁻¹A`'s (Nabben & Vuik 2004): CG no
    /// longer loses the translations. It costs four passes
    /// over the particles an iteration beyond `P`, so a solve pays it only
    /// once its translations needed a correction. Leaves `S s` in `out`
    /// and returns `rᵀ s`, as [`Preconditioner::apply_filtered`] does.
    pub fn apply(
        &mut self,
        precond: &mut dyn Preconditioner,
        (a, filter): (&BlockCsr, &[Filter]),
        r: &[Vec3],
        out: &mut [Vec3],
    ) -> Real {
        let inverse = self.inverse.unwrap_or_default();
        let c1 = inverse * net(r);
        let az = &self.az;
        self.scratch.resize(r.len(), Vec3::zeros());
        parallel::for_chunks(&mut self.scratch, |start, chunk| {
            for (k, t) in chunk.iter_mut().enumerate() {
                *t = r[start + k] - az[start + k] * c1;
            }
        });
        precond.apply_filtered(a, filter, &self.scratch, out);
        let back = parallel::sum_of(out.len(), Vec3::zeros(), |range| {
            let start = range.start;
            out[range]
                .iter()
                .enumerate()
                .fold(Vec3::zeros(), |m, (k, s)| m + az[start + k].tr_mul(s))
        });
        let shift = c1 - inverse * back;
        parallel::update_sum(out, |start, chunk| {
            chunk
                .iter_mut()
                .enumerate()
                .map(|(k, s)| {
                    *s += filter[start + k].apply(&shift);
                    s.dot(&r[start + k])
                })
                .sum()
        })
    }
}

/// `Zᵀ r = Σ_i r_i` of a filtered `r`.
fn net(r: &[Vec3]) -> Vec3 {
    parallel::sum_of(r.len(), Vec3::zeros(), |range| {
        r[range].iter().fold(Vec3::zeros(), |s, r| s + r)
    })
}

/// `(A + R) Z` row by row: `S_i Σ_j A_ij S_j`, plus the couplings'.
fn rows(a: &BlockCsr, remote: &[Remote], filter: &[Filter], out: &mut Vec<Mat3>) {
    out.resize(a.rows(), Mat3::zeros());
    parallel::for_chunks_min(out, parallel::ROWS_MIN, |start, chunk| {
        for (k, w) in chunk.iter_mut().enumerate() {
            let i = start + k;
            let row = a.row(i).fold(Mat3::zeros(), |row, (j, b)| {
                row + match filter[j] {
                    Filter::Free => *b,
                    f => columns(&f, &b.transpose()).transpose(),
                }
            });
            *w = columns(&filter[i], &row);
        }
    });
    for (k, block) in coupling::translation_blocks(remote, |k, v| filter[k].apply(v)) {
        out[k] += block;
    }
}

/// `E = Zᵀ (A + R) Z = Σ_ij S_i A_ij S_j + Σ_remote S_k (coef n nᵀ) S_l`:
/// the sum of every block of `A`, corrected where a filter is not the
/// identity (`A` is symmetric: the blocks of a constrained particle's
/// column are its row's, transposed).
fn operator(a: &BlockCsr, remote: &[Remote], filter: &[Filter]) -> Mat3 {
    let values = &a.values;
    let all = parallel::sum_of(values.len(), Mat3::zeros(), |range| {
        // PERF: four sums side by side, so the additions do not wait on
        // each other.
        let blocks = &values[range];
        let mut lanes = [Mat3::zeros(); 4];
        let mut quads = blocks.chunks_exact(4);
        for quad in &mut quads {
            for (lane, b) in lanes.iter_mut().zip(quad) {
                *lane += b;
            }
        }
        let rest = quads.remainder().iter().fold(Mat3::zeros(), |e, b| e + b);
        lanes.iter().fold(rest, |e, lane| e + lane)
    });
    let mut correction = Mat3::zeros();
    for (j, f) in filter
        .iter()
        .enumerate()
        .filter(|(_, f)| **f != Filter::Free)
    {
        for (k, b) in a.row(j) {
            // S_j b, then (S_j b) S_k = (S_k (S_j b)ᵀ)ᵀ.
            let sb = columns(f, b);
            if filter[k] == Filter::Free {
                // And the block (k, j) = bᵀ of a free row k: bᵀ S_j.
                correction += sb - b + sb.transpose() - b.transpose();
            } else {
                correction += columns(&filter[k], &sb.transpose()).transpose() - b;
            }
        }
    }
    coupling::translation_blocks(remote, |k, v| filter[k].apply(v))
        .fold(all + correction, |e, (_, block)| e + block)
}

/// `S m`, the filter applied to each column of `m`.
fn columns(f: &Filter, m: &Mat3) -> Mat3 {
    Mat3::from_columns(&[
        f.apply(&m.column(0).into()),
        f.apply(&m.column(1).into()),
        f.apply(&m.column(2).into()),
    ])
}

/// The inverse of `E` on its range: translations that every particle
/// blocks (a cloth pinned or lying on a plane) have no error to correct.
fn pseudo_inverse(e: &Mat3) -> Mat3 {
    let eigen = nalgebra::SymmetricEigen::new((e + e.transpose()) * 0.5);
    let top = eigen.eigenvalues.max();
    let mut inverse = Mat3::zeros();
    for (k, &l) in eigen.eigenvalues.iter().enumerate() {
        if l > RANGE * top {
            let q = eigen.eigenvectors.column(k);
            inverse += q * q.transpose() / l;
        }
    }
    inverse
}

/// Eigenvalues of `E` below this share of its largest are taken as zero.
const RANGE: Real = 1e-12;

#[cfg(test)]
mod tests {
    use super::super::super::precond::BlockJacobi;
    use super::super::tests::{random_spd, random_vec3};
    use super::*;
    use rand::{SeedableRng, rngs::StdRng};

    /// A random SPD block matrix (`mpcg::tests::random_spd`) and filters
    /// of every kind.
    fn system(n: usize, rng: &mut StdRng) -> (BlockCsr, Vec<Filter>) {
        let a = random_spd(n, rng);
        let filter = (0..n)
            .map(|i| match i % 5 {
                0 => Filter::Plane(random_vec3(rng).normalize()),
                1 => Filter::Line(random_vec3(rng).normalize()),
                2 => Filter::Fixed,
                _ => Filter::Free,
            })
            .collect();
        (a, filter)
    }

    /// The block sum with its corrections is `Σ_ij S_i A_ij S_j` computed
    /// block by block, on a symmetric matrix with every kind of filter.
    #[test]
    fn the_operator_is_the_filtered_sum_of_the_blocks() {
        let mut rng = StdRng::seed_from_u64(3);
        let (a, filter) = system(50, &mut rng);
        let mut direct = Mat3::zeros();
        for i in 0..a.rows() {
            for (j, b) in a.row(i) {
                direct += filter[i].matrix() * b * filter[j].matrix();
            }
        }
        let got = operator(&a, &[], &filter);
        assert!(
            (got - direct).norm() <= 1e-12 * direct.norm(),
            "{got} against {direct}"
        );
    }

    /// The balancing preconditioner `B` is symmetric on the filtered
    /// space and inverts `A` exactly on the translations: `B A Z c = Z c`.
    #[test]
    fn the_balancing_preconditioner_is_symmetric_and_exact_on_translations() {
        let mut rng = StdRng::seed_from_u64(11);
        let n = 60;
        let (a, filter) = system(n, &mut rng);
        let filtered = |rng: &mut StdRng| -> Vec<Vec3> {
            filter.iter().map(|f| f.apply(&random_vec3(rng))).collect()
        };
        let mut precond = BlockJacobi::default();
        precond.update(&a, &filter);
        let mut t = Translation::default();
        let r = filtered(&mut rng);
        assert!(t.correction((&a, &[], &filter), &r, 0.0).is_some());
        assert!(t.deflating());
        let mut apply = |v: &[Vec3]| {
            let mut out = vec![Vec3::zeros(); n];
            t.apply(&mut precond, (&a, &filter), v, &mut out);
            out
        };
        let (u, v) = (filtered(&mut rng), filtered(&mut rng));
        let (bu, bv) = (apply(&u), apply(&v));
        let dot = |p: &[Vec3], q: &[Vec3]| p.iter().zip(q).map(|(p, q)| p.dot(q)).sum::<Real>();
        let (ubv, vbu) = (dot(&u, &bv), dot(&v, &bu));
        assert!(
            (ubv - vbu).abs() <= 1e-12 * ubv.abs().max(1.0),
            "{ubv} against {vbu}"
        );
        assert!(dot(&u, &bu) > 0.0);
        let c = Vec3::new(0.3, -1.2, 0.7);
        let zc: Vec<Vec3> = filter.iter().map(|f| f.apply(&c)).collect();
        let mut azc = vec![Vec3::zeros(); n];
        a.mul(&zc, &mut azc);
        let azc: Vec<Vec3> = azc.iter().zip(&filter).map(|(v, f)| f.apply(v)).collect();
        let back = apply(&azc);
        let err = back
            .iter()
            .zip(&zc)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, Real::max);
        assert!(err <= 1e-10, "B A Z c off Z c by {err}");
    }

    /// The pseudo-inverse inverts on the range and drops a blocked
    /// direction.
    #[test]
    fn the_pseudo_inverse_drops_blocked_translations() {
        let e = Mat3::from_diagonal(&Vec3::new(2.0, 4.0, 0.0));
        let inverse = pseudo_inverse(&e);
        assert!((inverse - Mat3::from_diagonal(&Vec3::new(0.5, 0.25, 0.0))).norm() < 1e-15);
    }
}
