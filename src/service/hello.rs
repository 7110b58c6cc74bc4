//! The stream's `hello` message: what a viewer needs before the first
//! frame — the grid's shape and triangles, and each obstacle as a
//! triangle mesh (at its pose at time 0; each frame's `stats` carries the
//! poses after that).
//!
//! Built once at submission and stored with the job, so every stream of
//! the job, live or replayed, starts with the same message.

use drapery_sim::cloth::Grid;
use drapery_sim::collision::display_mesh;
use drapery_sim::spec::{Scene, SpecError};
use serde_json::json;

/// The hello message of job `id` running `scene`, as JSON text.
pub fn build(scene: &Scene, id: &str) -> Result<String, SpecError> {
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
        let vertices: Vec<[f32; 3]> = mesh
            .vertices()
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect();
        obstacles.push(json!({
            "vertices": vertices,
            "triangles": mesh.triangles(),
            "moving": o.motion.is_some(),
        }));
    }
    Ok(json!({
        "type": "hello",
        "job": id,
        "name": scene.name,
        "grid": [grid.nu, grid.nv],
        "vertices": grid.len(),
        "frames": scene.frames + 1,
        "fps": scene.fps,
        "duration": scene.duration,
        "triangles": grid.triangles(),
        "obstacles": obstacles,
    })
    .to_string())
}
