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
//! does not vanish at equilibrium (see `integrator.rs`). Given an
//! `error_bound` it also stops as soon as its error in the energy norm is
//! estimated below that bound. With `A e = r` and `P⁻¹A ≥ λ_min`,
//!
//! ```text
//! |e|²_A = rᵀ A⁻¹ r ≤ rᵀ P⁻¹ r / λ_min = δ / λ_min
//! ```
//!
//! where `δ = rᵀ P⁻¹ r` is the quantity CG computes anyway, and
//! `λ_min(P⁻¹A)` is estimated by the smallest Ritz value of CG's Lanczos
//! tridiagonal ([`ritz`]), which falls toward it from above. Late in a
//! solve the error lies mostly along the slowest modes, where the bound is
//! nearly an equality. Because a Ritz value overestimates `λ_min` early
//! on, the rule waits for [`MIN_RITZ`] iterations and asks twice the
//! estimate's norm to meet the bound.
//!
//! A second estimate stops a solve too, whichever fires first: CG's step
//! terms `t_j = α_j δ_j = |dv_{j+1} - dv_j|²_A` sum to the error, `|e_k|²_A
//! = Σ_{j ≥ k} t_j` (Strakoš & Tichý 2002), so the last [`DELAY`] terms
//! bound the error `DELAY` iterations back from below; twice its norm
//! must meet the bound. Alone it stops about four iterations after the
//! error has met the bound (a quarter of a solve on sphere-drape-30), but
//! where hundreds of contacts spread the residual over fast modes `δ /
//! λ_min` overstates the error and the step terms fire first (pedestal-mesh:
//! 16,512 CG iterations with the Ritz bound alone, 13,755 with both). On
//! ill-conditioned random systems under block Jacobi the iterate that
//! either estimate returns alone stays within the bound (`tests.rs`).
//!
//! Neither estimate sees a mode CG has not found yet, and a stiff, light
//! cloth's rigid translation can hide from it for hundreds of iterations;
//! before either stops a solve, the residual's net force bounds the error
//! along the translations from below, and where that alone breaks the
//! bound the solve corrects along them and restarts, deflating them from
//! then on ([`translation`]).
//!
//! A solve is [`start`]ed (the warm start's residual, which may already
//! meet the tolerance: then no preconditioner is needed at all) and then
//! [`iterate`]d. Vector operations run on [`crate::parallel`]'s
//! fixed chunks, so the result does not depend on the thread count.

use super::bsr::BlockCsr;
use super::constraints::{Filter, filter_and_dot};
use super::coupling::{self, Remote};
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
    /// Stop also once the error's energy norm `|e|_A` is estimated below
    /// this; `None`: the residual rule alone.
    pub error_bound: Option<Real>,
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

/// Iterations before the error rule may stop a solve: the Ritz value of a
/// one- or two-dimensional Krylov space is too far above `λ_min`.
const MIN_RITZ: usize = 3;

/// Step terms summed into the second estimate (Strakoš & Tichý's delay).
const DELAY: usize = 4;

mod ritz;
mod translation;

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
    lanczos: ritz::Lanczos,
    translation: translation::Translation,
}

impl MpcgWorkspace {
    fn resize(&mut self, n: usize) {
        for v in [&mut self.r, &mut self.c, &mut self.q, &mut self.s] {
            v.resize(n, Vec3::zeros());
        }
    }
}

/// The system `(A + R) dv = b` with filters `S` and targets `z`.
#[derive(Debug, Clone, Copy)]
pub struct Problem<'a> {
    /// The symmetric positive definite matrix (what the preconditioner
    /// sees).
    pub a: &'a BlockCsr,
    /// Couplings' blocks outside `A`'s pattern, applied matrix-free.
    pub remote: &'a [Remote],
    /// The right-hand side.
    pub b: &'a [Vec3],
    /// Per-particle filters `S_i`.
    pub filter: &'a [Filter],
    /// Targets `z_i` of the constrained directions.
    pub z: &'a [Vec3],
}

impl Problem<'_> {
    /// `out = (A + R) v`: the operator the solve inverts.
    pub fn apply(&self, v: &[Vec3], out: &mut [Vec3]) {
        self.a.mul(v, out);
        coupling::mul_add(self.remote, v, out);
    }
}

