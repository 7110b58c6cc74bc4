//! [`Spec::validate`]: every rule, every error with its field path. One
//! file per part of the spec; [`Check`] collects the errors.

mod check;
mod cloth;
mod material;
mod obstacle;
mod solver;

use super::error::SpecErrors;
use super::limits::Limits;
use super::scene::Scene;
use super::types::Spec;
use crate::math::Vec3;
use check::Check;

impl Spec {
    /// Checks every field against the rules and `limits`, returning the
    /// ready scene or every error found (never just the first).
    pub fn validate(&self, limits: &Limits) -> Result<Scene, SpecErrors> {
        let mut c = Check::default();
        if let Some(name) = &self.name
            && name.chars().count() > 200
        {
            c.fail("name", "must be at most 200 characters");
        }
        let cloth = cloth::validate_cloth(self, limits, &mut c);
        let material = material::validate_material(&self.material, &mut c);
        // An acceleration, not a place: bounded by its magnitude alone (a
        // component past the coordinates' bound in metres was named so).
        let mut finite = true;
        for (k, &x) in self.gravity.iter().enumerate() {
            finite &= c.finite(&format!("gravity[{k}]"), x);
        }
        let g = Vec3::from(self.gravity);
        let gravity = if !finite {
            None
        } else if g.norm() > 1000.0 {
            c.fail("gravity", "must have magnitude <= 1000 m/s²");
            None
        } else {
            Some(g)
        };
        if self.obstacles.len() > limits.max_obstacles {
            // Not looked into: each could be a mesh to build.
            c.fail(
                "obstacles",
                format!(
                    "{} obstacles exceeds the limit of {}",
                    self.obstacles.len(),
                    limits.max_obstacles
                ),
            );
        } else {
            let mut triangles = 0;
            for (k, o) in self.obstacles.iter().enumerate() {
                let path = format!("obstacles[{k}]");
                obstacle::validate_obstacle(&path, o, limits, &mut triangles, &mut c);
            }
        }
        let frames = solver::validate_timing(self, limits, &mut c);
        let solver = solver::validate_solver(self, limits, frames, &mut c);

        match (cloth, material, gravity, frames, solver) {
            (Some(cloth), Some(material), Some(gravity), Some(frames), Some(solver))
                if c.errors.is_empty() =>
            {
                Ok(Scene {
                    name: self.name.clone().unwrap_or_else(|| "untitled".into()),
                    cloth,
                    material,
                    obstacles: self.obstacles.clone(),
                    gravity,
                    duration: self.duration,
                    fps: self.fps,
                    frames,
                    solver,
                })
            }
            _ => Err(SpecErrors(c.errors)),
        }
    }
}
