//! Collision of the cloth with itself: no part of the cloth passes
//! through another (method.md §3 applied to the cloth's own triangles, as
//! the paper's conclusion proposes, with the edge–edge tests it lacks).
//!
//! | file | owns |
//! | --- | --- |
//! | `geometry` | closest points, the segment–triangle crossing |
//! | `topology` | the cloth's triangles and edges, their owners, swept boxes and hierarchy |
//! | `cones` | bounds on a patch's normals over a step: which patches cannot meet themselves |
//! | `contour` | and whose boundary, projected, stays simple |
//! | `plan` | one descent at the step's start for every query of the step |
//! | `budget` | how many candidate pairs a gather may hold |
//! | `kept` | candidate lists filtered without a branch per candidate |
//! | `query_boxes` | a query's boxes in single precision, rounded outward |
//! | `couplings` | layers within the thickness held apart inside the solve |
//! | `ccd` | continuous vertex–face and edge–edge tests |
//! | `impulse` | a pair's impulse, and how pinned, resting and free particles yield to it |
//! | `response` | proximity impulses, collision impulses, rigid impact zones |
//! | `recheck` | whether a change made after the response (the sharp-feature stage's) passes the cloth through itself |
//! | `crossings` | the exact count of cloth edges through cloth triangles |
//!
//! It runs twice a step. Before the solve, layers closer than the
//! thickness become couplings, springs on a pair's four particles that
//! the solve carries (`couplings`). After the solve and obstacle
//! collision, on the step's motion `x1 - x0`, the response is a velocity
//! correction of the accepted motion (Bridson, Fedkiw & Anderson 2002),
//! which ends every step without crossings.

mod budget;
mod ccd;
mod cones;
mod contour;
mod couplings;
mod crossings;
mod geometry;
mod impulse;
mod kept;
mod plan;
mod query_boxes;
mod recheck;
mod response;
mod topology;

pub use budget::of_particles as pair_budget;
pub use ccd::{Closest, Kind, Moving, closest};
pub use crossings::{count_crossings, count_crossings_culled};
pub use geometry::{point_triangle, segment_crosses_triangle};
pub use impulse::Hold;
pub use response::{Motion, SelfReport};
pub use topology::ClothMesh;

use crate::cloth::Grid;
use crate::math::{Real, Vec3};
use crate::solver::{ClothState, Coupling};

/// Default thickness as a share of the finer grid spacing: thin enough
/// that no two particles of a flat or moderately sheared grid that do not
/// share a triangle are within it (the nearest such pair of a quad is
/// `0.7` spacings apart), thick enough that the continuous tests never
/// work at rounding level.
pub const THICKNESS_SHARE: Real = 0.1;

/// Largest thickness a scene may ask for, as a share of the finer spacing.
pub const MAX_THICKNESS_SHARE: Real = 0.25;

/// Coulomb friction between layers of cloth (woven cotton on itself is
/// about 0.3–0.6; the lower end keeps folds able to slide).
pub const FRICTION: Real = 0.3;

/// The cloth's self-collision state: its mesh and the response's buffers.
#[derive(Debug, Clone)]
pub struct SelfCollision {
    mesh: ClothMesh,
    plan: plan::Plan,
    scratch: response::Scratch,
    layers: couplings::Layers,
    thickness: Real,
    u: Vec<Vec3>,
    u0: Vec<Vec3>,
    /// Scratch of [`SelfCollision::crosses_along`].
    recheck: recheck::Scratch,
}

impl SelfCollision {
    /// Self-collision of `grid` keeping layers `thickness` apart.
    pub fn new(grid: &Grid, thickness: Real) -> Self {
        Self {
            mesh: ClothMesh::new(grid),
            plan: plan::Plan::default(),
            scratch: response::Scratch::default(),
            layers: couplings::Layers::default(),
            thickness,
            u: Vec::new(),
            u0: Vec::new(),
            recheck: recheck::Scratch::default(),
        }
    }

    /// The thickness layers keep.
    pub fn thickness(&self) -> Real {
        self.thickness
    }

    /// Before a step of `h`: appends a coupling for every pair of layers
    /// closer than the thickness at `x`, of lumped masses `mass`
    /// (`couplings`). With `last_moved` (the last step's motion), the
    /// step's pairs are planned at `x` first (`plan`), for this and the
    /// step's later queries; without, the plan is left as it is (queries
    /// from other positions than its own do not use it).
    pub fn couple(
        &mut self,
        x: &[Vec3],
        mass: &[Real],
        h: Real,
        last_moved: Option<&[Vec3]>,
        out: &mut Vec<Coupling>,
    ) {
        if let Some(moved) = last_moved {
            self.plan.make(&mut self.mesh, x, self.thickness, moved);
        }
        self.layers.couple(
            (&mut self.mesh, &self.plan),
            x,
            self.thickness,
            mass,
            h,
            out,
        );
    }

    /// Corrects one step's motion so the cloth does not pass through
    /// itself: `moved` (each particle's displacement from `x0`) on entry
    /// is the solve's, on return the corrected one; `state.x = x0 + moved`,
    /// and the end velocities `state.v` receive the average velocity's change less
    /// the repulsion that only separates layers. Particles whose motion is not changed keep their `x`
    /// and `v` bit for bit.
    pub fn resolve(
        &mut self,
        x0: &[Vec3],
        mass: &[Real],
        held: &[Hold],
        h: Real,
        state: &mut ClothState,
        moved: &mut [Vec3],
    ) -> SelfReport {
        self.plan.cover(&mut self.mesh, x0, self.thickness, moved);
        self.u.clear();
        self.u.extend(moved.iter().map(|d| d / h));
        self.u0.clone_from(&self.u);
        let motion = Motion {
            x0,
            mass,
            held,
            h,
            thickness: self.thickness,
            friction: FRICTION,
            plan: &self.plan,
        };
        let report = self.scratch.resolve(&mut self.mesh, &motion, &mut self.u);
        let separation = self.scratch.separation();
        for k in 0..moved.len() {
            if self.u[k] != self.u0[k] {
                let d = self.u[k] * h;
                state.v[k] += self.u[k] - self.u0[k] - separation[k];
                moved[k] = d;
                state.x[k] = x0[k] + d;
            }
        }
        report
    }

    /// The particles in self contact in the last step: those of every
    /// pair that received an impulse (with a part in its closest points),
    /// in index order.
    pub fn contact_particles(&self) -> impl Iterator<Item = u32> + '_ {
        self.scratch
            .touched()
            .iter()
            .enumerate()
            .filter(|&(_, &t)| t)
            .map(|(k, _)| k as u32)
    }

    /// The number of cloth edges through cloth triangles at `x`
    /// ([`count_crossings_culled`], which tests hold to the full count):
    /// zero whenever the response did its work.
    pub fn crossings(&mut self, x: &[Vec3]) -> usize {
        count_crossings_culled(&mut self.mesh, x)
    }

    /// Whether moving the cloth from `xa` (where the response left it) to
    /// `xb` passes it through itself (`recheck`).
    pub fn crosses_along(&mut self, xa: &[Vec3], xb: &[Vec3]) -> bool {
        recheck::crosses_along(&mut self.mesh, xa, xb, self.thickness, &mut self.recheck)
    }
}
