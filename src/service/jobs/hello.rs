//! The stream's `hello` message of a job: what a viewer needs before the
//! first frame — the grid's shape and triangles, and each obstacle as a
//! triangle mesh (at its pose at time 0; each frame's `stats` carries the
//! poses after that).
//!
//! Built once at submission and stored with the job, so every stream of
//! the job, live or replayed, starts with the same message.

use drapery_sim::cloth::Grid;
use drapery_sim::collision::display_mesh;
use drapery_sim::spec::{Scene, SpecError};

use crate::service::job::JobId;
use crate::service::protocol::{Hello, ObstacleMesh};

/// The hello of job `id` running `scene`; an obstacle that cannot be drawn
/// is an error at its spec path.
pub fn build(scene: &Scene, id: JobId) -> Result<Hello, SpecError> {
    let grid = Grid::new(&scene.cloth, scene.material.density);
    let diagonal = (scene.cloth.size[0].powi(2) + scene.cloth.size[1].powi(2)).sqrt();
    // Smooth enough to look round, coarse enough to stay small: about a
    // hundred edges across the cloth, never finer than its particles.
    let edge = (diagonal / 100.0).max(grid.du.min(grid.dv));
    let mut obstacles = Vec::with_capacity(scene.obstacles.len());
    for (k, o) in scene.obstacles.iter().enumerate() {
        let mesh = display_mesh(o, edge, 2.0 * diagonal).map_err(|e| SpecError {
            path: format!("obstacles[{k}]"),
            message: e.to_string(),
        })?;
        obstacles.push(ObstacleMesh {
            vertices: mesh
                .vertices()
                .iter()
                .map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect(),
            triangles: mesh.triangles().to_vec(),
            moving: o.motion.is_some(),
        });
    }
    Ok(Hello {
        job: id.to_string(),
        name: scene.name.clone(),
        grid: [grid.nu, grid.nv],
        vertices: grid.len(),
        frames: scene.frames + 1,
        fps: scene.fps,
        duration: scene.duration,
        triangles: grid.triangles(),
        obstacles,
    })
}
