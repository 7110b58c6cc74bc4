//! The stream's `hello` message of a job: what a viewer needs before the
//! first frame — the grid's shape and triangles, and each obstacle as a
//! triangle mesh (at its pose at time 0; each frame's `stats` carries the
//! poses after that).
//!
//! Built when the job first starts and stored with it, so every stream of
//! the job, live or replayed, starts with the same message; a stream of a
//! job that never ran builds it (the same, from the same spec) without
//! storing it. Submission only checks that every obstacle can be drawn.

use drapery_sim::cloth::Grid;
use drapery_sim::collision::display_mesh;
use drapery_sim::spec::{Obstacle, Scene, SpecError};

use super::error::Fault;
use super::lifecycle::Jobs;
use crate::service::job::JobId;
use crate::service::protocol::{Hello, ObstacleMesh, StreamMessage};
use crate::service::store::JobRow;

/// A primitive's display mesh has edges at least its size over this: a
/// sphere of any radius is at most ~50 x 100 quads, whatever the cloth.
const PRIMITIVE_SEGMENTS: f64 = 16.0;

/// Checks that every obstacle of `scene` can be drawn, without building
/// the whole hello: one display mesh at a time.
pub fn check(scene: &Scene) -> Result<(), SpecError> {
    obstacle_meshes(scene).try_for_each(|m| m.map(drop))
}

/// The hello of job `id` running `scene`; an obstacle that cannot be drawn
/// is an error at its spec path.
pub fn build(scene: &Scene, id: JobId) -> Result<Hello, SpecError> {
    let grid = Grid::new(&scene.cloth, scene.material.density);
    Ok(Hello {
        job: id.to_string(),
        name: scene.name.clone(),
        grid: [grid.nu, grid.nv],
        vertices: grid.len(),
        frames: scene.frames + 1,
        fps: scene.fps,
        duration: scene.duration,
        triangles: grid.triangles(),
        obstacles: obstacle_meshes(scene).collect::<Result<_, _>>()?,
    })
}

/// Each obstacle's display mesh, built as the iterator is advanced.
fn obstacle_meshes(scene: &Scene) -> impl Iterator<Item = Result<ObstacleMesh, SpecError>> {
    let [su, sv] = scene.cloth.size;
    let diagonal = (su.powi(2) + sv.powi(2)).sqrt();
    let spacing = (su / (scene.cloth.nu as f64 - 1.0)).min(sv / (scene.cloth.nv as f64 - 1.0));
    // Smooth enough to look round, coarse enough to stay small: about a
    // hundred edges across the cloth, never finer than its particles, and
    // never more than a few thousand triangles for a primitive however
    // large it is beside the cloth (`cost::DISPLAY_TRIANGLES`).
    let edge = (diagonal / 100.0).max(spacing);
    scene.obstacles.iter().enumerate().map(move |(k, o)| {
        let edge = edge.max(primitive_size(o) / PRIMITIVE_SEGMENTS);
        let mesh = display_mesh(o, edge, 2.0 * diagonal).map_err(|e| SpecError {
            path: format!("obstacles[{k}]"),
            message: e.to_string(),
        })?;
        Ok(ObstacleMesh {
            vertices: mesh
                .vertices()
                .iter()
                .map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect(),
            triangles: mesh.triangles().to_vec(),
            moving: o.motion.is_some(),
        })
    })
}

/// A primitive's largest extent (0 for a mesh or a plane, whose display
/// sizes are their own).
fn primitive_size(o: &Obstacle) -> f64 {
    let max3 = |v: [f64; 3]| v[0].max(v[1]).max(v[2]);
    if let Some(s) = &o.sphere {
        std::f64::consts::PI * s.radius
    } else if let Some(b) = &o.box_ {
        max3(b.size)
    } else if let Some(c) = &o.cylinder {
        (std::f64::consts::TAU * c.radius).max(c.height)
    } else {
        0.0
    }
}

impl Jobs {
    /// Job `id`'s hello message: the stored one, or for a job that never
    /// started, one built from its spec (not stored).
    pub(super) fn hello_of(&self, id: JobId) -> Result<String, Fault> {
        if let Some(stored) = self.store.hello(id)?
            && !stored.is_empty()
        {
            return Ok(stored);
        }
        let row = self.store.job(id)?.ok_or(Fault::Vanished(id))?;
        hello_message(&row)
    }

    /// Stores the hello of a job that starts for the first time.
    pub(super) fn store_hello(&self, row: &JobRow) -> Result<(), Fault> {
        if self.store.hello(row.id)?.is_some_and(|h| !h.is_empty()) {
            return Ok(());
        }
        let hello = hello_message(row)?;
        Ok(self.store.set_hello(row.id, &hello)?)
    }
}

/// The hello message of a stored job, as sent.
fn hello_message(row: &JobRow) -> Result<String, Fault> {
    let fault = |message: String| Fault::Hello {
        id: row.id,
        message,
    };
    let scene = row.scene().map_err(|e| fault(e.to_string()))?;
    let hello = build(&scene, row.id).map_err(|e| fault(e.to_string()))?;
    Ok(StreamMessage::Hello(hello).to_json())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::cost::DISPLAY_TRIANGLES;

    /// The cost model's bound on a primitive's display mesh holds for every
    /// kind, from far smaller than the cloth's spacing to far larger than
    /// the cloth.
    #[test]
    fn a_primitive_is_drawn_within_the_cost_models_triangles() {
        let cloths = [(0.01, 200), (1.0, 30), (1.0, 400), (100.0, 10)];
        let shapes = [
            r#"{"sphere": {"center": [0, 0, -50], "radius": R}}"#,
            r#"{"box": {"center": [0, 0, -50], "size": [R, R, R]}}"#,
            r#"{"box": {"center": [0, 0, -50], "size": [R, 0.001, 0.001]}}"#,
            r#"{"cylinder": {"center": [0, 0, -50], "axis": [0, 0, 1], "radius": R, "height": 1}}"#,
            r#"{"plane": {"point": [0, 0, -50], "normal": [0, 1, 1]}}"#,
        ];
        for (size, n) in cloths {
            for shape in shapes {
                for r in ["0.001", "0.3", "20"] {
                    let spec = format!(
                        r#"{{"cloth": {{"grid": [{n}, {n}], "size": [{size}, {size}], "origin": [0, 0, 0]}},
                            "material": "cotton", "duration": 0.1, "fps": 10,
                            "obstacles": [{}]}}"#,
                        shape.replace('R', r)
                    );
                    let scene = crate::specfile::load(&spec, &Default::default()).expect(&spec);
                    let mesh = obstacle_meshes(&scene).next().expect("one").expect("drawn");
                    assert!(
                        mesh.triangles.len() as f64 <= DISPLAY_TRIANGLES,
                        "{} triangles: {spec}",
                        mesh.triangles.len()
                    );
                }
            }
        }
    }
}
