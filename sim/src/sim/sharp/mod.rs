//! The sharp-feature stage of a step: no cloth edge passes through an
//! obstacle's edge and no obstacle corner through a cloth triangle.
//!
//! method.md §3 tests particles only, and so widens the offset until a
//! cloth edge whose ends rest on the offset surface cannot reach an
//! obstacle edge between them: 0.41 spacings for a box, which left the
//! table-drape cloth floating 11.1 mm above its table. Here the corners
//! and edges (`collision::Features`) are tested against the cloth's edges
//! and triangles themselves, edge–edge and vertex–face, as the cloth's
//! self-collision tests its own (Bridson, Fedkiw & Anderson 2002), and
//! the offset of a shape whose features are tested shrinks to its margin.
//!
//! | part | does | file |
//! | --- | --- | --- |
//! | features | each obstacle's corners at the step's start and end poses, their swept boxes grown by what the cloth keeps from them | `pairs` |
//! | pairs | cloth edges against feature edges, feature corners against cloth triangles: each cloth element's swept box against the features' small hierarchies | `pairs` |
//! | couplings | before the solve: a pair closer than [`KEEP`] of the offset at the step's start becomes a `solver::Coupling`, a stiff one-sided spring in `A` that carries the cloth's load (a chord over a table's corner holds up the cloth hanging from it) | here |
//! | sweeps | after the solve: a pair that ends closer than [`HARD`] × [`KEEP`] of the offset, or meets during the step (the continuous test), moves its cloth particles out by inverse mass; [`SWEEPS`] times over every pair | `correct` |
//! | freeze | the cloth particles of pairs that still meet move with the obstacle for the step (a rigid motion shared with the obstacle cannot bring them together: the start had no crossing), until none meets | `correct` |
//! | release | a particle moved by more than [`LIFT_OFF`] of the offset loses its contact, so the next step does not pull it back | here |
//!
//! The obstacle is infinitely heavy: only the cloth moves. The part of a
//! correction that stops an approach becomes velocity (an inelastic
//! contact); the rest only moves the cloth out. The correction runs after
//! the self-collision stage, as the last word on where the step ends; it
//! alone (without couplings) fought the solve wherever the cloth hangs
//! from an edge: 18–31 % stretch at table-drape's corners.

use crate::cloth::Grid;
use crate::collision::{Aabb, Bvh, Contact, Obstacles, StepFrame};
use crate::math::{Real, Vec3};
use crate::selfcollision::{Kind, closest, segment_crosses_triangle};
use crate::solver::{ClothState, Coupling};

mod correct;
mod pairs;

use pairs::Point;

/// The distance cloth edges and triangles keep from a sharp feature, as a
/// share of the obstacle's offset: closer, a coupling holds them off in
/// the solve. A particle on the offset surface is at the whole offset, so
/// one resting beside an edge is never held, but a chord across the edge
/// is held clear of it.
pub const KEEP: Real = 0.5;
/// The share of [`KEEP`] that the correction after the solve guarantees,
/// whatever the couplings did: below the couplings' own rest, so the two
/// do not fight over a chord the couplings carry.
pub const HARD: Real = 0.5;
/// The couplings' stiffness as a share of the cloth's stiffest spring.
/// On table-drape at 60² (a chord over the table's corner carries the
/// weight of the cloth hanging from it): 1.0 took 9,753 CG iterations,
/// 0.1 took 4,359 with the same largest stretch (0.06 %), and 0.01 let
/// chords sink to the correction's distance, which then fought the solve
/// (5 % stretch).
const STIFFNESS: Real = 0.1;
/// Sweeps over the pairs before particles are frozen.
pub const SWEEPS: usize = 4;
/// A particle moved by more than this share of the offset loses its
/// contact.
const LIFT_OFF: Real = 0.1;

/// What the stage did in one step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SharpReport {
    /// Corrections made (pairs moved apart, over all sweeps).
    pub corrections: usize,
    /// Particles frozen to an obstacle's motion.
    pub frozen: usize,
}