/// Starts a solve: puts `dv`'s constrained components at their targets
/// (keeping its free components as the warm start) and leaves the residual
/// `S (b - A dv)` in the workspace. Returns its norm.
pub fn start(problem: &Problem<'_>, dv: &mut [Vec3], ws: &mut MpcgWorkspace) -> Real {
    let Problem {
        b, filter: s, z, ..
    } = *problem;
    ws.resize(b.len());
    parallel::for_chunks(dv, |start, chunk| {
        for (k, d) in chunk.iter_mut().enumerate() {
            let i = start + k;
            *d = s[i].apply(d) + z[i] - s[i].apply(&z[i]);
        }
    });
    problem.apply(dv, &mut ws.q);
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
    // Iterations since CG (re)started: the estimates' own count.
    let mut since = 0;
    let mut delta = Real::NAN;
    let mut window = [0.0; DELAY];
    ws.lanczos.clear();
    ws.translation.clear();
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
        let delta_new = if ws.translation.deflating() {
            ws.translation.apply(precond, (a, s), &ws.r, &mut ws.s)
        } else {
            precond.apply_filtered(a, s, &ws.r, &mut ws.s)
        };
        if !delta_new.is_finite() {
            break SolveStatus::Breakdown;
        }
        // The error rule: |e|²_A ≤ δ / λ_min, twice its norm in the bound.
        // (The ceiling is a one-pass upper bracket of the Ritz value.)
        if let Some(bound) = opts.error_bound
            && since >= MIN_RITZ
            && 4.0 * delta_new <= bound * bound * ws.lanczos.ceiling()
            && 4.0 * delta_new <= bound * bound * ws.lanczos.smallest()
        {
            if translate(problem, dv, ws, bound) {
                (since, window, rnorm) = (0, [0.0; DELAY], dot(&ws.r, &ws.r).sqrt());
                continue;
            }
            break SolveStatus::Converged;
        }
        // c = s + beta c (the first direction is s itself).
        let beta = if since == 0 { 0.0 } else { delta_new / delta };
        delta = delta_new;
        let sv = &ws.s;
        parallel::for_chunks(&mut ws.c, |start, chunk| {
            for (c, s) in chunk.iter_mut().zip(&sv[start..]) {
                *c = s + *c * beta;
            }
        });
        problem.apply(&ws.c, &mut ws.q);
        let curvature = filter_and_dot(s, &mut ws.q, &ws.c);
        if curvature <= 0.0 || !curvature.is_finite() {
            break SolveStatus::Breakdown;
        }
        let alpha = delta / curvature;
        ws.lanczos.push(alpha, beta);
        // dv += alpha c and r -= alpha q, with |r|², in one pass.
        let (c, q) = (&ws.c, &ws.q);
        rnorm = parallel::update_sum2(dv, &mut ws.r, |start, d, r| {
            d.iter_mut()
                .zip(r.iter_mut())
                .zip(c[start..].iter().zip(&q[start..]))
                .map(|((d, r), (c, q))| {
                    *d += c * alpha;
                    *r -= q * alpha;
                    r.dot(r)
                })
                .sum()
        })
        .sqrt();
        iterations += 1;
        since += 1;
        // Or the step terms' estimate, which many constraints favour: it
        // needs no new δ, so it is checked before the next apply.
        window[since % DELAY] = alpha * delta;
        if let Some(bound) = opts.error_bound
            && since >= DELAY
            && 4.0 * window.iter().sum::<Real>() <= bound * bound
        {
            if translate(problem, dv, ws, bound) {
                (since, window, rnorm) = (0, [0.0; DELAY], dot(&ws.r, &ws.r).sqrt());
                continue;
            }
            break SolveStatus::Converged;
        }
    };
    SolveReport {
        iterations,
        residual: rnorm / floor,
        status,
    }
}

/// Before the error rule stops a solve: whether the error along the
/// rigid translations alone breaks `bound` ([`translation`]). If so,
/// `dv` and the residual take the Galerkin correction along them and CG
/// must restart, deflating them from then on (the Lanczos tridiagonal
/// and the step terms describe the iterates before it).
fn translate(problem: &Problem<'_>, dv: &mut [Vec3], ws: &mut MpcgWorkspace, bound: Real) -> bool {
    let allowed = 0.25 * bound * bound;
    let s = problem.filter;
    let Some(c) = ws
        .translation
        .correction((problem.a, problem.remote, s), &ws.r, allowed)
    else {
        return false;
    };
    parallel::for_chunks2(dv, &mut ws.c, |start, d, c_out| {
        for (k, (d, co)) in d.iter_mut().zip(c_out).enumerate() {
            *co = s[start + k].apply(&c);
            *d += *co;
        }
    });
    problem.apply(&ws.c, &mut ws.q);
    let q = &ws.q;
    parallel::for_chunks(&mut ws.r, |start, chunk| {
        for (k, r) in chunk.iter_mut().enumerate() {
            *r -= s[start + k].apply(&q[start + k]);
        }
    });
    ws.lanczos.clear();
    true
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
mod tests;
