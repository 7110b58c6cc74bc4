//! The shared finite-difference tester for every force (STYLE.md 7).
//!
//! For a force and a configuration it checks, by central differences,
//! - `f = -∂E/∂x` at rest (forces with an energy; a force that also
//!   damps, as shear does, dissipates nothing at `v = 0`),
//! - `∂f/∂x` against the [`JacobianMode::Exact`] `dfdx` blocks,
//! - `∂f/∂v` against the `dfdv` blocks.
//!
//! Central differences with step `η` have truncation error `O(η²)` and
//! round-off `O(ε_mach |f| / η)`; with `η = 1e-6 · scale` both sit near
//! `1e-8` relative, so the tolerance `1e-5` relative to the largest entry
//! leaves three orders of margin and still catches any wrong term (a missing
//! term is an O(1) relative error).

use super::force::{Force, Sink};
use crate::math::{Mat3, Real, Vec3};
use crate::spec::JacobianMode;

/// A sink that accumulates into dense arrays.
pub struct DenseSink {
    pub f: Vec<Vec3>,
    pub dfdx: Vec<Vec<Mat3>>,
    pub dfdv: Vec<Vec<Mat3>>,
}

impl DenseSink {
    pub fn new(n: usize) -> Self {
        Self {
            f: vec![Vec3::zeros(); n],
            dfdx: vec![vec![Mat3::zeros(); n]; n],
            dfdv: vec![vec![Mat3::zeros(); n]; n],
        }
    }
}

impl Sink for DenseSink {
    fn add<const N: usize>(
        &mut self,
        _element: usize,
        idx: &[usize; N],
        f: &[Vec3; N],
        dfdx: Option<&[[Mat3; N]; N]>,
        dfdv: Option<&[[Mat3; N]; N]>,
    ) {
        for a in 0..N {
            self.f[idx[a]] += f[a];
            for b in 0..N {
                if let Some(k) = dfdx {
                    self.dfdx[idx[a]][idx[b]] += k[a][b];
                }
                if let Some(d) = dfdv {
                    self.dfdv[idx[a]][idx[b]] += d[a][b];
                }
            }
        }
    }
}

pub fn evaluate<F: Force>(force: &F, x: &[Vec3], v: &[Vec3], mode: JacobianMode) -> DenseSink {
    let mut s = DenseSink::new(x.len());
    force.accumulate(x, v, mode, &mut s);
    s
}

fn max_abs_f(s: &DenseSink) -> Real {
    s.f.iter().map(|f| f.amax()).fold(0.0, Real::max)
}

/// Asserts all three checks at `(x, v)`; `length` scales the position step.
pub fn check<F: Force>(force: &F, x: &[Vec3], v: &[Vec3], length: Real) {
    let n = x.len();
    let base = evaluate(force, x, v, JacobianMode::Exact);
    // The conservative part: the force at rest.
    let at_rest = evaluate(force, x, &vec![Vec3::zeros(); n], JacobianMode::Exact);
    let eta_x = 1e-6 * length;
    let eta_v = 1e-6 * v.iter().map(|v| v.amax()).fold(1e-3, Real::max);
    let mut worst_f: Real = 0.0;
    let (mut err_f, mut err_k, mut err_d): (Real, Real, Real) = (0.0, 0.0, 0.0);
    let (mut scale_k, mut scale_d): (Real, Real) = (0.0, 0.0);
    for p in 0..n {
        for c in 0..3 {
            let mut xp = x.to_vec();
            let mut xm = x.to_vec();
            xp[p][c] += eta_x;
            xm[p][c] -= eta_x;
            if let (Some(ep), Some(em)) = (force.energy(&xp), force.energy(&xm)) {
                let fd = -(ep - em) / (2.0 * eta_x);
                err_f = err_f.max((fd - at_rest.f[p][c]).abs());
                worst_f = worst_f.max(at_rest.f[p][c].abs());
            }
            let sp = evaluate(force, &xp, v, JacobianMode::Exact);
            let sm = evaluate(force, &xm, v, JacobianMode::Exact);
            let mut vp = v.to_vec();
            let mut vm = v.to_vec();
            vp[p][c] += eta_v;
            vm[p][c] -= eta_v;
            let tp = evaluate(force, x, &vp, JacobianMode::Exact);
            let tm = evaluate(force, x, &vm, JacobianMode::Exact);
            for a in 0..n {
                for r in 0..3 {
                    let fd_k = (sp.f[a][r] - sm.f[a][r]) / (2.0 * eta_x);
                    let an_k = base.dfdx[a][p][(r, c)];
                    err_k = err_k.max((fd_k - an_k).abs());
                    scale_k = scale_k.max(an_k.abs()).max(fd_k.abs());
                    let fd_d = (tp.f[a][r] - tm.f[a][r]) / (2.0 * eta_v);
                    let an_d = base.dfdv[a][p][(r, c)];
                    err_d = err_d.max((fd_d - an_d).abs());
                    scale_d = scale_d.max(an_d.abs()).max(fd_d.abs());
                }
            }
        }
    }
    let name = force.name();
    let tol = 1e-5;
    assert!(
        err_f <= tol * worst_f.max(max_abs_f(&at_rest)).max(1e-300),
        "{name}: force differs from -dE/dx by {err_f:e} (scale {worst_f:e})"
    );
    assert!(
        err_k <= tol * scale_k.max(1e-300),
        "{name}: df/dx differs from finite differences by {err_k:e} (scale {scale_k:e})"
    );
    assert!(
        err_d <= tol * scale_d.max(1e-300),
        "{name}: df/dv differs from finite differences by {err_d:e} (scale {scale_d:e})"
    );
}

/// A small grid with seeded random perturbations of positions (`jitter` as a
/// fraction of the spacing) and random velocities.
pub fn random_configuration(
    nu: usize,
    nv: usize,
    jitter: Real,
    seed: u64,
) -> (super::Grid, Vec<Vec3>, Vec<Vec3>) {
    use rand::{RngExt, SeedableRng, rngs::StdRng};
    let scene = crate::testing::scene_from_json(&format!(
        r#"{{"cloth": {{"grid": [{nu}, {nv}], "size": [0.3, 0.2]}}, "material": "cotton", "duration": 1, "fps": 1}}"#
    ));
    let grid = super::Grid::new(&scene.cloth, 0.15);
    let mut rng = StdRng::seed_from_u64(seed);
    let mut r = || {
        Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
    };
    let h = grid.du.min(grid.dv);
    let x = grid.rest.iter().map(|p| p + r() * (jitter * h)).collect();
    let v = (0..grid.len()).map(|_| r() * 0.5).collect();
    (grid, x, v)
}

/// Runs [`check`] on several seeded configurations of a 4x3 grid, from
/// nearly flat (angles near their rest values, where the closed forms switch
/// to series) to strongly crumpled.
pub fn check_on_random_grids<F: Force>(build: impl Fn(&super::Grid) -> F) {
    for (seed, jitter) in [(1, 1e-5), (2, 0.05), (3, 0.3), (4, 0.6)] {
        let (grid, x, v) = random_configuration(4, 3, jitter, seed);
        let force = build(&grid);
        check(&force, &x, &v, grid.du.min(grid.dv));
    }
}
