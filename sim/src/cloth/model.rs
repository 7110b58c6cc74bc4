//! All of a cloth's force terms together, built from the grid and material.

use super::angle::AngleForce;
use super::bend::Bend;
use super::damping::SpringDamping;
use super::drag::AirDrag;
use super::force::Force;
use super::grid::Grid;
use super::shear::Shear;
use super::stretch::Stretch;
use crate::math::{Real, Vec3};
use crate::spec::MaterialParams;

/// The internal and dissipative forces of one cloth (gravity is added by the
/// solver from the masses).
#[derive(Debug, Clone, Default)]
pub struct ForceModel {
    /// Stretch springs, eq. [1].
    pub stretch: Stretch,
    /// Damping along the springs.
    pub damping: SpringDamping,
    /// Bending hinges, eq. [2].
    pub bend: AngleForce<Bend>,
    /// Shear corners, eq. [3].
    pub shear: AngleForce<Shear>,
    /// Air drag.
    pub drag: AirDrag,
}

impl ForceModel {
    /// The forces of `grid` made of `material`, nothing pinned.
    pub fn new(grid: &Grid, material: &MaterialParams) -> Self {
        Self::with_pins(grid, material, &[])
    }

    /// The forces of `grid` made of `material` with the particles marked
    /// in `pinned` held (bending is stiffer at a clamp, see [`Bend`]).
    pub fn with_pins(grid: &Grid, material: &MaterialParams, pinned: &[bool]) -> Self {
        let stretch = Stretch::on_grid(grid, material.stretch);
        let damping = SpringDamping::new(&stretch.springs, material.damping);
        Self {
            damping,
            stretch,
            bend: Bend::on_grid(grid, material.bend, material.bend_threshold, pinned),
            shear: Shear::on_grid(grid, material.shear, material.shear_threshold)
                .with_damping(material.damping),
            drag: AirDrag::new(&grid.area, material.air_drag),
        }
    }

    /// Total elastic energy (stretch + bend + shear).
    pub fn elastic_energy(&self, x: &[Vec3]) -> Real {
        [
            self.stretch.energy(x),
            self.bend.energy(x),
            self.shear.energy(x),
        ]
        .into_iter()
        .flatten()
        .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::fdcheck::{DenseSink, random_configuration};
    use crate::math::Mat3;
    use crate::spec::JacobianMode;

    fn internal_force(model: &ForceModel, x: &[Vec3]) -> Vec<Vec3> {
        let v = vec![Vec3::zeros(); x.len()];
        let mut s = DenseSink::new(x.len());
        for f in [
            &model.stretch as &dyn ForceDyn,
            &model.bend,
            &model.shear,
            &model.damping,
            &model.drag,
        ] {
            f.add_to(x, &v, &mut s);
        }
        s.f
    }

    trait ForceDyn {
        fn add_to(&self, x: &[Vec3], v: &[Vec3], s: &mut DenseSink);
    }
    impl<F: Force> ForceDyn for F {
        fn add_to(&self, x: &[Vec3], v: &[Vec3], s: &mut DenseSink) {
            self.accumulate(x, v, JacobianMode::Exact, s);
        }
    }

    /// Patch test: zero internal force at rest, and under any rigid motion
    /// of the rest state. Forces scale like `k L ~ 2e4 N/m * 0.1 m`; round-off
    /// in the angle and length evaluations is ~1e-16 of that per term, so
    /// 1e-9 N is a bound with margin that any real force would break.
    #[test]
    fn rest_state_and_rigid_motions_have_zero_internal_force() {
        let (grid, _, _) = random_configuration(7, 5, 0.0, 1);
        let material = crate::spec::preset("cotton").expect("preset");
        let model = ForceModel::new(&grid, &material);
        let rot = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 2.0);
        let shift = Vec3::new(3.0, -2.0, 0.5);
        let moved: Vec<Vec3> = grid.rest.iter().map(|p| rot * p + shift).collect();
        for x in [&grid.rest, &moved] {
            let f = internal_force(&model, x);
            let worst = f.iter().map(|f| f.norm()).fold(0.0, f64::max);
            assert!(
                worst < 1e-9,
                "internal force {worst:e} N at a rigid configuration"
            );
            assert!(model.elastic_energy(x) < 1e-20);
        }
        // Sanity: the same check fails for a non-rigid map (stretch by 1 %).
        let stretched: Vec<Vec3> = grid
            .rest
            .iter()
            .map(|p| Mat3::identity() * 1.01 * p)
            .collect();
        let f = internal_force(&model, &stretched);
        assert!(f.iter().map(|f| f.norm()).fold(0.0, f64::max) > 1.0);
    }
}
