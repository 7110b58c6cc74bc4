//! What a scene builds once and every step reads but never changes: the
//! grid, its forces, the pins and the obstacles.

use super::error::SimError;
use super::pins::Pins;
use crate::cloth::{ForceModel, Grid};
use crate::collision::Obstacles;
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
        // NOTE: the offset follows the finer spacing: a grid resolves the
        // drape along its fine direction, and a strip spaced 1 mm along and
        // 5 mm across must not float 2 mm above its support.
        let obstacles = if scene.solver.collision {
            Obstacles::new(&scene.obstacles, grid.du.min(grid.dv)).map_err(|(index, e)| {
                SimError::Obstacle {
                    index,
                    message: e.to_string(),
                }
            })?
        } else {
            None
        };
        Ok(Self {
            scene: scene.clone(),
            grid,
            model,
            pins,
            obstacles,
        })
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