/// The stage's state: the cloth's edges and triangles with hierarchies
/// over them, and buffers reused across steps.
#[derive(Debug, Clone)]
pub struct SharpStage {
    edges: Vec<[u32; 2]>,
    triangles: Vec<[u32; 3]>,
    /// Each particle's swept box this step.
    swept: Vec<Aabb>,
    /// Triangle boxes and their hierarchy, for counting crossings.
    tri_boxes: Vec<Aabb>,
    tri_tree: Bvh,
    /// Every obstacle's features this step: corners at the start and end.
    f0: Vec<Vec3>,
    f1: Vec<Vec3>,
    /// Each corner's kept distance.
    keep: Vec<Real>,
    /// Each corner's obstacle.
    owner: Vec<u32>,
    /// Feature edges (indices into `f0`, `f1`).
    fedges: Vec<[u32; 2]>,
    /// Swept boxes of the corners and feature edges, and hierarchies.
    corner_boxes: Vec<Aabb>,
    fedge_boxes: Vec<Aabb>,
    corner_tree: Bvh,
    fedge_tree: Bvh,
    /// Pairs: (cloth edge, feature edge) and (corner, cloth triangle).
    ee: Vec<(u32, u32)>,
    vf: Vec<(u32, u32)>,
    end: Vec<Vec3>,
    velocity: Vec<Vec3>,
    frozen: Vec<bool>,
    /// Inverse masses, 0 for pins.
    w: Vec<Real>,
    released: Vec<u32>,
    /// The couplings' stiffness, N/m.
    stiffness: Real,
}

impl SharpStage {
    /// The stage for `grid` whose stiffest spring is `spring` N/m, or
    /// `None` if no obstacle has features.
    pub fn new(grid: &Grid, spring: Real, obstacles: Option<&Obstacles>) -> Option<Self> {
        let obstacles = obstacles?;
        let colliders = obstacles.colliders();
        if colliders.iter().all(|c| c.features.is_none()) {
            return None;
        }
        let mut stage = Self::of_grid(grid);
        stage.stiffness = STIFFNESS * spring;
        for (k, c) in colliders.iter().enumerate() {
            let Some(f) = &c.features else { continue };
            let base = stage.keep.len() as u32;
            stage.keep.extend(std::iter::repeat_n(
                KEEP * c.surface.offset(),
                f.points.len(),
            ));
            stage
                .owner
                .extend(std::iter::repeat_n(k as u32, f.points.len()));
            stage
                .fedges
                .extend(f.edges.iter().map(|e| e.map(|v| v + base)));
        }
        stage.corners(obstacles, 0.0, 0.0);
        stage.corner_tree = Bvh::build(&stage.corner_boxes);
        stage.fedge_tree = Bvh::build(&stage.fedge_boxes);
        Some(stage)
    }

    fn of_grid(grid: &Grid) -> Self {
        let triangles = grid.triangles();
        let mut edges: Vec<[u32; 2]> = triangles
            .iter()
            .flat_map(|t| {
                [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]].map(|[a, b]| [a.min(b), a.max(b)])
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let x = &grid.rest;
        let tri_boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| Aabb::of_points(t.iter().map(|&k| &x[k as usize])))
            .collect();
        Self {
            tri_tree: Bvh::build(&tri_boxes),
            edges,
            triangles,
            swept: Vec::new(),
            tri_boxes,
            f0: Vec::new(),
            f1: Vec::new(),
            keep: Vec::new(),
            owner: Vec::new(),
            fedges: Vec::new(),
            corner_boxes: Vec::new(),
            fedge_boxes: Vec::new(),
            corner_tree: Bvh::build(&[]),
            fedge_tree: Bvh::build(&[]),
            ee: Vec::new(),
            vf: Vec::new(),
            end: Vec::new(),
            velocity: Vec::new(),
            frozen: Vec::new(),
            w: Vec::new(),
            released: Vec::new(),
            stiffness: 0.0,
        }
    }

