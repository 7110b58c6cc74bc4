//! # drapery-sim: the numerical core of drapery
//!
//! A particle-grid cloth (`../shared/method.md` §1) advanced by implicit Euler
//! and solved with a modified preconditioned conjugate gradient (§2), with
//! obstacle collision handled inside the solve (§3, §4).
//!
//! Data flows one way:
//!
//! ```text
//! spec::Spec --validate--> spec::Scene --Simulation::new--> sim::Simulation --step*--> Frame + stats
//! ```
//!
//! The crate is a plain library: no async runtime, no HTTP, no JSON parser.
//! Callers hand it a validated scene and a [`sim::Control`] (progress and
//! cancellation) and receive frames.

pub mod cloth;
pub mod collision;
pub mod export;
pub mod math;
pub mod mesh;
pub mod parallel;
pub mod selfcollision;
pub mod sim;
pub mod solver;
pub mod spec;
pub mod subnormals;

#[cfg(test)]
pub(crate) mod testing;
