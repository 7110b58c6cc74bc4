//! Bending along grid lines, method.md §1 eq. [2]:
//! `E_b = 1/2 (C_b1 φ² + C_b0 |φ|)` with `φ = π - θ` at the middle of every
//! three consecutive particles of a warp or weft line.
//!
//! Resolution independence: a hinge turns by `φ` between the midpoints of
//! its two arms, over the arc `ℓ = (L1 + L2) / 2`, so its curvature is
//! `κ ≈ φ / ℓ`, and it stands for the strip `ℓ w` of cloth (`w` its width
//! across the line); the continuum energy `1/2 B κ² ℓ w` gives
//! `C_b1 = B w / ℓ` (`= B` inside a square grid). The threshold term takes
//! `C_b0 = bend_threshold · w`.
//!
//! At a clamp (an arm whose two particles are both pinned, so its direction
//! is held) the turning happens between the clamp and the midpoint of the
//! free arm: `ℓ = L2 / 2`, twice the stiffness. With the interior value
//! there instead, the clamp is too soft by a constant factor over one
//! spacing, and a clamped cantilever converges only at first order in the
//! spacing; with it, at second order (`sim/tests/elastica.rs`).
//!
//! `φ² = arccos(-f)²` is an analytic function of `f` even at the straight
//! configuration (`φ = 0`), so the exact Hessian follows through `f`, with
//! series near `φ = 0`.
//!
//! PSD treatment (Gauss–Newton on a vector residual): with `κ = û1 + û2`
//! (`|κ| = 2 sin(φ/2)`) the residual `ρ = φ κ / |κ|` is smooth, `|ρ|² = φ²`,
//! and the solver uses `2 E'(q) Jρᵀ Jρ` (`q = φ²`). It is positive
//! semi-definite everywhere, equals the exact Hessian at the straight rest
//! state, and, unlike Gauss–Newton on the scalar `φ`, keeps stiffness in
//! both transverse directions of a straight line.

use super::angle::{AngleElement, AngleForce, AngleGeom, AngleLaw, ArmDerivatives, ArmHessian};
use super::angle::{energy_of_square, exact_hessian_through_f, gradient_through_f};
use super::grid::Grid;
use crate::math::{Mat3, Real, outer};
use crate::spec::JacobianMode;

/// The bending law.
#[derive(Debug, Clone, Copy)]
pub struct Bend;

/// Below this angle the closed forms lose digits; use their series.
const SERIES_BELOW: Real = 1e-3;

impl Bend {
    /// Hinges along every warp and weft line, rigidity `b` (N·m) and
    /// threshold `b0` (N·m per metre of hinge width); `pinned` marks held
    /// particles (empty: none), which makes clamps.
    pub fn on_grid(grid: &Grid, b: Real, b0: Real, pinned: &[bool]) -> AngleForce<Bend> {
        let (nu, nv, du, dv) = (grid.nu, grid.nv, grid.du, grid.dv);
        let held = |p: usize| pinned.get(p).copied().unwrap_or(false);
        let mut el = Vec::new();
        let mut hinge = |idx: [usize; 3], spacing: Real, w: Real| {
            // Half of each arm that can turn.
            let free = |a: usize, b: usize| if held(a) && held(b) { 0.0 } else { 0.5 };
            let arc = spacing * (free(idx[0], idx[1]) + free(idx[1], idx[2]));
            if arc > 0.0 {
                el.push(AngleElement {
                    idx,
                    c1: b * w / arc,
                    c0: b0 * w,
                });
            }
        };
        for j in 0..nv {
            let w = Grid::edge_share(j, nv) * dv;
            for i in 1..nu.saturating_sub(1) {
                let idx = [grid.index(i - 1, j), grid.index(i, j), grid.index(i + 1, j)];
                hinge(idx, du, w);
            }
        }
        for i in 0..nu {
            let w = Grid::edge_share(i, nu) * du;
            for j in 1..nv.saturating_sub(1) {
                let idx = [grid.index(i, j - 1), grid.index(i, j), grid.index(i, j + 1)];
                hinge(idx, dv, w);
            }
        }
        AngleForce::new(el)
    }
}

/// With `κ = û1 + û2`, the half bend angle `φ/2 = asin(|κ| / 2)`, accurate
/// near zero: computed once an element for the angle and the solver's
/// Hessian ([`gauss_newton`]), which need the same arcsine.
struct Hinge {
    /// `|κ|²`.
    qk: Real,
    /// `|κ| / 2 = sin(φ/2)`.
    half: Real,
    /// `asin(min(|κ| / 2, 1))`.
    asin: Real,
}

impl Hinge {
    fn of(g: &AngleGeom) -> Self {
        let qk = (g.u + g.w).norm_squared();
        let half = 0.5 * qk.sqrt();
        Self {
            qk,
            half,
            asin: half.min(1.0).asin(),
        }
    }

    /// The bend angle `φ`.
    fn phi(&self) -> Real {
        self.asin * 2.0
    }
}

impl AngleLaw for Bend {
    const NAME: &'static str = "bend";

    fn energy(g: &AngleGeom, c1: Real, c0: Real) -> Real {
        let phi = Hinge::of(g).phi();
        energy_of_square(phi * phi, c1, c0).0
    }

