//! Collision of cloth particles with rigid obstacles (method.md §3, §4):
//! exact primitives and triangle meshes with a bounding-volume hierarchy,
//! continuous vertex–face tests on the offset surface in each obstacle's
//! own frame, and the response inside the solve through the filters,
//! targets and corrections of the modified PCG.

mod aabb;
mod analytic;
mod bvh;
mod collider;
mod contact;
mod features;
mod meshsurface;
mod obstacles;
mod paths;
mod pose;
mod scratch;
mod stage;
mod surface;
mod triangle;

pub use aabb::Aabb;
pub use analytic::{Analytic, Primitive};
pub use bvh::{Bvh, Task as BvhTask};
pub use collider::{Collider, display_mesh};
pub use contact::{Contact, Plan};
pub use features::Features;
pub use meshsurface::MeshSurface;
pub use obstacles::Obstacles;
pub use pose::{Pose, Trajectory};
pub use scratch::{CollisionCounters, CollisionScratch};
pub use stage::{CollisionStage, StepFrame, Verdict};
pub use surface::{Hit, Projection, Surface};
pub use triangle::{Feature, PlaneHit, Region, closest_point, closest_region, segment_hit};
