//! The implicit Euler step of method.md §2, solved by the modified PCG.
//!
//! ```text
//! constraints (S, z, y)  ─┐
//! forces + Jacobians ─────┼─> assemble A dv = b  (eq. [20])  ─> precondition ─> MPCG ─> update x, v
//! masses, gravity  ───────┘
//! ```
//!
//! - [`BlockCsr`]: symmetric block-sparse matrix, pattern built once per
//!   topology, values rewritten in place every step.
//! - [`System`]: assembly of `A = M - h D - h² K` and
//!   `b = h (f0 + K (h v0 + y))`.
//! - [`Constraints`]: per-particle filters `S_i`, targets `z_i`, position
//!   corrections `y_i` (pins now; contacts use the same seam).
//! - [`mpcg`]: the modified preconditioned conjugate gradient (Baraff &
//!   Witkin 1998 §5) behind the [`Preconditioner`] trait.
//! - [`Integrator`]: one step, with its reusable workspace.

mod assemble;
mod banded;
mod bsr;
mod constraints;
mod lines;
pub mod mpcg;
mod precond;
mod step;

pub use assemble::{AssemblyInput, System};
pub use bsr::BlockCsr;
pub use constraints::{Constraints, Filter};
pub use lines::AlternatingLines;
pub use mpcg::{MpcgOptions, MpcgWorkspace, Problem, SolveReport, SolveStatus};
pub use precond::{BlockJacobi, Jacobi, Preconditioner, make_preconditioner};
pub use step::{ClothState, Integrator, Physics, StageTimes, StepError, StepReport};
