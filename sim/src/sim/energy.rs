//! BDF2's energy guard: a step that gains energy is redone as two halves.
//!
//! BDF2 is A-stable for linear systems, but it linearises the forces once
//! about its prediction (plus one Newton correction), and where that
//! linearisation is poor — a crumpled cloth whose stiff springs buckle
//! and unbuckle within a step, a free corner whipping round — the step
//! can end with more energy than it started with although nothing did
//! work on the cloth: a crumpled cloth in zero gravity gained 56 % of its
//! kinetic and elastic energy in one step, hanging-corners 7 % at its
//! whip (docs/benchmarks.md, section 1w). The driver then redoes the step
//! as two halves (`Driver::guarded_step`, as for a step that
//! overstretches), which resolve what one step could not. Redoing it by
//! backward Euler instead does not help: from the states BDF2 leaves, an
//! Euler step gained energy too (all 27 redos on hanging-corners), so the
//! guard watches BDF2's Euler restarts as well.
//!
//! What counts as a gain. The energy is `E = 1/2 Σ m v² + U(x) − Σ m g·x`
//! (`U` the stretch, shear and bend energies). Moving pins do work on the
//! cloth; the guard compares the step's end against its start with every
//! pinned particle already where and how fast the pins hold it at the end
//! (the pins' work credited up front), which is exactly the state a
//! backward Euler step of the pinned cloth starts from. Drag and the
//! material's damping only take energy out. Obstacles can put energy in
//! (a moving obstacle, a position correction out of an offset surface), so
//! the guard is for the steps of a cloth without obstacles. Layers of the
//! cloth pushed apart by self-collision's couplings gain energy the guard
//! does not count (the couplings' springs are not part of `U`); such a
//! step may be halved when it need not be, at most down to a sixteenth.
//!
//! A step is redone when it gains more than [`ALLOWANCE`] of the cloth's
//! kinetic plus elastic energy at its start: BDF2's own energy wobbles by
//! less than that on a resolved swing (gravity's part of `E` depends on
//! where its zero is, so it is not part of the scale).

use super::world::World;
use crate::math::{Real, Vec3};
use crate::solver::ClothState;

/// The share of the kinetic plus elastic energy a step of a BDF2 cloth
/// may gain before it is redone as two halves.
pub const ALLOWANCE: Real = 1e-3;

/// The guard's buffers, reused across steps: the start with the pins
/// moved, and the last state measured with its energy (a step's end is
/// the next step's start: measured once, not twice).
#[derive(Debug, Clone, Default)]
pub struct EnergyGuard {
    start: ClothState,
    last: ClothState,
    last_energy: Option<(Real, Real)>,
}

impl EnergyGuard {
    /// Whether the step from `start` to `end` gained more energy than
    /// [`ALLOWANCE`] allows, with the pinned particles of `start` moved to
    /// their place and speed at `end` first.
    pub fn gained(&mut self, world: &World, start: &ClothState, end: &ClothState) -> bool {
        self.start.clone_from(start);
        for (k, &held) in world.pins.mask().iter().enumerate() {
            if held {
                self.start.x[k] = end.x[k];
                self.start.v[k] = end.v[k];
            }
        }
        let (e0, scale) = match self.last_energy {
            Some(e) if self.last.x == self.start.x && self.last.v == self.start.v => e,
            _ => energy(world, &self.start.x, &self.start.v),
        };
        let e1 = energy(world, &end.x, &end.v);
        self.last.clone_from(end);
        self.last_energy = Some(e1);
        e1.0 - e0 > ALLOWANCE * scale
    }
}

/// The cloth's energy at `(x, v)` and its scale: `(E, kinetic + elastic)`.
fn energy(world: &World, x: &[Vec3], v: &[Vec3]) -> (Real, Real) {
    let mut kinetic = 0.0;
    let mut height = 0.0;
    for ((x, v), m) in x.iter().zip(v).zip(&world.grid.mass) {
        kinetic += 0.5 * m * v.norm_squared();
        height -= m * world.scene.gravity.dot(x);
    }
    let active = kinetic + world.model.elastic_energy(x);
    (active + height, active)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::scene_from_json;

    /// A 5 x 5 cloth in zero gravity with its first particle pinned.
    fn world() -> World {
        World::new(&scene_from_json(
            r#"{"cloth": {"grid": [5, 5], "size": [0.4, 0.4], "pinned": [[0, 0]]},
                "material": "cotton", "gravity": [0, 0, 0], "duration": 0.1, "fps": 10,
                "solver": {"integrator": "bdf2"}}"#,
        ))
        .expect("builds")
    }

    fn rest(world: &World) -> ClothState {
        ClothState {
            time: 0.0,
            x: world.grid.rest.clone(),
            v: vec![Vec3::zeros(); world.grid.len()],
        }
    }

    /// A pin that moves and drags its springs long does work the guard
    /// credits; a free particle sped up from nothing is a gain; and a
    /// gain within the allowance passes.
    #[test]
    fn pins_work_is_credited_and_free_gains_are_caught() {
        let world = world();
        let start = rest(&world);
        let mut guard = EnergyGuard::default();
        assert!(!guard.gained(&world, &start, &start));
        // The pin pulled 1 cm away at 1 m/s: its springs store energy
        // and it moves, all the pin's work.
        let mut pulled = start.clone();
        pulled.x[0].x -= 0.01;
        pulled.v[0].x = -1.0;
        assert!(!guard.gained(&world, &start, &pulled));
        // A free particle given speed: a gain of its kinetic energy over
        // a start with none.
        let mut kicked = start.clone();
        kicked.v[12].z = 0.1;
        assert!(guard.gained(&world, &start, &kicked));
        // A kick adding a few millionths of the energy of a cloth already
        // moving: below the allowance.
        let mut moving = pulled.clone();
        for v in &mut moving.v[1..] {
            v.z = 10.0 / (world.grid.len() as Real - 1.0).sqrt();
        }
        let mut kicked = moving.clone();
        kicked.v[12].z += 1e-4;
        assert!(!guard.gained(&world, &moving, &kicked));
        // Cached: the end measured last is the start of the next check.
        assert!(guard.gained(&world, &kicked, &{
            let mut more = kicked.clone();
            more.v[12].z += 1.0;
            more
        }));
    }
}