    /// Before the solve: a coupling (`solver::Coupling`) for every pair
    /// closer than it keeps at the step's start `x0`, along the pair's
    /// direction there, into `couplings`.
    pub fn prepare(
        &mut self,
        obstacles: &Obstacles,
        time: Real,
        x0: &[Vec3],
        couplings: &mut Vec<Coupling>,
    ) {
        self.corners(obstacles, time, 0.0);
        self.corner_tree.refit(&self.corner_boxes);
        self.fedge_tree.refit(&self.fedge_boxes);
        self.end.clear();
        self.end.extend_from_slice(x0);
        if !self.gather(x0) {
            return;
        }
        for kind in [Kind::VertexFace, Kind::EdgeEdge] {
            let pairs = match kind {
                Kind::VertexFace => &self.vf,
                Kind::EdgeEdge => &self.ee,
            };
            for &(a, b) in pairs {
                let (points, keep) = self.pair(kind, a, b);
                let m = self.moving(x0, &points);
                let cl = closest(kind, &m.x);
                let g = cl.gap.norm();
                if g >= keep || g <= 0.0 {
                    continue;
                }
                let n = cl.gap / g;
                let mut coupling = Coupling {
                    particles: [0; 3],
                    weights: [0.0; 3],
                    normal: n,
                    target: keep,
                    stiffness: self.stiffness,
                };
                let mut slot = 0;
                for (k, p) in points.iter().enumerate() {
                    match *p {
                        Point::Cloth(i) => {
                            coupling.particles[slot] = i;
                            coupling.weights[slot] = cl.c[k];
                            slot += 1;
                        }
                        // The feature's part of `d` is fixed.
                        Point::Corner(_) => coupling.target -= n.dot(&(m.x[k] * cl.c[k])),
                    }
                }
                couplings.push(coupling);
            }
        }
    }

    /// Runs the stage (the module's table) on the accepted step from `x0`:
    /// `state` and `moved` are corrected, `contacts` loses those of
    /// particles moved off their surface.
    pub fn run(
        &mut self,
        frame: &StepFrame<'_>,
        obstacles: &Obstacles,
        x0: &[Vec3],
        state: &mut ClothState,
        moved: &mut [Vec3],
        contacts: &mut Vec<Contact>,
    ) -> SharpReport {
        let mut report = SharpReport::default();
        self.corners(obstacles, frame.time, frame.h);
        self.corner_tree.refit(&self.corner_boxes);
        self.fedge_tree.refit(&self.fedge_boxes);
        self.end.clear();
        self.end
            .extend(x0.iter().zip(moved.iter()).map(|(x, d)| x + d));
        if !self.gather(x0) {
            return report;
        }
        let n = x0.len();
        self.velocity.clear();
        self.velocity.resize(n, Vec3::zeros());
        let mut w = std::mem::take(&mut self.w);
        w.clear();
        w.extend((0..n).map(|k| {
            if frame.pinned[k] || frame.mass[k] <= 0.0 {
                0.0
            } else {
                1.0 / frame.mass[k]
            }
        }));
        for _ in 0..SWEEPS {
            let hits = self.sweep(x0, &w, frame.h);
            report.corrections += hits;
            if hits == 0 {
                break;
            }
        }
        self.w = w;
        report.frozen = self.freeze(obstacles, frame, x0);
        // Write back what changed.
        let lift_off: Real = LIFT_OFF
            * obstacles
                .offsets()
                .into_iter()
                .fold(Real::INFINITY, Real::min);
        self.released.clear();
        for k in 0..n {
            let d = self.end[k] - x0[k];
            if d == moved[k] {
                continue;
            }
            let shift = d - moved[k];
            if shift.norm() > lift_off {
                self.released.push(k as u32);
            }
            moved[k] = d;
            state.x[k] = self.end[k];
            state.v[k] = if self.frozen[k] {
                d / frame.h
            } else {
                state.v[k] + self.velocity[k]
            };
        }
        if !self.released.is_empty() {
            let released = &self.released;
            contacts.retain(|c| released.binary_search(&c.particle).is_err());
        }
        report
    }

    /// The number of (feature edge, cloth triangle) pairs where the edge
    /// passes through the triangle, the cloth at `x` and the obstacles at
    /// time `t`: zero whenever no obstacle edge cuts the cloth (an edge
    /// of the true surface, not the offset one).
    pub fn crossings(&mut self, obstacles: &Obstacles, t: Real, x: &[Vec3]) -> usize {
        self.corners(obstacles, t, 0.0);
        for (b, tri) in self.tri_boxes.iter_mut().zip(&self.triangles) {
            *b = Aabb::of_points(tri.iter().map(|&k| &x[k as usize]));
        }
        self.tri_tree.refit(&self.tri_boxes);
        let mut count = 0;
        for &[a, b] in &self.fedges {
            let (p, q) = (self.f0[a as usize], self.f0[b as usize]);
            self.tri_tree.query(&Aabb::of_segment(&p, &q), |k| {
                let [i, j, l] = self.triangles[k].map(|v| x[v as usize]);
                if segment_crosses_triangle(&p, &q, &i, &j, &l) {
                    count += 1;
                }
            });
        }
        count
    }
}
