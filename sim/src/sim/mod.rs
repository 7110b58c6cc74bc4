//! The driver: builds a simulation from a validated scene and steps it to
//! frames, with statistics, progress, cancellation and checkpoints.
//!
//! ```text
//! Scene ─World::new─> World (grid, forces, pins, obstacles; fixed)
//!                       │
//!   RunState (the state; a checkpoint) ─┬─ driver: frames -> steps (fixed,
//!   Workspace (buffers)  ───────────────┘   subdivided, adaptive)
//!                                            └─ step: the table of stages
//!                                                 -> FrameStats -> RunStats
//! ```

mod apart;
mod control;
mod driver;
mod energy;
mod error;
mod pins;
mod sharp;
mod simulation;
mod stage;
mod state;
mod stats;
mod step;
mod workspace;
mod world;

pub use control::{Control, Progress};
pub use energy::ALLOWANCE as ENERGY_ALLOWANCE;
pub use error::SimError;
pub use pins::Pins;
pub use sharp::{KEEP, SharpReport};
pub use simulation::Simulation;
pub use stage::{Stage, StageClock, StageTimes};
pub use state::{Checkpoint, RunState};
pub use stats::{FrameStats, RunStats, StatsRecorder};
pub use step::{MAX_REDOS, StepReport};
pub use world::World;
