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
use super::stretch::Spring;
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
        let dv = v[s.a] - v[s.b];
        let rate = u.dot(&dv);
        let c = s.k;
        let damp = outer(&u, &u) * c;
        let dfdx = match mode {
            JacobianMode::Solver => None,
            JacobianMode::Exact => {
                let p = Mat3::identity() - outer(&u, &u);
                Some((u * (dv.transpose() * p) + p * rate) * (c / l))
            }
        };
        sink.add_pair(e, [s.a, s.b], u * (c * rate), dfdx.as_ref(), Some(&damp));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::{Stretch, fdcheck};

    #[test]
    fn spring_damping_jacobians_match_finite_differences() {
        fdcheck::check_on_random_grids(|g| {
            SpringDamping::new(&Stretch::on_grid(g, 2.0e4).springs, 0.01)
        });
    }
}
