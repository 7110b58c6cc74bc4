//! What a scene builds once and every step reads but never changes: the
//! grid, its forces, the pins and the obstacles.

use super::error::SimError;
use super::pins::Pins;
use crate::cloth::{ForceModel, Grid};
use crate::collision::Obstacles;
use crate::math::Real;
use crate::solver::Physics;
use crate::spec::Scene;

/// The fixed part of a simulation.
#[derive(Debug)]
pub struct World {
    /// The validated scene.
    pub scene: Scene,
    /// The particle grid with rest positions and lumped masses.
    pub grid: Grid,
    /// The cloth's forces.
    pub model: ForceModel,
    /// Pinned particles and their motions.
    pub pins: Pins,
    /// The obstacles; `None` when the scene has none (or collision is
    /// switched off): then there is no collision stage at all.
    pub obstacles: Option<Obstacles>,
}

impl World {
    /// Builds the cloth, its forces, the pins and the obstacles of `scene`.
    pub fn new(scene: &Scene) -> Result<Self, SimError> {
        let grid = Grid::new(&scene.cloth, scene.material.density);
        let pins = Pins::new(&scene.cloth, grid.len());
        let model = ForceModel::with_pins(&grid, &scene.material, pins.mask());
        let obstacles = obstacles_of(scene, &grid)?;
        Ok(Self {
            scene: scene.clone(),
            grid,
            model,
            pins,
            obstacles,
        })
    }

    /// Whether `scene` can be built: its obstacles, and a cloth that does
    /// not start inside one (the errors [`World::new`] would give), without
    /// building the rest.
    pub fn check(scene: &Scene) -> Result<(), SimError> {
        let grid = Grid::new(&scene.cloth, scene.material.density);
        obstacles_of(scene, &grid).map(|_| ())
    }

    /// The physical inputs of a step.
    pub fn physics(&self) -> Physics<'_> {
        Physics {
            model: &self.model,
            mass: &self.grid.mass,
            gravity: self.scene.gravity,
        }
    }
}

/// The obstacles of `scene` for `grid` (none with collision switched off),
/// refusing a cloth that starts inside one.
fn obstacles_of(scene: &Scene, grid: &Grid) -> Result<Option<Obstacles>, SimError> {
    if !scene.solver.collision {
        return Ok(None);
    }
    // NOTE: the offset follows the finer spacing: a grid resolves the
    // drape along its fine direction, and a strip spaced 1 mm along and
    // 5 mm across must not float 2 mm above its support.
    let obstacles =
        Obstacles::new(&scene.obstacles, grid.du.min(grid.dv)).map_err(|(index, e)| {
            SimError::Obstacle {
                index,
                message: e.to_string(),
            }
        })?;
    if let Some(o) = &obstacles {
        refuse_starting_inside(o, grid)?;
    }
    Ok(obstacles)
}

/// How far a particle may start inside an obstacle: round-off of a cloth
/// laid exactly on a surface, nothing a user means.
const START_INSIDE_TOLERANCE: Real = 1e-9;

/// A cloth that starts inside an obstacle is refused, naming the
/// obstacle and the deepest particle. Nothing it could do would be right:
/// pushed out a tenth of the spacing a step (`collision::obstacles`), the
/// cloth gathers the springs' pull into speed and is thrown off (a sheet
/// through a 5 cm rod left at 36 m/s), and a solid it cannot leave (it
/// cuts through a sphere, or lies inside a box) tears it.
fn refuse_starting_inside(obstacles: &Obstacles, grid: &Grid) -> Result<(), SimError> {
    match obstacles.deepest_inside(&grid.rest, 0.0, START_INSIDE_TOLERANCE) {
        None => Ok(()),
        Some((index, particle, depth)) => Err(SimError::Obstacle {
            index,
            message: format!(
                "the cloth starts inside it: particle [{}, {}] is {depth:.3e} m inside its surface \
                 (start the cloth outside every obstacle)",
                particle % grid.nu,
                particle / grid.nu
            ),
        }),
    }
}
