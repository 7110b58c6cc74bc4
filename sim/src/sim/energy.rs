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
//! (`U` the stretch, shear and bend energies). Drag and the material's
//! damping only take energy out, and pins held still do no work, so any
//! gain is the step's own. Obstacles can put energy in (a moving obstacle,
//! a position correction out of an offset surface), and so can moving
//! pins; their work over a step is not known to the precision the test
//! needs (crediting it as if the pins jumped to their end first let a
//! cloth shaken by its pins halve 578 steps and stretch 163 %,
//! docs/benchmarks.md 1w), so the guard is for a cloth without obstacles
//! whose pins, if any, hold still. Layers of the cloth pushed apart by
//! self-collision's couplings gain energy the guard does not count (the
//! couplings' springs are not part of `U`); such a step may be halved
//! when it need not be, at most down to a sixteenth.
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

/// The guard's memory: the last state measured and its energy (a step's
/// end is the next step's start: measured once, not twice).
#[derive(Debug, Clone, Default)]
pub struct EnergyGuard {
    last: ClothState,
    last_energy: Option<(Real, Real)>,
}

impl EnergyGuard {
    /// Whether the step from `start` to `end` gained more energy than
    /// [`ALLOWANCE`] allows.
    pub fn gained(&mut self, world: &World, start: &ClothState, end: &ClothState) -> bool {
        let (e0, scale) = match self.last_energy {
            Some(e) if self.last.x == start.x && self.last.v == start.v => e,
            _ => energy(world, &start.x, &start.v),
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

    /// A free particle sped up from rest is a gain; a small kick to a
    /// cloth already moving is within the allowance; a state measured as
    /// a step's end serves as the next step's start.
    #[test]
    fn gains_beyond_the_allowance_are_caught() {
        let world = world();
        let start = rest(&world);
        let mut guard = EnergyGuard::default();
        assert!(!guard.gained(&world, &start, &start));
        // A free particle given speed: a gain of its kinetic energy over
        // a start with none.
        let mut kicked = start.clone();
        kicked.v[12].z = 0.1;
        assert!(guard.gained(&world, &start, &kicked));
        // A kick adding a few millionths of the energy of a cloth already
        // moving: below the allowance.
        let mut moving = start.clone();
        for v in &mut moving.v[1..] {
            v.z = 10.0 / (world.grid.len() as Real - 1.0).sqrt();
        }
        let mut kicked = moving.clone();
        kicked.v[12].z += 1e-4;
        assert!(!guard.gained(&world, &moving, &kicked));
        // The end measured last is the start of the next check, and slowing
        // down is no gain.
        let mut slower = kicked.clone();
        slower.v[12].z = 0.0;
        assert!(!guard.gained(&world, &kicked, &slower));
        let mut faster = slower.clone();
        faster.v[12].z = 3.0;
        assert!(guard.gained(&world, &slower, &faster));
    }
}
