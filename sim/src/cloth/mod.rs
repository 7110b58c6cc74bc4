//! The cloth model of method.md §1: a particle grid with stretch, shear and
//! bend energies, damping and air drag.
//!
//! Each force is a type implementing [`Force`]: it adds its forces and
//! Jacobian blocks (`df/dx`, `df/dv`) into a caller-owned [`Sink`]; the
//! solver's sink writes straight into the system matrix, the tests' sink
//! into dense matrices for finite-difference checks.
//!
//! Coefficients are derived from the continuum material so that refining the
//! grid converges to the same cloth (see [`grid`] and each force's docs).

mod angle;
mod arms;
mod bend;
mod damping;
mod drag;
mod force;
mod grid;
mod model;
mod shear;
mod stretch;

pub use angle::{
    AngleElement, AngleForce, AngleGeom, AngleLaw, THRESHOLD_SMOOTHING, energy_of_square,
};
pub use arms::{ArmRef, ArmTable};
pub use bend::Bend;
pub use damping::SpringDamping;
pub use drag::AirDrag;
pub use force::{Force, Sink, arm_blocks};
pub use grid::Grid;
pub use model::ForceModel;
pub use shear::Shear;
pub use stretch::{Spring, SpringPair, Stretch};

#[cfg(test)]
pub(crate) mod fdcheck;
