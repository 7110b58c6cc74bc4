//! The validated scene: every default applied, every number checked.

use super::material::MaterialParams;
use super::obstacle::Obstacle;
use super::types::{IntegratorKind, PreconditionerKind, StoppingRule};
use crate::math::{Real, Vec3};

/// A scene ready to simulate; only [`super::Spec::validate`] makes one.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The spec's name, or `"untitled"`.
    pub name: String,
    /// The particle grid.
    pub cloth: ClothScene,
    /// Resolved material parameters.
    pub material: MaterialParams,
    /// Obstacles as specified (validated).
    pub obstacles: Vec<Obstacle>,
    /// Gravitational acceleration.
    pub gravity: Vec3,
    /// Simulated time in seconds.
    pub duration: Real,
    /// Output frames per second.
    pub fps: Real,
    /// Number of frames after the initial one (frame 0 is `t = 0`).
    pub frames: usize,
    /// Time stepping and linear solver settings.
    pub solver: SolverScene,
}

impl Scene {
    /// Time between output frames.
    pub fn frame_dt(&self) -> Real {
        1.0 / self.fps
    }

    /// The largest step the scene's stepping takes: a fixed step (halved
    /// when a step overstretches, never lengthened), or a frame, the
    /// coarsest adaptive step.
    pub fn largest_step(&self) -> Real {
        match self.solver.stepping {
            TimeStepping::Fixed { substeps } => self.frame_dt() / substeps as Real,
            TimeStepping::Adaptive { .. } => self.frame_dt(),
        }
    }
}

/// The cloth grid with directions normalised and pins as particle indices.
#[derive(Debug, Clone, PartialEq)]
pub struct ClothScene {
    /// Particles along `u`.
    pub nu: usize,
    /// Particles along `v`.
    pub nv: usize,
    /// Lengths along `u` and `v`.
    pub size: [Real; 2],
    /// Position of particle `(0, 0)`.
    pub origin: Vec3,
    /// Unit warp direction.
    pub u: Vec3,
    /// Unit weft direction, perpendicular to `u`.
    pub v: Vec3,
    /// Pinned particle indices (`i + j * nu`), sorted, without repeats.
    pub pinned: Vec<usize>,
    /// For each of `pinned`, the index in `pin_motions` of the motion it
    /// follows; `None`: held where it starts.
    pub pin_group: Vec<Option<usize>>,
    /// The motions of moving pin groups.
    pub pin_motions: Vec<super::Motion>,
    /// Self-collision's thickness, metres; `None`: no self-collision.
    pub self_thickness: Option<Real>,
}

/// Solver settings with defaults applied.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverScene {
    /// How steps are sized.
    pub stepping: TimeStepping,
    /// Relative residual tolerance of the modified PCG.
    pub tolerance: Real,
    /// Whether the solver's error estimate may stop it earlier.
    pub stopping: StoppingRule,
    /// Iteration cap of the modified PCG.
    pub max_iterations: usize,
    /// The preconditioner.
    pub preconditioner: PreconditionerKind,
    /// The time integrator.
    pub integrator: IntegratorKind,
    /// Start each solve from the previous step's velocity change.
    pub warm_start: bool,
    /// Run the collision stage.
    pub collision: bool,
}

/// How the frame interval is divided into steps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStepping {
    /// `substeps` equal steps per frame: `dt = frame_dt / substeps`, the
    /// largest such step not above the requested one.
    Fixed {
        /// Steps per frame.
        substeps: usize,
    },
    /// Steps of `frame_dt / 2^level`, `level` in `0..=max_level`, halved on
    /// trouble and doubled back after a run of easy steps.
    Adaptive {
        /// Deepest subdivision before the controller gives up.
        max_level: u32,
        /// The position error a frame may add, metres.
        error: Real,
    },
}
