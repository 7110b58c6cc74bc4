//! In-plane shear, method.md §1 eq. [3]:
//! `E_s = 1/2 (C_s1 γ² + C_s0 |γ|)` with `γ = π/2 - θ` the angle between a
//! particle's warp and weft edges.
//!
//! Every quad contributes one element at each of its four corners, so the
//! cloth has no zero-energy shear mode and the stencil is symmetric. A
//! corner owns a quarter of its quad, `A = du dv / 4`; the continuum energy
//! `1/2 G γ² A` gives `C_s1 = G A` (the issue's `G h²` per quad) and
//! `C_s0 = shear_threshold · A`.
//!
//! `γ = asin f`. PSD treatment: Gauss–Newton on the scalar `γ`,
//! `2 E'(q) ∇γ ∇γᵀ` with `∇γ = ∇f / cos γ`; exact at the square rest state,
//! where `γ = 0`.

use super::angle::{
    AngleElement, AngleForce, AngleGeom, AngleLaw, ArmDamping, ArmDerivatives, ArmHessian,
};
use super::angle::{energy_of_square, exact_hessian_through_f, gradient_through_f};
use super::grid::Grid;
use crate::math::{Mat3, Real, Vec3, outer};
use crate::spec::JacobianMode;

/// The shear law.
#[derive(Debug, Clone, Copy)]
pub struct Shear;

impl Shear {
    /// Four corner elements per quad, stiffness `g` and threshold `g0` (N/m).
    pub fn on_grid(grid: &Grid, g: Real, g0: Real) -> AngleForce<Shear> {
        let area = grid.du * grid.dv / 4.0;
        let mut el = Vec::with_capacity(4 * (grid.nu - 1) * (grid.nv - 1));
        for j in 0..grid.nv - 1 {
            for i in 0..grid.nu - 1 {
                let p00 = grid.index(i, j);
                let p10 = grid.index(i + 1, j);
                let p11 = grid.index(i + 1, j + 1);
                let p01 = grid.index(i, j + 1);
                for idx in [
                    [p10, p00, p01],
                    [p00, p10, p11],
                    [p01, p11, p10],
                    [p11, p01, p00],
                ] {
                    el.push(AngleElement {
                        idx,
                        c1: g * area,
                        c0: g0 * area,
                    });
                }
            }
        }
        AngleForce::new(el)
    }
}

impl AngleLaw for Shear {
    const NAME: &'static str = "shear";

    /// Rayleigh damping of the shear rate: `f = -k γ̇ ∇γ` with
    /// `γ̇ = ∇γ · ė` (`k = β C_s1`, the dissipation `1/2 k γ̇²`), so a
    /// quad's corners dissipate `β G A γ̇²` whatever the resolution, as the
    /// springs' damping does for stretch. Without it in-plane shear waves
    /// ring undamped far above any step's resolution (`√(G/ρ) π / Δx`,
    /// 2,200 rad/s for cotton at 40²), and BDF2 converged at first order
    /// on a swinging cloth (docs/benchmarks.md, section 1n). With
    /// `∇γ = j / cos γ` (`j = ∇f`, the solver's rank-one `j`):
    /// `-∂f/∂ė = k/cos²γ j jᵀ`; the exact `-∂f/∂e = k (∇γ (H_γ ė)ᵀ + γ̇ H_γ)`
    /// with `H_γ` the Hessian of `γ = asin f`.
    #[inline]
    fn damping(g: &AngleGeom, k: Real, rate: [Vec3; 2], mode: JacobianMode) -> Option<ArmDamping> {
        let cos = g.sin.max(1e-9);
        let j = [g.g1, g.g2];
        let c = k / (cos * cos);
        let jr = j[0].dot(&rate[0]) + j[1].dot(&rate[1]);
        let grad = [j[0] * (c * jr), j[1] * (c * jr)];
        let dgde = match mode {
            JacobianMode::Solver => None,
            JacobianMode::Exact => {
                // γ = asin f: γ_f = 1/cos γ, γ_ff = f / cos³ γ.
                let hg = exact_hessian_through_f(g, 1.0 / cos, g.f / (cos * cos * cos));
                let gamma_dot = jr / cos;
                let hr = [
                    hg[0][0] * rate[0] + hg[0][1] * rate[1],
                    hg[1][0] * rate[0] + hg[1][1] * rate[1],
                ];
                let dg = [j[0] / cos, j[1] / cos];
                let mut out = [[Mat3::zeros(); 2]; 2];
                for (a, row) in out.iter_mut().enumerate() {
                    for (b, block) in row.iter_mut().enumerate() {
                        *block = (outer(&dg[a], &hr[b]) + hg[a][b] * gamma_dot) * k;
                    }
                }
                Some(out)
            }
        };
        Some(ArmDamping { grad, c, j, dgde })
    }

    fn energy(g: &AngleGeom, c1: Real, c0: Real) -> Real {
        let gamma = g.f.asin();
        energy_of_square(gamma * gamma, c1, c0).0
    }

