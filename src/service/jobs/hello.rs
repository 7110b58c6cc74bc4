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
/// the whole hello.
pub fn check(scene: &Scene) -> Result<(), SpecError> {
    obstacle_meshes(scene).map(drop)
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
        obstacles: obstacle_meshes(scene)?,
    })
}

fn obstacle_meshes(scene: &Scene) -> Result<Vec<ObstacleMesh>, SpecError> {
    let [su, sv] = scene.cloth.size;
    let diagonal = (su.powi(2) + sv.powi(2)).sqrt();
    let spacing = (su / (scene.cloth.nu as f64 - 1.0)).min(sv / (scene.cloth.nv as f64 - 1.0));
    // Smooth enough to look round, coarse enough to stay small: about a
    // hundred edges across the cloth, never finer than its particles, and
    // never more than a few thousand triangles for a primitive however
    // large it is beside the cloth.
    let edge = (diagonal / 100.0).max(spacing);
    let mut obstacles = Vec::with_capacity(scene.obstacles.len());
    for (k, o) in scene.obstacles.iter().enumerate() {
        let edge = edge.max(primitive_size(o) / PRIMITIVE_SEGMENTS);
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
    Ok(obstacles)
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
