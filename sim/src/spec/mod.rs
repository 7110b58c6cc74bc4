//! The job format (DESIGN.md "Job spec"): serde types as users write them,
//! validation with precise field paths, material presets, and the validated
//! [`Scene`] the rest of the core consumes.
//!
//! `Spec` is what a user wrote (optional fields, preset names). `Scene` is
//! what the simulation needs (every default applied, materials resolved to
//! numbers, directions normalised). Only [`Spec::validate`] turns one into
//! the other, so nothing downstream re-checks input.

mod error;
mod limits;
mod material;
mod obstacle;
mod scene;
mod types;
mod validate;

pub use error::{SpecError, SpecErrors};
pub use limits::Limits;
pub use material::{MaterialParams, MaterialSpec, PRESETS, preset};
pub use obstacle::{BoxShape, Cylinder, Keyframe, MeshSource, Motion, Obstacle, Plane, Sphere};
pub use scene::{ClothScene, Scene, SolverScene, TimeStepping};
pub use types::{
    ClothSpec, IntegratorKind, JacobianMode, Pin, PinEntry, PinGroup, PreconditionerKind,
    SolverSpec, Spec, StoppingRule, TimeStep,
};
