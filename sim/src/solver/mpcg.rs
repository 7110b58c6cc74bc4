//! The modified preconditioned conjugate gradient (Baraff & Witkin 1998 §5;
//! method.md §2).
//!
//! Solves `A dv = b` for the free components only: `dv` starts at
//! `S g + (I - S) z` (a warm-start guess `g` in the free directions, the
//! targets `z` in the constrained ones) and every residual and search
//! direction is filtered by `S`, so the constrained components stay at `z`
//! while `A` stays symmetric.
//!
//! It stops when `|S (b - A dv)| <= tolerance * reference`, where the
//! reference defaults to `|S b|`; the step pipeline passes a reference that
//! does not vanish at equilibrium (see `integrator.rs`).
//!
//! A solve is [`start`]ed (the warm start's residual, which may already
//! meet the tolerance: then no preconditioner is needed at all) and then
//! [`iterate`]d. Vector operations run on [`crate::parallel`]'s
//! fixed chunks, so the result does not depend on the thread count.

use super::bsr::BlockCsr;
use super::constraints::Filter;
use super::precond::Preconditioner;
use crate::math::{Real, Vec3};
use crate::parallel::{self, dot};

/// Stopping rules.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MpcgOptions {
    /// Relative tolerance on the filtered residual.
    pub tolerance: Real,
    /// Iteration cap.
    pub max_iterations: usize,
    /// Norm the residual is measured against; `None` means `|S b|`.
    pub reference: Option<Real>,
}

impl MpcgOptions {
    /// The residual norm at which a solve of `problem` stops.
    pub fn threshold(&self, problem: &Problem<'_>) -> Real {
        self.tolerance * self.floor(problem)
    }

    /// The reference norm, kept away from zero so an all-zero system
    /// converges at once instead of dividing by zero.
    fn floor(&self, problem: &Problem<'_>) -> Real {
        self.reference
            .unwrap_or_else(|| filtered_norm(problem.b, problem.filter))
            .max(1e-300)
    }
}

/// How a solve ended (STYLE.md 8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SolveStatus {
    /// The residual met the tolerance.
    Converged,
    /// The iteration cap was reached first.
    MaxIterations,
    /// A non-positive or non-finite curvature `cᵀ A c`: `A` is not SPD on
    /// the free subspace or the data is not finite.
    Breakdown,
}

/// The outcome of one solve.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SolveReport {
    /// CG iterations taken.
    pub iterations: usize,
    /// Final filtered residual norm divided by the reference norm.
    pub residual: Real,
    /// How it ended.
    pub status: SolveStatus,
}

/// Scratch vectors, reused across solves.
#[derive(Debug, Clone, Default)]
pub struct MpcgWorkspace {
    r: Vec<Vec3>,
    c: Vec<Vec3>,
    q: Vec<Vec3>,
    s: Vec<Vec3>,
}

impl MpcgWorkspace {
    fn resize(&mut self, n: usize) {
        for v in [&mut self.r, &mut self.c, &mut self.q, &mut self.s] {
            v.resize(n, Vec3::zeros());
        }
    }
}

fn filter_in_place(s: &[Filter], v: &mut [Vec3]) {
    parallel::for_chunks(v, |start, chunk| {
        for (k, x) in chunk.iter_mut().enumerate() {
            *x = s[start + k].apply(x);
        }
    });
}

/// The system `A dv = b` with filters `S` and targets `z`.
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// The symmetric positive definite matrix.
    pub a: &'a BlockCsr,
    /// The right-hand side.
    pub b: &'a [Vec3],
    /// Per-particle filters `S_i`.
    pub filter: &'a [Filter],
    /// Targets `z_i` of the constrained directions.
    pub z: &'a [Vec3],
}