    #[inline]
    fn eval(g: &AngleGeom, c1: Real, c0: Real, mode: JacobianMode) -> ArmDerivatives {
        let hinge = Hinge::of(g);
        let phi = hinge.phi();
        let (_, e_q, e_qq) = energy_of_square(phi * phi, c1, c0);
        // q = φ² as a function of f: q_f = 2φ / sin φ,
        // q_ff = 2 (sin φ - φ cos φ) / sin³ φ, with cos φ = -f.
        let (q_f, q_ff) = if phi < SERIES_BELOW {
            let p2 = phi * phi;
            (2.0 * (1.0 + p2 / 6.0), 2.0 * (1.0 / 3.0 + 2.0 * p2 / 15.0))
        } else {
            // NOTE: a hinge folded flat onto itself (φ = π) has no direction
            // to unfold in; the clamp keeps the numbers finite there.
            let s = g.sin.max(1e-9);
            (2.0 * phi / s, 2.0 * (s + phi * g.f) / (s * s * s))
        };
        let e_f = e_q * q_f;
        let hess = ArmHessian::Full(match mode {
            JacobianMode::Exact => exact_hessian_through_f(g, e_f, e_qq * q_f * q_f + e_q * q_ff),
            JacobianMode::Solver => gauss_newton(g, &hinge, e_q),
        });
        ArmDerivatives {
            grad: gradient_through_f(g, e_f),
            hess,
        }
    }
}

/// `2 E'(q) Jρᵀ Jρ` with `Jρ = M P_i / r_i`, `M = α I + 2 α' κ κᵀ`,
/// `α(|κ|²) = φ / (2 sin(φ/2))`.
///
/// PERF: written out rather than as products of 3x3 matrices. With
/// `M² = a I + c κκᵀ` and `P_i κ / r_i = ∂f/∂e_i = g_i`, each block is
/// `2 E'(q) [a P_i P_j / (r_i r_j) + c g_i g_jᵀ]`, and the projector
/// products are `P_1 P_1 = I - û1 û1ᵀ`, `P_1 P_2 = I - û1 û1ᵀ - û2 û2ᵀ +
/// f û1 û2ᵀ`: a handful of outer products.
fn gauss_newton(g: &AngleGeom, hinge: &Hinge, e_q: Real) -> [[Mat3; 2]; 2] {
    let qk = hinge.qk;
    let x = hinge.half.min(1.0 - 1e-12); // sin(φ/2)
    let (alpha, dalpha) = if x < SERIES_BELOW {
        let x2 = x * x;
        (1.0 + x2 / 6.0, 1.0 / 24.0 + 3.0 * x2 / 80.0)
    } else {
        // The hinge's arcsine unless the clamp moved `x` (folded flat).
        let a = if x == hinge.half {
            hinge.asin
        } else {
            x.asin()
        };
        (a / x, (x / (1.0 - x * x).sqrt() - a) / (8.0 * x * x * x))
    };
    let s = 2.0 * e_q;
    let a = s * alpha * alpha;
    let c = s * (4.0 * alpha * dalpha + 4.0 * dalpha * dalpha * qk);
    let uu = outer(&g.u, &g.u);
    let ww = outer(&g.w, &g.w);
    let id = Mat3::identity();
    let h11 = (id - uu) * (a / (g.r1 * g.r1)) + outer(&g.g1, &g.g1) * c;
    let h22 = (id - ww) * (a / (g.r2 * g.r2)) + outer(&g.g2, &g.g2) * c;
    let h12 =
        (id - uu - ww + outer(&g.u, &g.w) * g.f) * (a / (g.r1 * g.r2)) + outer(&g.g1, &g.g2) * c;
    [[h11, h12], [h12.transpose(), h22]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::{Force, fdcheck};
    use crate::math::Vec3;

    #[test]
    fn bend_force_and_jacobian_match_finite_differences() {
        fdcheck::check_on_random_grids(|g| Bend::on_grid(g, 1.0e-3, 0.0, &[]));
    }

    #[test]
    fn bend_threshold_term_matches_finite_differences() {
        fdcheck::check_on_random_grids(|g| Bend::on_grid(g, 1.0e-3, 2.0e-3, &[]));
    }

    /// The solver Hessian is PSD everywhere and equals the exact one at the
    /// straight rest state, in both transverse directions.
    #[test]
    fn solver_hessian_is_psd_and_exact_at_rest() {
        let f = Bend::on_grid(
            &fdcheck::random_configuration(3, 2, 0.0, 0).0,
            1.0,
            0.0,
            &[],
        );
        let f = AngleForce::<Bend>::new(f.elements[..1].to_vec());
        let straight = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
        ];
        let mut x = vec![Vec3::zeros(); 6];
        x[..3].copy_from_slice(&straight);
        let v = vec![Vec3::zeros(); 6];
        let solver = fdcheck::evaluate(&f, &x, &v, JacobianMode::Solver);
        let exact = fdcheck::evaluate(&f, &x, &v, JacobianMode::Exact);
        for a in 0..3 {
            for b in 0..3 {
                assert!((solver.dfdx[a][b] - exact.dfdx[a][b]).amax() < 1e-12);
            }
        }
        // Transverse stiffness in y and z at the middle particle.
        assert!(solver.dfdx[1][1][(1, 1)] < -1.0 && solver.dfdx[1][1][(2, 2)] < -1.0);
        // PSD (of -K) at bent configurations.
        let (_, xr, _) = fdcheck::random_configuration(3, 2, 0.8, 9);
        let d = fdcheck::evaluate(&f, &xr, &v, JacobianMode::Solver);
        let mut dense = nalgebra::DMatrix::<f64>::zeros(9, 9);
        for a in 0..3 {
            for b in 0..3 {
                let blk = -d.dfdx[f.elements[0].idx[a]][f.elements[0].idx[b]];
                dense.view_mut((3 * a, 3 * b), (3, 3)).copy_from(&blk);
            }
        }
        let min = dense.symmetric_eigenvalues().min();
        assert!(min > -1e-9 * dense.amax(), "min eigenvalue {min}");
        assert!(f.energy(&x).expect("energy") < 1e-30);
    }
}
