//! The embedded local error estimate of an accepted step: the step's end
//! against an explicit predictor of the same data, scaled by the two
//! methods' error constants (Milne's device; Hairer, Nørsett & Wanner,
//! *Solving ODEs I*, §III.5). It costs one pass over the particles and no
//! extra solve.
//!
//! - **Backward Euler** ends at `x1 = x0 + h v1`, with local error
//!   `x1 - x(t1) ≈ +h²/2 x''`; the explicit predictor `x̂ = x0 + h v0` is
//!   off by `-h²/2 x''`, so `x1 - x̂ ≈ h² x''` and
//!   `err ≈ (x1 - x̂) / 2`.
//! - **BDF2** at a constant step satisfies the exact solution up to the
//!   residual `-2/9 h³ x'''`, so `x1 - x(t1) ≈ 2/9 h³ x'''`. The predictor
//!   is the quadratic through `x_prev`, `x0` with slope `v0` at `t0`,
//!   `x̂ = x0 + h v0 + r² (x_prev - x0 + h_prev v0)` with `r = h / h_prev`,
//!   off by `-h² (h + h_prev) x''' / 6` (`-h³/3 x'''` at a constant step),
//!   so `x1 - x̂ ≈ 5/9 h³ x'''` and `err ≈ 2/5 (x1 - x̂)`. After a change
//!   of step (ratio 2 or 1/2 under the adaptive controller) the constants
//!   shift by tens of percent, which the controller's safety factor covers.
//!
//! Particles under a constraint (pins, contacts) follow a prescribed
//! motion, not the ODE, and are left out; the estimate is the RMS over the
//! free ones, in metres.

use super::constraints::{Constraints, Filter};
use super::scheme::Scheme;
use crate::math::{Real, Vec3};

/// The RMS local position error of a step of `scheme` that moved each
/// particle by `moved` and changed its velocity by `dv`, ending at
/// velocities `v1`.
pub fn local_error(
    scheme: &Scheme<'_>,
    v1: &[Vec3],
    dv: &[Vec3],
    moved: &[Vec3],
    constraints: &Constraints,
) -> Real {
    let h = scheme.h;
    let bdf2 = scheme.is_two_step();
    let r = if bdf2 { h / scheme.h_prev } else { 0.0 };
    let free = |i: usize| constraints.filter[i] == Filter::Free;
    let count = constraints
        .filter
        .iter()
        .filter(|f| **f == Filter::Free)
        .count();
    let sum = crate::parallel::sum(v1.len(), |range| {
        let mut sum = 0.0;
        for i in range.filter(|&i| free(i)) {
            let v0 = v1[i] - dv[i];
            let e = if bdf2 {
                // x_prev - x0 = -dx, the last step's motion reversed.
                let predicted = v0 * h + (v0 * scheme.h_prev - scheme.dx[i]) * (r * r);
                (moved[i] - predicted) * 0.4
            } else {
                (moved[i] - v0 * h) * 0.5
            };
            sum += e.norm_squared();
        }
        sum
    });
    if count == 0 {
        0.0
    } else {
        (sum / count as Real).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One free particle on a cubic path `x = t³` (a' constant = 6), both
    /// methods' steps taken exactly from their formulas: the estimate is the
    /// true local error of each.
    #[test]
    fn estimates_match_true_local_errors_on_a_cubic() {
        let x = |t: Real| t * t * t;
        let v = |t: Real| 3.0 * t * t;
        let (t0, h) = (1.0, 1e-3);
        let c = Constraints::free(1);
        let at = |s: Real| Vec3::new(s, 0.0, 0.0);
        // Backward Euler with the exact v1: x1 = x0 + h v(t1).
        let moved = at(h * v(t0 + h));
        let dv = at(v(t0 + h) - v(t0));
        let est = local_error(&Scheme::euler(h), &[at(v(t0 + h))], &[dv], &[moved], &c);
        let truth = (x(t0) + moved.x - x(t0 + h)).abs();
        assert!((est / truth - 1.0).abs() < 0.01, "{est} vs {truth}");
        // BDF2 at a constant step from exact history, solving the scalar
        // scheme x1 = x0 + (x0 - x_prev)/3 + 2/3 h v1 for the exact v1.
        let dx = [at(x(t0) - x(t0 - h))];
        let dvp = [at(v(t0) - v(t0 - h))];
        let s = Scheme::bdf2(h, h, &dx, &dvp);
        let moved = at(dx[0].x / 3.0 + 2.0 / 3.0 * h * v(t0 + h));
        let est = local_error(&s, &[at(v(t0 + h))], &[dv], &[moved], &c);
        let truth = (x(t0) + moved.x - x(t0 + h)).abs();
        // x''' = 6 is constant, so only higher-order terms separate them.
        assert!((est / truth - 1.0).abs() < 0.02, "{est} vs {truth}");
        // A pinned particle counts for nothing.
        let mut pinned = Constraints::free(1);
        pinned.fix(0, Vec3::zeros(), Vec3::zeros());
        assert_eq!(local_error(&s, &[at(1.0)], &[dv], &[moved], &pinned), 0.0);
    }
}