/// Starts a solve: puts `dv`'s constrained components at their targets
/// (keeping its free components as the warm start) and leaves the residual
/// `S (b - A dv)` in the workspace. Returns its norm.
pub fn start(problem: &Problem<'_>, dv: &mut [Vec3], ws: &mut MpcgWorkspace) -> Real {
    let Problem { a, b, filter: s, z } = *problem;
    ws.resize(b.len());
    parallel::for_chunks(dv, |start, chunk| {
        for (k, d) in chunk.iter_mut().enumerate() {
            let i = start + k;
            *d = s[i].apply(d) + z[i] - s[i].apply(&z[i]);
        }
    });
    a.mul(dv, &mut ws.q);
    let q = &ws.q;
    parallel::for_chunks(&mut ws.r, |start, chunk| {
        for (k, r) in chunk.iter_mut().enumerate() {
            let i = start + k;
            *r = s[i].apply(&(b[i] - q[i]));
        }
    });
    dot(&ws.r, &ws.r).sqrt()
}

/// Continues a [`start`]ed solve until the residual meets the options.
pub fn iterate(
    problem: &Problem<'_>,
    precond: &mut dyn Preconditioner,
    dv: &mut [Vec3],
    opts: &MpcgOptions,
    ws: &mut MpcgWorkspace,
) -> SolveReport {
    let Problem { a, filter: s, .. } = *problem;
    let floor = opts.floor(problem);
    let threshold = opts.tolerance * floor;
    let mut rnorm = dot(&ws.r, &ws.r).sqrt();
    let mut iterations = 0;
    let mut delta = Real::NAN;
    let status = loop {
        if !rnorm.is_finite() {
            break SolveStatus::Breakdown;
        }
        if rnorm <= threshold {
            break SolveStatus::Converged;
        }
        if iterations >= opts.max_iterations {
            break SolveStatus::MaxIterations;
        }
        precond.apply(a, s, &ws.r, &mut ws.s);
        filter_in_place(s, &mut ws.s);
        let delta_new = dot(&ws.r, &ws.s);
        if !delta_new.is_finite() {
            break SolveStatus::Breakdown;
        }
        // c = s + beta c (the first direction is s itself).
        let beta = if iterations == 0 {
            0.0
        } else {
            delta_new / delta
        };
        delta = delta_new;
        let sv = &ws.s;
        parallel::for_chunks(&mut ws.c, |start, chunk| {
            for (k, c) in chunk.iter_mut().enumerate() {
                *c = sv[start + k] + *c * beta;
            }
        });
        a.mul(&ws.c, &mut ws.q);
        filter_in_place(s, &mut ws.q);
        let curvature = dot(&ws.c, &ws.q);
        if curvature <= 0.0 || !curvature.is_finite() {
            break SolveStatus::Breakdown;
        }
        let alpha = delta / curvature;
        let (c, q) = (&ws.c, &ws.q);
        parallel::for_chunks2(dv, &mut ws.r, |start, d, r| {
            for k in 0..d.len() {
                d[k] += c[start + k] * alpha;
                r[k] -= q[start + k] * alpha;
            }
        });
        rnorm = dot(&ws.r, &ws.r).sqrt();
        iterations += 1;
    };
    SolveReport {
        iterations,
        residual: rnorm / floor,
        status,
    }
}

/// The constrained-system solve: [`start`] then [`iterate`]. `dv` holds
/// the warm-start guess on entry and the solution on return; the residual
/// `S (b - A dv)` is left in the workspace for [`residual`].
pub fn solve(
    problem: &Problem<'_>,
    precond: &mut dyn Preconditioner,
    dv: &mut [Vec3],
    opts: &MpcgOptions,
    ws: &mut MpcgWorkspace,
) -> SolveReport {
    start(problem, dv, ws);
    iterate(problem, precond, dv, opts, ws)
}

/// `|S v|`: the norm of `v` on the free directions.
pub fn filtered_norm(v: &[Vec3], s: &[Filter]) -> Real {
    parallel::sum(v.len(), |r| {
        v[r.clone()]
            .iter()
            .zip(&s[r])
            .map(|(v, f)| f.apply(v).norm_squared())
            .sum()
    })
    .sqrt()
}

