//! The sharp-feature stage's state and its two entry points: couplings
//! before the solve, the correction after it (the table in `super`).

use crate::cloth::Grid;
use crate::collision::{Aabb, Bvh, Contact, Obstacles, StepFrame};
use crate::math::{Real, Vec3};
use crate::selfcollision::{Kind, closest, pair_budget, segment_crosses_triangle};
use crate::solver::{ClothState, Coupling};

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
/// Sweeps over the pairs before particles are frozen. A cloth pulled off
/// the table at 8 m/s (a spacing per step; the stress suite's
/// tablecloth-pull) froze particles in 28 steps with 4 sweeps, and the
/// frozen ones stretched it 25 %; 16 sweeps froze in 4 steps (8.4 %).
/// The sweeps cost little: they visit the few pairs near features.
pub const SWEEPS: usize = 16;
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
    /// The pairs passed their budget (`SharpStage::gather`): those past it
    /// were not tested, and the driver redoes the step in halves.
    pub over_budget: bool,
}

/// The stage's state: the cloth's edges and triangles with hierarchies
/// over them, and buffers reused across steps.
#[derive(Debug, Clone)]
pub struct SharpStage {
    pub(super) edges: Vec<[u32; 2]>,
    pub(super) triangles: Vec<[u32; 3]>,
    /// Each particle's swept box this step.
    pub(super) swept: Vec<Aabb>,
    /// Triangle boxes and their hierarchy, for counting crossings.
    pub(super) tri_boxes: Vec<Aabb>,
    pub(super) tri_tree: Bvh,
    /// Every obstacle's features this step: corners at the start and end.
    pub(super) f0: Vec<Vec3>,
    pub(super) f1: Vec<Vec3>,
    /// Each corner's kept distance.
    pub(super) keep: Vec<Real>,
    /// Each corner's obstacle.
    pub(super) owner: Vec<u32>,
    /// Feature edges (indices into `f0`, `f1`).
    pub(super) fedges: Vec<[u32; 2]>,
    /// Swept boxes of the corners and feature edges, and hierarchies.
    pub(super) corner_boxes: Vec<Aabb>,
    pub(super) fedge_boxes: Vec<Aabb>,
    pub(super) corner_tree: Bvh,
    pub(super) fedge_tree: Bvh,
    /// Pairs: (cloth edge, feature edge) and (corner, cloth triangle).
    pub(super) ee: Vec<(u32, u32)>,
    pub(super) vf: Vec<(u32, u32)>,
    /// The most pairs a gather holds (`selfcollision::pair_budget`).
    pub(super) budget: usize,
    pub(super) end: Vec<Vec3>,
    pub(super) velocity: Vec<Vec3>,
    pub(super) frozen: Vec<bool>,
    /// Inverse masses, 0 for pins.
    pub(super) w: Vec<Real>,
    pub(super) released: Vec<u32>,
    /// The couplings' stiffness, N/m.
    pub(super) stiffness: Real,
    /// Some obstacle with features moves: its corners are placed again
    /// every step.
    pub(super) moves: bool,
    /// A particle moved farther than this loses its contact, metres
    /// (`LIFT_OFF` of the smallest offset).
    pub(super) lift_off: Real,
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
        stage.moves = colliders
            .iter()
            .any(|c| c.features.is_some() && !c.is_static);
        stage.lift_off = LIFT_OFF
            * obstacles
                .offsets()
                .into_iter()
                .fold(Real::INFINITY, Real::min);
        stage.place_corners(obstacles, 0.0, 0.0);
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
            budget: pair_budget(x.len()),
            end: Vec::new(),
            velocity: Vec::new(),
            frozen: Vec::new(),
            w: Vec::new(),
            released: Vec::new(),
            stiffness: 0.0,
            moves: false,
            lift_off: 0.0,
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
        self.end.clear();
        self.end.extend_from_slice(x0);
        if !self.gather(x0).any {
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
                    particles: [0; 4],
                    weights: [0.0; 4],
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
        self.end.clear();
        self.end
            .extend(x0.iter().zip(moved.iter()).map(|(x, d)| x + d));
        let gathered = self.gather(x0);
        report.over_budget = gathered.over_budget;
        if !gathered.any {
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
        let lift_off = self.lift_off;
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

/// One of a pair's four points.
#[derive(Debug, Clone, Copy)]
pub(super) enum Point {
    /// A cloth particle.
    Cloth(u32),
    /// An obstacle corner (index into the step's features).
    Corner(u32),
}
