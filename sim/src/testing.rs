//! Helpers shared by the core's unit tests.

use crate::spec::{Limits, Scene, Spec};

/// Parses and validates a JSON spec, panicking with the errors if invalid.
pub fn scene_from_json(json: &str) -> Scene {
    let spec: Spec = serde_json::from_str(json).expect("spec parses");
    spec.validate(&Limits::default()).expect("spec validates")
}

/// A cotton cloth on `grid` at `x`, `v` and its system for one backward
/// Euler step of `h` under gravity with position corrections `y`.
#[cfg(test)]
pub fn cotton_system(
    grid: &crate::cloth::Grid,
    x: &[crate::math::Vec3],
    v: &[crate::math::Vec3],
    y: &[crate::math::Vec3],
    h: crate::math::Real,
) -> (crate::cloth::ForceModel, crate::solver::System) {
    let material = crate::spec::preset("cotton").expect("preset");
    let model = crate::cloth::ForceModel::new(grid, &material);
    let mut sys = crate::solver::System::new(grid.len(), &model);
    sys.assemble(
        &model,
        &crate::solver::AssemblyInput {
            x,
            predicted: false,
            v,
            y,
            mass: &grid.mass,
            gravity: crate::math::Vec3::new(0.0, 0.0, -9.81),
            scheme: crate::solver::Scheme::euler(h),
        },
    );
    (model, sys)
}

/// A flat `nu` x `nv` grid of `size` metres in the `xy` plane from the
/// origin, of areal density 0.1 kg/m², nothing pinned.
#[cfg(test)]
pub fn flat_grid(nu: usize, nv: usize, size: [crate::math::Real; 2]) -> crate::cloth::Grid {
    use crate::math::Vec3;
    crate::cloth::Grid::new(
        &crate::spec::ClothScene {
            nu,
            nv,
            size,
            origin: Vec3::zeros(),
            u: Vec3::x(),
            v: Vec3::y(),
            pinned: vec![],
            pin_group: vec![],
            pin_motions: vec![],
            self_thickness: None,
        },
        0.1,
    )
}

/// A strip of `nu` x `nv` particles `s` apart folded back over itself:
/// the columns from `nu / 2` on mirrored over the first half, shifted
/// `shift` spacings along it and lifted `lift` spacings above it.
#[cfg(test)]
pub fn folded_strip(
    nu: usize,
    nv: usize,
    s: crate::math::Real,
    shift: crate::math::Real,
    lift: crate::math::Real,
) -> Vec<crate::math::Vec3> {
    use crate::math::{Real, Vec3};
    (0..nu * nv)
        .map(|k| {
            let (i, j) = (k % nu, k / nu);
            let (u, z) = if i < nu / 2 {
                (i as Real, 0.0)
            } else {
                ((nu - 1 - i) as Real + shift, lift)
            };
            Vec3::new(u, j as Real, z) * s
        })
        .collect()
}
