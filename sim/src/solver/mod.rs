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
//!   corrections `y_i` (pins and contacts fill the same arrays), and
//!   [`Coupling`]s: stiff one-sided springs to obstacles' sharp features.
//! - [`mpcg`]: the modified preconditioned conjugate gradient (Baraff &
//!   Witkin 1998 §5) behind the [`Preconditioner`] trait.
//! - [`Integrator`]: the system, its preconditioner and the solver's
//!   scratch, with one method per stage of the step; [`ClothState`] is what
//!   a step advances.

mod assemble;
mod bsr;
mod constraints;
mod coupling;
mod error_rule;
mod integrator;
mod left_out;
mod lines;
mod local_error;
pub mod mpcg;
pub mod multigrid;
mod precond;
mod redo;
mod scheme;
mod sink;
mod state;

pub use assemble::{AssemblyInput, System};
pub use bsr::BlockCsr;
pub use constraints::{Constraints, Filter};
pub use coupling::{Coupling, Remote};
pub use integrator::{Integrator, Physics, StepError, update};
pub use left_out::LeftOut;
pub use lines::AlternatingLines;
pub use local_error::local_error;
pub use mpcg::{MpcgOptions, MpcgWorkspace, Problem, SolveReport, SolveStatus};
pub use multigrid::Multigrid;
pub use precond::{BlockJacobi, Jacobi, Preconditioner};
pub use scheme::Scheme;
pub use state::ClothState;
