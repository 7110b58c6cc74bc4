//! Size limits: what a spec may ask for before it is refused as absurd.
//!
//! The core's defaults stop inputs that cannot be meant (a billion particles,
//! a year of simulated time); the service tightens them per deployment and
//! the errors quote the limit in force.

/// Upper bounds applied by [`super::Spec::validate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest number of cloth particles (`nu * nv`).
    pub max_particles: usize,
    /// Largest number of obstacle triangles, summed over obstacles.
    pub max_triangles: usize,
    /// Longest simulated duration in seconds.
    pub max_duration: f64,
    /// Largest number of output frames.
    pub max_frames: usize,
    /// Largest number of solver steps (duration / dt).
    pub max_steps: usize,
    /// Largest number of obstacles: each is tested against every particle
    /// whose box it reaches, and a primitive is drawn for the stream with
    /// up to a few thousand triangles.
    pub max_obstacles: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            max_particles: 4_000_000,
            max_triangles: 10_000_000,
            max_duration: 3600.0,
            max_frames: 1_000_000,
            max_steps: 100_000_000,
            max_obstacles: 256,
        }
    }
}