    #[inline]
    fn eval(g: &AngleGeom, c1: Real, c0: Real, mode: JacobianMode) -> ArmDerivatives {
        let gamma = g.f.asin();
        let (_, e_q, e_qq) = energy_of_square(gamma * gamma, c1, c0);
        // NOTE: collinear arms (γ = ±π/2) are a degenerate quad; the clamp
        // keeps the numbers finite while the springs restore it.
        let cos = g.sin.max(1e-9);
        // q = γ²: q_f = 2γ / cos γ, q_ff = 2 / cos² γ + 2 γ f / cos³ γ.
        let q_f = 2.0 * gamma / cos;
        let hess = match mode {
            JacobianMode::Exact => {
                let q_ff = 2.0 / (cos * cos) + 2.0 * gamma * g.f / (cos * cos * cos);
                ArmHessian::Full(exact_hessian_through_f(
                    g,
                    e_q * q_f,
                    e_qq * q_f * q_f + e_q * q_ff,
                ))
            }
            // `2 E'(q) ∇γ ∇γᵀ` with `∇γ = ∇f / cos γ`: rank one.
            JacobianMode::Solver => ArmHessian::Rank1 {
                s: 2.0 * e_q / (cos * cos),
                j: [g.g1, g.g2],
            },
        };
        ArmDerivatives {
            grad: gradient_through_f(g, e_q * q_f),
            hess,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::{Force, fdcheck};

    #[test]
    fn shear_force_and_jacobian_match_finite_differences() {
        fdcheck::check_on_random_grids(|g| Shear::on_grid(g, 50.0, 0.0));
    }

    /// The picture-frame (trellis) test: threads keep their lengths and
    /// the angle between warp and weft closes by `γ`; the continuum energy
    /// is `1/2 G γ² A` over the rest area `A` (G per rest area, as KES
    /// reports it). Every corner element sees the same angle, so the
    /// discrete energy is exact at any resolution, and so is the
    /// force–angle curve `dE/dγ = G γ A`.
    #[test]
    fn trellised_cloth_has_the_continuum_shear_energy_at_any_resolution() {
        let g = 50.0;
        for n in [3, 7, 20] {
            let (grid, _, _) = fdcheck::random_configuration(n, n, 0.0, 0);
            let shear = Shear::on_grid(&grid, g, 0.0);
            let area = grid.du * (n - 1) as f64 * grid.dv * (n - 1) as f64;
            let energy = |gamma: f64| {
                let weft = crate::math::Vec3::new(gamma.sin(), gamma.cos(), 0.0);
                let x: Vec<_> = (0..grid.len())
                    .map(|k| {
                        let (i, j) = ((k % n) as f64, (k / n) as f64);
                        crate::math::Vec3::x() * (i * grid.du) + weft * (j * grid.dv)
                    })
                    .collect();
                shear.energy(&x).expect("energy")
            };
            for gamma in [0.01, 0.2, 0.6] {
                let exact = 0.5 * g * gamma * gamma * area;
                assert!(
                    (energy(gamma) / exact - 1.0).abs() < 1e-12,
                    "n {n}, γ {gamma}"
                );
                let e = 1e-6;
                let force = (energy(gamma + e) - energy(gamma - e)) / (2.0 * e);
                assert!(
                    (force / (g * gamma * area) - 1.0).abs() < 1e-6,
                    "n {n}, γ {gamma}"
                );
            }
        }
    }

    /// Every derivative of the damped shear; its force at rest against the
    /// energy (the damping dissipates nothing there).
    #[test]
    fn shear_damping_matches_finite_differences() {
        fdcheck::check_on_random_grids(|g| Shear::on_grid(g, 50.0, 0.0).with_damping(0.01));
        fdcheck::check_on_random_grids(|g| Shear::on_grid(g, 50.0, 30.0).with_damping(0.002));
    }

    /// The damping is Rayleigh's: a trellised cloth shearing uniformly at
    /// `γ̇` loses `β G A γ̇²` (A its rest area) at any resolution and any
    /// angle, since every corner element sees the same rate.
    #[test]
    fn a_shearing_cloth_dissipates_beta_g_area_rate_squared() {
        let (g, beta) = (50.0, 0.002);
        for n in [3, 7, 20] {
            let (grid, _, _) = fdcheck::random_configuration(n, n, 0.0, 0);
            let elastic = Shear::on_grid(&grid, g, 0.0);
            let damped = elastic.clone().with_damping(beta);
            let area = grid.du * (n - 1) as Real * grid.dv * (n - 1) as Real;
            for (gamma, rate) in [(0.0_f64, 1.0), (0.3, -2.0), (0.6, 0.5)] {
                // Warp along x; weft at angle γ from y, turning at `rate`.
                let weft = Vec3::new(gamma.sin(), gamma.cos(), 0.0);
                let turn = Vec3::new(gamma.cos(), -gamma.sin(), 0.0) * rate;
                let (mut x, mut v) = (Vec::new(), Vec::new());
                for k in 0..grid.len() {
                    let (i, j) = ((k % n) as Real, (k / n) as Real);
                    x.push(Vec3::x() * (i * grid.du) + weft * (j * grid.dv));
                    v.push(turn * (j * grid.dv));
                }
                // The damping's power: the elastic force's taken away.
                let power = |force: &AngleForce<Shear>| -> Real {
                    let s = fdcheck::evaluate(force, &x, &v, JacobianMode::Solver);
                    s.f.iter().zip(&v).map(|(f, v)| f.dot(v)).sum()
                };
                let power = power(&damped) - power(&elastic);
                let want = -beta * g * area * rate * rate;
                assert!(
                    (power / want - 1.0).abs() < 1e-9,
                    "n {n}, γ {gamma}: {power} against {want}"
                );
            }
        }
    }

    #[test]
    fn shear_threshold_term_matches_finite_differences() {
        fdcheck::check_on_random_grids(|g| Shear::on_grid(g, 50.0, 30.0));
    }
}
