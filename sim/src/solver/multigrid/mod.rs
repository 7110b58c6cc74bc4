//! Geometric multigrid for the cloth's grid (speed issue: CG iterations
//! flat in the number of particles): structured block matrices, bilinear
//! transfers with Galerkin coarse operators, line relaxation, a dense
//! coarsest solve, and the V-cycle preconditioner over them.

mod dense;
mod grid_matrix;
mod hierarchy;
mod lanes;
mod line_factor;
mod lines;
mod symmetric;
mod transfer;

pub use grid_matrix::{Block, GridMatrix, Vec3f};
pub use hierarchy::{CycleShape, Multigrid};
pub use lines::{Direction, Entry, LineFamily, LineScratch};
pub use symmetric::symmetric_sweep;
pub use transfer::{Axis, Transfer};
