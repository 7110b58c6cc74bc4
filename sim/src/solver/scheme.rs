//! The time-stepping scheme of one step: backward Euler, or the
//! two-step BDF2 of Choi & Ko (2002), both solved as one implicit system of
//! the same shape (method.md §6).
//!
//! Variable-step BDF2 with the step ratio `ω = h / h_prev` reads
//!
//! ```text
//! x1 - x0 = β (x0 - x_prev) + γ h v1
//! v1 - v0 = β (v0 - v_prev) + γ h M⁻¹ f(x1, v1),
//! β = ω² / (1 + 2ω),  γ = (1 + ω) / (1 + 2ω)
//! ```
//!
//! (`β = 1/3, γ = 2/3` at a constant step). Backward Euler is the case
//! `β = 0, γ = 1` (the limit `ω -> 0`), which is also how BDF2 starts and
//! restarts. With `h' = γ h`, `p = β (x0 - x_prev)`, `q = β (v0 - v_prev)`
//! and the position correction `y` of eq. [20], `x1 = x0 + p + h' v1 + y`.
//! Linearising `f` once (eq. [8]) about the prediction
//! `x̂ = x0 + p + h' v0`, from which the step ends at `x̂ + h' dv + y`,
//! gives eq. [20] in BDF2's variables:
//!
//! ```text
//! (M - h' D - h'² K) dv = M q + h' (f(x̂, v0) + K y),   dv = v1 - v0
//! ```
//!
//! (about `x0` instead, the curvature of `f` over the carried motion `p`
//! is dropped, an `O(h²)` error per step that costs BDF2 its order);
//! the same matrix as backward Euler with `h'` for `h`, so the modified PCG,
//! its filters `S` and targets `z`, and every preconditioner carry over;
//! only the right-hand side gains the memory terms. Constraints are written
//! through [`Scheme::end`]: a pin or a contact prescribes where its particle
//! ends and how fast, whatever the scheme, so a contact made or released
//! needs no restart.

use crate::math::{Real, Vec3};

/// One step's scheme.
#[derive(Debug, Clone, Copy)]
pub struct Scheme<'a> {
    /// The step, seconds.
    pub h: Real,
    /// `β`: the weight of the last step's motion.
    pub beta: Real,
    /// `γ`: the new velocity's (and the forces') share of the step.
    pub gamma: Real,
    /// The last step's size (0 for backward Euler).
    pub h_prev: Real,
    /// `x0 - x_prev` per particle (empty when `β = 0`).
    pub dx: &'a [Vec3],
    /// `v0 - v_prev` per particle (empty when `β = 0`).
    pub dv: &'a [Vec3],
}

/// Largest step ratio for which variable-step BDF2 stays zero-stable
/// (`1 + √2`); a larger jump restarts with backward Euler.
pub const MAX_RATIO: Real = 2.4;

impl<'a> Scheme<'a> {
    /// Backward Euler with step `h`.
    pub fn euler(h: Real) -> Self {
        Self {
            h,
            beta: 0.0,
            gamma: 1.0,
            h_prev: 0.0,
            dx: &[],
            dv: &[],
        }
    }

    /// BDF2 with step `h` after a step of `h_prev` that moved the cloth by
    /// `dx` and changed its velocities by `dv`; backward Euler when there is
    /// no such step (`h_prev = 0`) or the ratio is beyond [`MAX_RATIO`].
    pub fn bdf2(h: Real, h_prev: Real, dx: &'a [Vec3], dv: &'a [Vec3]) -> Self {
        let omega = h / h_prev;
        if h_prev <= 0.0 || omega.is_nan() || omega > MAX_RATIO {
            return Self::euler(h);
        }
        Self {
            h,
            beta: omega * omega / (1.0 + 2.0 * omega),
            gamma: (1.0 + omega) / (1.0 + 2.0 * omega),
            h_prev,
            dx,
            dv,
        }
    }

    /// `h' = γ h`: how far the new velocity carries a particle in the step.
    #[inline]
    pub fn h_eff(&self) -> Real {
        self.gamma * self.h
    }

    /// `p = β (x0 - x_prev)`: what the last step's motion adds to this one.
    #[inline]
    pub fn carry(&self, i: usize) -> Vec3 {
        if self.beta == 0.0 {
            Vec3::zeros()
        } else {
            self.dx[i] * self.beta
        }
    }

    /// `q = β (v0 - v_prev)`: the velocity change the last step carries on.
    #[inline]
    pub fn velocity_carry(&self, i: usize) -> Vec3 {
        if self.beta == 0.0 {
            Vec3::zeros()
        } else {
            self.dv[i] * self.beta
        }
    }

    /// Where particle `i`, now at `x`, ends the step if its new velocity is
    /// `v1` (before any position correction): `x + p + h' v1`.
    #[inline]
    pub fn end(&self, i: usize, x: &Vec3, v1: &Vec3) -> Vec3 {
        x + self.carry(i) + v1 * self.h_eff()
    }

    /// The new velocity that brings particle `i` from `x` to `target`
    /// without a position correction.
    #[inline]
    pub fn velocity_to(&self, i: usize, x: &Vec3, target: &Vec3) -> Vec3 {
        (target - x - self.carry(i)) / self.h_eff()
    }

    /// Whether this step uses the last one (BDF2 proper).
    pub fn is_two_step(&self) -> bool {
        self.beta != 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At a constant step the coefficients are BDF2's 1/3 and 2/3, and the
    /// scheme is exact for a parabola: x(t) = t², v(t) = 2t.
    #[test]
    fn constant_step_bdf2_is_exact_for_quadratic_motion() {
        let h = 0.1;
        let (x_prev, x0, x1) = (0.0f64, h * h, 4.0 * h * h);
        let (v_prev, v0, v1) = (0.0f64, 2.0 * h, 4.0 * h);
        let dx = [Vec3::new(x0 - x_prev, 0.0, 0.0)];
        let dv = [Vec3::new(v0 - v_prev, 0.0, 0.0)];
        let s = Scheme::bdf2(h, h, &dx, &dv);
        assert!((s.beta - 1.0 / 3.0).abs() < 1e-15 && (s.gamma - 2.0 / 3.0).abs() < 1e-15);
        let end = s.end(0, &Vec3::new(x0, 0.0, 0.0), &Vec3::new(v1, 0.0, 0.0));
        assert!((end.x - x1).abs() < 1e-15);
        // The velocity law with the acceleration 2.
        let got = v0 + s.velocity_carry(0).x + s.h_eff() * 2.0;
        assert!((got - v1).abs() < 1e-15);
        // A variable step: ratio 2 (x at 0, 0.1, 0.3), still exact.
        let (h0, h1) = (0.1, 0.2);
        let dx = [Vec3::new(h0 * h0, 0.0, 0.0)];
        let no_dv = [Vec3::zeros()];
        let s = Scheme::bdf2(h1, h0, &dx, &no_dv);
        let t1: f64 = h0 + h1;
        let end = s.end(
            0,
            &Vec3::new(h0 * h0, 0.0, 0.0),
            &Vec3::new(2.0 * t1, 0.0, 0.0),
        );
        assert!((end.x - t1 * t1).abs() < 1e-14, "{}", end.x);
        // No history, or a jump beyond the stable ratio: backward Euler.
        assert_eq!(Scheme::bdf2(h, 0.0, &[], &[]).beta, 0.0);
        assert_eq!(Scheme::bdf2(1.0, 0.1, &dx, &dx).gamma, 1.0);
    }
}
