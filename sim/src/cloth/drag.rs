//! Air drag (method.md §1, external forces [4]): linear and isotropic,
//! `f_i = -c A_i v_i` with `c = material.air_drag` (kg/(m²·s)) and `A_i` the
//! particle's lumped area, so it is a per-area quantity that refines
//! consistently. `∂f/∂v = -c A_i I` enters the system matrix exactly.

use super::force::{Force, Sink};
use crate::math::{Mat3, Real, Vec3};
use crate::spec::JacobianMode;

/// Linear air drag on every particle.
#[derive(Debug, Clone, Default)]
pub struct AirDrag {
    /// `c A_i` per particle, kg/s.
    pub coefficient: Vec<Real>,
}

impl AirDrag {
    /// Drag `air_drag * area_i` on each particle.
    pub fn new(area: &[Real], air_drag: Real) -> Self {
        Self {
            coefficient: area.iter().map(|a| a * air_drag).collect(),
        }
    }
}

impl Force for AirDrag {
    fn name(&self) -> &'static str {
        "air drag"
    }

    fn energy(&self, _x: &[Vec3]) -> Option<Real> {
        None
    }

    fn for_each_element(&self, visit: &mut dyn FnMut(&[usize])) {
        for i in 0..self.coefficient.len() {
            visit(&[i]);
        }
    }

    fn element_count(&self) -> usize {
        self.coefficient.len()
    }

    fn add_element<S: Sink>(
        &self,
        i: usize,
        _x: &[Vec3],
        v: &[Vec3],
        _mode: JacobianMode,
        sink: &mut S,
    ) {
        let c = self.coefficient[i];
        if c == 0.0 {
            return;
        }
        sink.add(
            i,
            &[i],
            &[-v[i] * c],
            None,
            Some(&[[-Mat3::identity() * c]]),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::fdcheck;

    #[test]
    fn air_drag_jacobian_matches_finite_differences() {
        fdcheck::check_on_random_grids(|g| AirDrag::new(&g.area, 0.3));
    }
}