/// The filtered residual `S (b - A dv)` of the last solve, per particle.
pub fn residual(ws: &MpcgWorkspace) -> &[Vec3] {
    &ws.r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat3;
    use crate::solver::precond::{BlockJacobi, Jacobi};
    use rand::{RngExt, SeedableRng, rngs::StdRng};

    /// A random SPD block matrix on a ring of `n` particles with neighbours
    /// up to distance 2, made diagonally dominant only weakly so CG has work.
    fn random_spd(n: usize, rng: &mut StdRng) -> BlockCsr {
        let pairs: Vec<(usize, usize)> = (0..n)
            .flat_map(|i| [(i, (i + 1) % n), (i, (i + 2) % n)])
            .collect();
        let mut a = BlockCsr::with_pattern(n, pairs.iter().copied());
        // Sum of random PSD "spring" terms k (e_i - e_j)(e_i - e_j)ᵀ ⊗ d dᵀ
        // plus a positive diagonal: SPD by construction.
        for &(i, j) in &pairs {
            let d = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            let k: f64 = rng.random_range(1.0..100.0);
            let m = d * d.transpose() * k;
            for (p, q, sign) in [(i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)] {
                let sl = a.slot(p, q).expect("in pattern");
                a.values[sl] += m * sign;
            }
        }
        for i in 0..n {
            let sl = a.diag_slot(i);
            a.values[sl] += Mat3::identity() * rng.random_range(0.01..1.0);
        }
        a
    }

    fn random_vec(n: usize, rng: &mut StdRng) -> Vec<Vec3> {
        (0..n)
            .map(|_| {
                Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
            })
            .collect()
    }

    #[test]
    fn converges_on_random_spd_systems_and_meets_tolerance() {
        let mut rng = StdRng::seed_from_u64(7);
        for trial in 0..20 {
            let n = 50 + trial * 10;
            let a = random_spd(n, &mut rng);
            let b = random_vec(n, &mut rng);
            let s = vec![Filter::Free; n];
            let z = vec![Vec3::zeros(); n];
            let precs: [Box<dyn Preconditioner>; 2] =
                [Box::<Jacobi>::default(), Box::<BlockJacobi>::default()];
            for mut p in precs {
                p.update(&a, &s);
                let mut x = vec![Vec3::zeros(); n];
                let opts = MpcgOptions {
                    tolerance: 1e-10,
                    max_iterations: 10 * 3 * n,
                    reference: None,
                };
                let rep = solve(
                    &Problem {
                        a: &a,
                        b: &b,
                        filter: &s,
                        z: &z,
                    },
                    p.as_mut(),
                    &mut x,
                    &opts,
                    &mut MpcgWorkspace::default(),
                );
                assert_eq!(
                    rep.status,
                    SolveStatus::Converged,
                    "trial {trial} {}",
                    p.name()
                );
                // The true residual, recomputed, meets the tolerance.
                let mut ax = vec![Vec3::zeros(); n];
                a.mul(&x, &mut ax);
                let r: f64 = ax
                    .iter()
                    .zip(&b)
                    .map(|(p, q)| (p - q).norm_squared())
                    .sum::<f64>()
                    .sqrt();
                let bn: f64 = b.iter().map(|v| v.norm_squared()).sum::<f64>().sqrt();
                assert!(
                    r <= 1.01e-10 * bn,
                    "trial {trial}: residual {r:e} vs {bn:e}"
                );
            }
        }
    }

    #[test]
    fn constrained_components_equal_targets_and_filtered_residual_meets_tolerance() {
        let mut rng = StdRng::seed_from_u64(11);
        let n = 80;
        let a = random_spd(n, &mut rng);
        let b = random_vec(n, &mut rng);
        let z = random_vec(n, &mut rng);
        let s: Vec<Filter> = (0..n)
            .map(|i| match i % 4 {
                0 => Filter::Free,
                1 => Filter::blocking(&[random_vec(1, &mut rng)[0]]),
                2 => Filter::blocking(&random_vec(2, &mut rng)),
                _ => Filter::Fixed,
            })
            .collect();
        let mut p = BlockJacobi::default();
        p.update(&a, &s);
        // A warm start that violates the constraints must be corrected.
        let mut x = random_vec(n, &mut rng);
        let opts = MpcgOptions {
            tolerance: 1e-9,
            max_iterations: 3000,
            reference: None,
        };
        let mut ws = MpcgWorkspace::default();
        let rep = solve(
            &Problem {
                a: &a,
                b: &b,
                filter: &s,
                z: &z,
            },
            &mut p,
            &mut x,
            &opts,
            &mut ws,
        );
        assert_eq!(rep.status, SolveStatus::Converged);
        for i in 0..n {
            let constrained = x[i] - s[i].apply(&x[i]);
            let target = z[i] - s[i].apply(&z[i]);
            if s[i] == Filter::Fixed {
                assert_eq!(x[i], z[i], "fixed particle {i} moved off its target");
            } else {
                assert!(
                    (constrained - target).norm() < 1e-12,
                    "particle {i}: {constrained:?} vs {target:?}"
                );
            }
        }
        // The filtered residual, recomputed from scratch, meets the tolerance.
        let mut ax = vec![Vec3::zeros(); n];
        a.mul(&x, &mut ax);
        let r: f64 = (0..n)
            .map(|i| s[i].apply(&(b[i] - ax[i])).norm_squared())
            .sum::<f64>()
            .sqrt();
        let sb: f64 = (0..n)
            .map(|i| s[i].apply(&b[i]).norm_squared())
            .sum::<f64>()
            .sqrt();
        assert!(r <= 1.01e-9 * sb, "filtered residual {r:e} vs {sb:e}");
        assert!(
            residual(&ws)
                .iter()
                .zip(&s)
                .all(|(r, f)| (f.apply(r) - r).norm() <= 1e-12 * sb)
        );
    }

    #[test]
    fn reports_breakdown_on_indefinite_matrix_and_max_iterations_at_cap() {
        let n = 10;
        let mut a = BlockCsr::with_pattern(n, []);
        for i in 0..n {
            let sl = a.diag_slot(i);
            a.values[sl] = Mat3::identity() * if i == 3 { -1.0 } else { 1.0 };
        }
        let b = vec![Vec3::new(1.0, 1.0, 1.0); n];
        let s = vec![Filter::Free; n];
        let z = vec![Vec3::zeros(); n];
        // Jacobi would flip the negative row positive; precondition with
        // the identity (Jacobi of I) so the indefiniteness is seen.
        let mut identity = BlockCsr::with_pattern(n, []);
        for i in 0..n {
            let sl = identity.diag_slot(i);
            identity.values[sl] = Mat3::identity();
        }
        let mut id = Jacobi::default();
        id.update(&identity, &s);
        let mut x = vec![Vec3::zeros(); n];
        let opts = MpcgOptions {
            tolerance: 1e-12,
            max_iterations: 100,
            reference: None,
        };
        let mut b2 = b.clone();
        b2[3] = Vec3::new(10.0, 10.0, 10.0);
        let rep = solve(
            &Problem {
                a: &a,
                b: &b2,
                filter: &s,
                z: &z,
            },
            &mut id,
            &mut x,
            &opts,
            &mut MpcgWorkspace::default(),
        );
        assert_eq!(rep.status, SolveStatus::Breakdown);

        let mut rng = StdRng::seed_from_u64(3);
        let a = random_spd(200, &mut rng);
        let b = random_vec(200, &mut rng);
        let mut p = Jacobi::default();
        p.update(&a, &s);
        let mut x = vec![Vec3::zeros(); 200];
        let opts = MpcgOptions {
            tolerance: 1e-14,
            max_iterations: 2,
            reference: None,
        };
        let s = vec![Filter::Free; 200];
        let z = vec![Vec3::zeros(); 200];
        let rep = solve(
            &Problem {
                a: &a,
                b: &b,
                filter: &s,
                z: &z,
            },
            &mut p,
            &mut x,
            &opts,
            &mut MpcgWorkspace::default(),
        );
        assert_eq!(rep.status, SolveStatus::MaxIterations);
        assert_eq!(rep.iterations, 2);
    }
}
