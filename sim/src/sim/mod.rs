//! The driver: builds a simulation from a validated scene and steps it to
//! frames, with statistics, progress, cancellation and non-finite detection.
//!
//! ```text
//! Scene -> Simulation::new -> (advance_frame)* -> FrameStats per frame -> RunStats
//! ```

mod checkpoint;
mod control;
mod error;
mod simulation;
mod stats;

pub use checkpoint::Checkpoint;
pub use control::{Control, Progress};
pub use error::SimError;
pub use simulation::Simulation;
pub use stats::{FrameStats, RunStats, StatsRecorder};
