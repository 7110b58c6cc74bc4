//! The stability stress suite: scenes built to break the solver, and the
//! checks each must pass.
//!
//! Every case must finish with finite numbers, keep every edge's stretch
//! under its bound at every frame, keep every particle within 1 mm of the
//! outside of every obstacle's true surface (method.md §3: the offset
//! surface is where contact acts, the true surface is what must not be
//! crossed), and converge every solve within the iteration cap (§2).
//! `drapery bench stress` (full size) and `cargo test` (small size) run the
//! very same cases through the studies' [`crate::runner`].

mod case;
mod cases;
mod check;
mod crumple;

pub use case::Case;
pub use cases::cases;
pub use check::{MAX_PENETRATION, Outcome, run};
pub use crumple::crumple;
