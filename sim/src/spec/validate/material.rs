//! `material`: a preset name or physical parameters.

use super::check::Check;
use crate::spec::material::{MaterialParams, MaterialSpec, PRESETS, preset};

pub(super) fn validate_material(m: &MaterialSpec, c: &mut Check) -> Option<MaterialParams> {
    let p = match m {
        MaterialSpec::Preset(name) => match preset(name) {
            Some(p) => return Some(p),
            None => {
                let names: Vec<&str> = PRESETS.iter().map(|(n, _)| *n).collect();
                c.fail(
                    "material",
                    format!(
                        "unknown preset {name:?}; expected one of {}",
                        names.join(", ")
                    ),
                );
                return None;
            }
        },
        MaterialSpec::Params(p) => p,
    };
    let checks = [
        ("material.density", p.density, true, 100.0),
        ("material.stretch", p.stretch, true, 1.0e9),
        ("material.shear", p.shear, false, 1.0e9),
        ("material.bend", p.bend, false, 1.0e3),
        ("material.bend_threshold", p.bend_threshold, false, 1.0e3),
        ("material.shear_threshold", p.shear_threshold, false, 1.0e9),
        ("material.damping", p.damping, false, 10.0),
        ("material.air_drag", p.air_drag, false, 1.0e4),
    ];
    let mut ok = true;
    for (path, x, positive, hi) in checks {
        ok &= c.range(path, x, positive, hi);
    }
    ok.then_some(*p)
}
