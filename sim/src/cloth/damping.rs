//! Spring-direction damping (method.md §1, "Damping"): each stretch spring
//! resists the rate of change of its length, `f_a = -c (ûᵀ (v_a - v_b)) û`,
//! with stiffness-proportional `c = β k` (β = `material.damping`, seconds).
//!
//! Being proportional to `k = Y w / L`, the damping is a continuum
//! (Rayleigh) quantity and refines like the stiffness.
//!
//! Jacobians: `∂f/∂v = -c û ûᵀ` (symmetric, negative semi-definite) goes into
//! the system matrix. `∂f/∂x` is unsymmetric; as Baraff & Witkin (1998) do,
//! [`JacobianMode::Solver`] omits it, and [`JacobianMode::Exact`] gives it so
//! the finite-difference tests check every derivative.

use super::force::{Force, Sink};
use super::stretch::{Spring, Stretch};
use crate::math::{Mat3, Real, Vec3, outer};
use crate::spec::JacobianMode;

/// Damping along the stretch springs.
#[derive(Debug, Clone, Default)]
pub struct SpringDamping {
    /// The damped springs, with `k` already multiplied by β.
    pub springs: Vec<Spring>,
}

impl SpringDamping {
    /// Damping of coefficient `beta * k` on each spring.
    pub fn new(springs: &[Spring], beta: Real) -> Self {
        Self {
            springs: springs
                .iter()
                .map(|s| Spring {
                    k: s.k * beta,
                    ..*s
                })
                .collect(),
        }
    }
}

impl Force for SpringDamping {
    fn name(&self) -> &'static str {
        "spring damping"
    }

    fn energy(&self, _x: &[Vec3]) -> Option<Real> {
        None
    }

    fn for_each_element(&self, visit: &mut dyn FnMut(&[usize])) {
        for s in &self.springs {
            visit(&[s.a, s.b]);
        }
    }

    fn element_count(&self) -> usize {
        self.springs.len()
    }

    fn add_element<S: Sink>(
        &self,
        e: usize,
        x: &[Vec3],
        v: &[Vec3],
        mode: JacobianMode,
        sink: &mut S,
    ) {
        let s = &self.springs[e];
        let d = x[s.a] - x[s.b];
        let l = d.norm();
        if l <= Real::EPSILON * s.rest || s.k == 0.0 {
            return;
        }
        let u = d / l;
        let (g, damp) = self.along(e, &u, v);
        let dfdx = match mode {
            JacobianMode::Solver => None,
            JacobianMode::Exact => {
                let dv = v[s.a] - v[s.b];
                let p = Mat3::identity() - outer(&u, &u);
                Some((u * (dv.transpose() * p) + p * u.dot(&dv)) * (s.k / l))
            }
        };
        sink.add_pair(e, [s.a, s.b], g, dfdx.as_ref(), Some(&damp));
    }
}

impl SpringDamping {
    /// Spring `e`'s damping along its direction `u`: `-f_a = c (ûᵀ (v_a
    /// - v_b)) û` and the block `c û ûᵀ = -∂f_a/∂v_a`.
    #[inline]
    fn along(&self, e: usize, u: &Vec3, v: &[Vec3]) -> (Vec3, Mat3) {
        let s = &self.springs[e];
        let rate = u.dot(&(v[s.a] - v[s.b]));
        (u * (s.k * rate), outer(u, u) * s.k)
    }

    /// Whether these are `stretch`'s springs, one for one (as
    /// `ForceModel` makes them), so [`SpringDamping::add_with_stretch`]
    /// may stand for both forces.
    pub fn damps(&self, stretch: &Stretch) -> bool {
        self.springs.len() == stretch.springs.len()
            && self
                .springs
                .iter()
                .zip(&stretch.springs)
                .all(|(d, s)| (d.a, d.b, d.rest) == (s.a, s.b, s.rest))
    }

    /// Spring `e` of `stretch` with its damping, for the solver
    /// ([`JacobianMode::Solver`]): one pair with both blocks, the spring's
    /// length and direction computed once. The sum of both forces'
    /// `add_element` (requires [`SpringDamping::damps`]).
    #[inline]
    pub fn add_with_stretch<S: Sink>(
        &self,
        stretch: &Stretch,
        e: usize,
        x: &[Vec3],
        v: &[Vec3],
        sink: &mut S,
    ) {
        let Some(p) = stretch.pair(e, x, JacobianMode::Solver) else {
            return;
        };
        let s = &stretch.springs[e];
        if self.springs[e].k == 0.0 {
            sink.add_pair(e, [s.a, s.b], p.g, Some(&p.h), None);
        } else {
            let (g, damp) = self.along(e, &p.u, v);
            sink.add_pair(e, [s.a, s.b], p.g + g, Some(&p.h), Some(&damp));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::{Force, fdcheck};

    /// A spring and its damping added as one pair give the sum of the two
    /// forces' elements (to round-off), and only springs damped one for
    /// one may be added so.
    #[test]
    fn a_spring_with_its_damping_is_the_sum_of_both() {
        let (grid, x, v) = fdcheck::random_configuration(5, 4, 0.3, 7);
        let stretch = Stretch::on_grid(&grid, 2.0e4);
        let damping = SpringDamping::new(&stretch.springs, 0.01);
        assert!(damping.damps(&stretch));
        assert!(!SpringDamping::default().damps(&stretch));
        let mode = JacobianMode::Solver;
        let mut both = fdcheck::evaluate(&stretch, &x, &v, mode);
        damping.accumulate(&x, &v, mode, &mut both);
        let mut fused = fdcheck::DenseSink::new(x.len());
        for e in 0..stretch.element_count() {
            damping.add_with_stretch(&stretch, e, &x, &v, &mut fused);
        }
        let scale = both
            .dfdx
            .iter()
            .flatten()
            .map(|m| m.amax())
            .fold(0.0, Real::max);
        for i in 0..x.len() {
            assert!((both.f[i] - fused.f[i]).amax() <= 1e-12 * scale * grid.du);
            for j in 0..x.len() {
                assert!((both.dfdx[i][j] - fused.dfdx[i][j]).amax() <= 1e-12 * scale);
                assert!((both.dfdv[i][j] - fused.dfdv[i][j]).amax() <= 1e-12 * scale);
            }
        }
        // Not a vacuous comparison: the damping acts.
        assert!(fused.dfdv.iter().flatten().any(|m| m.amax() > 0.0));
    }

    #[test]
    fn spring_damping_jacobians_match_finite_differences() {
        fdcheck::check_on_random_grids(|g| {
            SpringDamping::new(&Stretch::on_grid(g, 2.0e4).springs, 0.01)
        });
    }
}
