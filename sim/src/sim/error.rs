//! Why a run stopped early.

/// A run that did not complete.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A step produced NaN or infinity.
    #[error("non-finite {quantity} at step {step} (t = {time:.6} s), particle {particle}")]
    NonFinite {
        /// The step (counted from 0) that failed.
        step: usize,
        /// Simulated time at the start of that step.
        time: f64,
        /// The first offending particle.
        particle: usize,
        /// What was not finite.
        quantity: &'static str,
    },
    /// The cancel flag was set.
    #[error("cancelled at step {step}")]
    Cancelled {
        /// Steps completed before stopping.
        step: usize,
    },
    /// An obstacle could not be built (a mesh that validation should have
    /// refused).
    #[error("obstacles[{index}]: {message}")]
    Obstacle {
        /// The obstacle's index in the scene.
        index: usize,
        /// What was wrong.
        message: String,
    },
    /// A checkpoint does not fit the scene.
    #[error("checkpoint {0}")]
    Checkpoint(String),
    /// The frame consumer failed (for example, a disk write).
    #[error("frame output failed: {0}")]
    Output(String),
}
