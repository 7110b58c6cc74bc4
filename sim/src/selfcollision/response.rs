//! The response to cloth–cloth contact, after the implicit solve, on the
//! step's average velocity `u = (x1 - x0) / h` (Bridson, Fedkiw & Anderson
//! 2002, §7), in three passes each guaranteeing more than the one before:
//!
//! | pass | does |
//! | --- | --- |
//! | proximity | pairs within `thickness` at the start, or predicted to end inside it: an inelastic impulse stops their approach, a repulsion recovers a tenth of the overlap per step (a displacement only: the end velocity does not keep it), friction takes tangential velocity in proportion to the normal impulse (Coulomb) |
//! | collisions | continuous tests of every nearby pair over `x0 + t h u`; each hit gets an inelastic impulse, in a fixed order, for [`COLLISION_SWEEPS`] sweeps |
//! | impact zones | pairs still colliding merge their particles into zones, each moved as one rigid body (linear and angular momentum kept, Provot 1997); repeated until no pair collides |
//!
//! A rigid zone cannot intersect itself: its motion `x0 + t h (v + ω ×
//! r)` is an invertible affine map of the start for every `t` (its linear
//! part `I + t h [ω]×` has determinant `1 + t² h² |ω|² > 0`), and the start
//! has no crossings; zones grow until no pair between them collides
//! either. If [`MAX_ZONE_ROUNDS`] rounds do not end it, every particle
//! keeps its start position (the start had no crossings): the fail-safe of
//! the fail-safe, counted in the report. Held particles stop too (a pinned
//! particle that went on moving past frozen neighbours could pass through
//! them), and a pin that lags is pulled back by the next step's correction
//! `y`.
//!
//! Particles that are held ([`Hold`]: pins, obstacle contacts) weigh
//! [`HELD_WEIGHT`] times their mass in a zone, so the cloth gives way
//! around them rather than pushing them into an obstacle or off their pin;
//! a zone whose rigid motion would still push a resting particle into its
//! obstacle (pins lowering cloth onto cloth that lies on the floor: no
//! rigid motion keeps both) keeps its start for the step. To impulses a
//! pin does not yield at all, and a particle on an obstacle yields only by
//! leaving it (`super::impulse`). Before that, a curtain lowered onto a
//! floor passed or failed by round-off: along some paths two layers
//! landed in the floor's plane and passed through each other there, along
//! others every step from t = 0.9 s ended in the fail-safe and the pins
//! stayed 20 cm behind their motion (`sim/tests/self_collision.rs` now
//! lowers it along four).

use super::ccd::{Closest, Kind, Moving, closest};
use super::impulse::{Hold, Mobility, apply, relative, stop};
use super::plan::Plan;
use super::topology::ClothMesh;
use crate::math::{Mat3, Real, Vec3};

/// Sweeps of inelastic collision impulses before impact zones.
pub const COLLISION_SWEEPS: usize = 4;
/// Rounds of zone merging before the fail-safe stop.
pub const MAX_ZONE_ROUNDS: usize = 64;
/// How much heavier a held particle is in a rigid zone.
const HELD_WEIGHT: Real = 1e4;
/// Distance, as a share of the thickness, within which coplanar features
/// count as touching (the continuous tests' tolerance).
const COLLISION_PAD: Real = 0.01;
/// Pairs a particle in a resolution's last gather at most, for the
/// response to plan for itself (`Plan::for_response`): without this
/// bound, a 60² silk drape over a small sphere at 1/30 s (a cloth thrown
/// onto itself) took 45.0 s against 35.4 s, and its frames changed
/// (`super::plan`'s module doc says how they can).
const LOCAL_PLAN_PAIRS: usize = 1;
/// Share of the overlap with the thickness recovered per step.
const REPULSION: Real = 0.1;

/// What one resolution did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SelfReport {
    /// Pairs that received a proximity (repulsion, friction) impulse.
    pub contacts: usize,
    /// Collisions found by the continuous test and answered by impulses.
    pub collisions: usize,
    /// Rigid impact zones formed.
    pub zones: usize,
    /// Whether the fail-safe stop was needed.
    pub failsafe: bool,
    /// Whether a gather passed its budget (`super::budget`), so the
    /// fail-safe stop held the cloth still without testing its pairs.
    pub over_budget: bool,
}

/// Inputs of one resolution.
#[derive(Debug, Clone, Copy)]
pub struct Motion<'a> {
    /// Positions at the start of the step (without crossings).
    pub x0: &'a [Vec3],
    /// Lumped masses.
    pub mass: &'a [Real],
    /// How each particle yields.
    pub held: &'a [Hold],
    /// The step.
    pub h: Real,
    /// The cloth's thickness: the distance the layers keep.
    pub thickness: Real,
    /// Coulomb friction between layers.
    pub friction: Real,
    /// The step's planned pairs.
    pub plan: &'a Plan,
}

/// The buffers of the response, reused across steps.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    /// The part of each particle's change of `u` that only separates
    /// layers (positions, not velocities).
    separation: Vec<Vec3>,
    vf: Vec<(u32, u32)>,
    ee: Vec<(u32, u32)>,
    end: Vec<Vec3>,
    zone: Vec<u32>,
    /// Per particle: in a pair that received an impulse in the last
    /// resolution (a self contact, for viewers to show).
    touched: Vec<bool>,
    /// How each particle yields to an impulse, this resolution.
    mobility: Vec<Mobility>,
    /// Whether the last gather took a plan's pairs.
    planned: bool,
    /// The response's own plan, made when the step's does not hold
    /// (`Plan::for_response`), for this resolution only, and the motion
    /// it was made for.
    local: Plan,
    motion: Vec<Vec3>,
    /// Gathers of this resolution so far.
    gathers: usize,
    /// Whether the last gather passed its budget (its lists are partial).
    over_budget: bool,
}

impl Scratch {
    /// Changes the average velocities `u` so that `x0 + h u` keeps the
    /// cloth apart from itself.
    pub fn resolve(&mut self, mesh: &mut ClothMesh, m: &Motion<'_>, u: &mut [Vec3]) -> SelfReport {
        let mut report = SelfReport::default();
        self.separation.clear();
        self.separation.resize(u.len(), Vec3::zeros());
        self.touched.clear();
        self.touched.resize(u.len(), false);
        self.gathers = 0;
        self.local.forget();
        // Taken out of the scratch for the passes that borrow it beside
        // `self`, and put back: no allocation per step.
        let mut mobility = std::mem::take(&mut self.mobility);
        mobility.clear();
        mobility.extend(
            m.mass
                .iter()
                .zip(m.held)
                .map(|(&mass, &held)| Mobility::of(held, mass)),
        );
        self.passes(mesh, m, &mobility, u, &mut report);
        self.mobility = mobility;
        report
    }

    /// The three passes of [`Scratch::resolve`], with each particle's
    /// mobility.
    fn passes(
        &mut self,
        mesh: &mut ClothMesh,
        m: &Motion<'_>,
        inv_mass: &[Mobility],
        u: &mut [Vec3],
        report: &mut SelfReport,
    ) {
        let before = report.contacts;
        self.proximity(mesh, m, inv_mass, u, report);
        if report.over_budget {
            return;
        }
        // The proximity pass's pairs were gathered with the thickness as
        // pad over the solve's motion: they are every pair the collision
        // test needs if that pass changed no velocity. Otherwise they are
        // gathered again: boxes that still hold the new paths would do,
        // but the patches culled as flat were culled for the old motion,
        // and a patch flat over it need not be over the new one. (A
        // planned list is culled for the plan's bounds, and the gather
        // asks the plan again for the new paths.)
        let eta = COLLISION_PAD * m.thickness;
        let mut fresh = !self.planned && report.contacts == before;
        for _ in 0..COLLISION_SWEEPS {
            if !fresh {
                self.gather(mesh, m, u, eta);
                if self.stop_if_over(u, report) {
                    return;
                }
            }
            fresh = false;
            let mut touched = std::mem::take(&mut self.touched);
            let hits = self.collisions(mesh, m, u, |kind, idx, cl, u| {
                let w = idx.map(|k| inv_mass[k]);
                let n = cl.gap.normalize();
                let vn = relative(u, idx, &cl.c).dot(&n);
                if vn < 0.0 {
                    stop(u, idx, &cl.c, &w, &(n * -vn));
                    // Grid neighbours meet where the cloth crumples, not
                    // where layers touch: not a self contact to show.
                    if !mesh.grid_neighbours(kind, idx) {
                        mark(&mut touched, idx, &cl.c);
                    }
                }
            });
            self.touched = touched;
            report.collisions += hits;
            if hits == 0 {
                return;
            }
        }
        self.zones(mesh, m, u, report);
    }

    /// The proximity pass (Bridson et al. §7.2): one Gauss–Seidel sweep
    /// over the pairs in their fixed order.
    fn proximity(
        &mut self,
        mesh: &mut ClothMesh,
        m: &Motion<'_>,
        inv_mass: &[Mobility],
        u: &mut [Vec3],
        report: &mut SelfReport,
    ) {
        self.gather(mesh, m, u, m.thickness);
        if self.stop_if_over(u, report) {
            return;
        }
        let lists = [(Kind::VertexFace, &self.vf), (Kind::EdgeEdge, &self.ee)];
        for (kind, pairs) in lists {
            for &(a, b) in pairs.iter() {
                let idx = mesh.particles(kind, a, b);
                // Grid neighbours come close only by shearing, which the
                // cloth's own forces answer: repelling them would fight
                // shear (the collision passes still stop them crossing).
                if mesh.grid_neighbours(kind, &idx) {
                    continue;
                }
                let x = idx.map(|k| m.x0[k]);
                let cl = closest(kind, &x);
                // An edge pair closest at an end is a vertex near a
                // triangle's edge: the vertex-face pairs answer it.
                if kind == Kind::EdgeEdge && cl.c.contains(&0.0) {
                    continue;
                }
                let g0 = cl.gap.norm();
                if g0 <= 1e-12 * m.thickness {
                    continue; // no direction to push along
                }
                let n = cl.gap / g0;
                let rel = relative(u, &idx, &cl.c);
                let vn = rel.dot(&n);
                let g1 = g0 + m.h * vn;
                let target = if g0 >= m.thickness {
                    m.thickness
                } else {
                    g0 + REPULSION * (m.thickness - g0)
                };
                if g1 >= target {
                    continue;
                }
                let dvn = (target - g1) / m.h;
                // Stopping the approach is a velocity change; the rest
                // moves the layers apart without leaving them moving
                // apart (otherwise a short step's large `1/h` would throw
                // them).
                let stop = dvn.min((-vn).max(0.0));
                let tangent = rel - n * vn;
                let slide = tangent.norm();
                let keep = if slide > 0.0 {
                    (1.0 - m.friction * dvn / slide).max(0.0)
                } else {
                    1.0
                };
                let want = n * dvn - tangent * (1.0 - keep);
                let w = idx.map(|k| inv_mass[k]);
                apply(u, &idx, &cl.c, &w, &want);
                apply(&mut self.separation, &idx, &cl.c, &w, &(n * (dvn - stop)));
                mark(&mut self.touched, &idx, &cl.c);
                report.contacts += 1;
            }
        }
    }

    /// Whether each particle was in a pair that received an impulse in
    /// the last resolution (its part of the pair's closest points not
    /// zero).
    pub fn touched(&self) -> &[bool] {
        &self.touched
    }

    /// The part of the last resolution's change of `u` that separates
    /// layers without being a velocity.
    pub fn separation(&self) -> &[Vec3] {
        &self.separation
    }

    /// The pairs whose paths under `u` come within `pad`: the step's
    /// planned ones if the plan holds for this motion (`super::plan`), else
    /// the response's own plan's; from the second gather of a resolution
    /// on, that plan is made for this motion if it does not hold. Which
    /// plan serves changes no pair that acts (`super::plan`).
    fn gather(&mut self, mesh: &mut ClothMesh, m: &Motion<'_>, u: &[Vec3], pad: Real) {
        self.end_positions(m, u);
        let ends = (m.x0, self.end.as_slice());
        let (vf, ee) = (&mut self.vf, &mut self.ee);
        self.planned = m.plan.pairs(mesh, ends, pad, vf, ee)
            || self.local.pairs(mesh, ends, pad, vf, ee)
            || (self.gathers > 0 && vf.len() + ee.len() <= LOCAL_PLAN_PAIRS * m.x0.len() && {
                self.motion.clear();
                self.motion
                    .extend(ends.1.iter().zip(ends.0).map(|(x1, x0)| x1 - x0));
                self.local.for_response(mesh, m.x0, pad, &self.motion)
                    && self.local.pairs(mesh, ends, pad, vf, ee)
            });
        self.gathers += 1;
        self.over_budget = false;
        if !self.planned {
            mesh.refit(m.x0, &self.end, pad);
            self.over_budget = !mesh.feature_pairs(&mut self.vf, &mut self.ee);
        }
    }

    /// After a gather over its budget: the fail-safe stop, with no pair
    /// tested (`super::budget`). Returns whether it was.
    fn stop_if_over(&self, u: &mut [Vec3], report: &mut SelfReport) -> bool {
        if self.over_budget {
            report.over_budget = true;
            report.failsafe = true;
            u.fill(Vec3::zeros());
        }
        self.over_budget
    }

    fn end_positions(&mut self, m: &Motion<'_>, u: &[Vec3]) {
        self.end.clear();
        self.end
            .extend(m.x0.iter().zip(u).map(|(x, u)| x + u * m.h));
    }

    /// Tests every gathered pair over the step with the current `u` and
    /// calls `hit` on each collision, in the fixed pair order; returns how
    /// many there were.
    fn collisions(
        &self,
        mesh: &ClothMesh,
        m: &Motion<'_>,
        u: &mut [Vec3],
        mut hit: impl FnMut(Kind, &[usize; 4], &Closest, &mut [Vec3]),
    ) -> usize {
        let eta = COLLISION_PAD * m.thickness;
        let mut hits = 0;
        let lists = [(Kind::VertexFace, &self.vf), (Kind::EdgeEdge, &self.ee)];
        for (kind, pairs) in lists {
            for &(a, b) in pairs.iter() {
                let idx = mesh.particles(kind, a, b);
                let moving = Moving {
                    x: idx.map(|k| m.x0[k]),
                    d: idx.map(|k| u[k] * m.h),
                };
                if let Some((_, cl)) = moving.first_contact(kind, eta) {
                    // The direction that separates them is the one they
                    // had at the start.
                    let start = closest(kind, &moving.x);
                    if start.gap.norm() > 0.0 {
                        hits += 1;
                        let cl = Closest {
                            c: cl.c,
                            gap: start.gap,
                        };
                        hit(kind, &idx, &cl, &mut *u);
                    }
                }
            }
        }
        hits
    }

    /// Rigid impact zones until no pair collides.
    fn zones(
        &mut self,
        mesh: &mut ClothMesh,
        m: &Motion<'_>,
        u: &mut [Vec3],
        report: &mut SelfReport,
    ) {
        let n = u.len();
        self.zone.clear();
        self.zone.extend(0..n as u32);
        for _ in 0..MAX_ZONE_ROUNDS {
            self.gather(mesh, m, u, COLLISION_PAD * m.thickness);
            if self.stop_if_over(u, report) {
                return;
            }
            let mut zone = std::mem::take(&mut self.zone);
            let hits = self.collisions(mesh, m, u, |_, idx, _, _| {
                for k in 1..4 {
                    union(&mut zone, idx[0], idx[k]);
                }
            });
            self.zone = zone;
            if hits == 0 {
                return;
            }
            report.zones = rigidify(&mut self.zone, m, u);
        }
        report.failsafe = true;
        u.fill(Vec3::zeros());
    }
}

/// Marks the particles of a pair that take part in its closest points.
fn mark(touched: &mut [bool], idx: &[usize; 4], c: &[Real; 4]) {
    for (&k, &ck) in idx.iter().zip(c) {
        if ck != 0.0 {
            touched[k] = true;
        }
    }
}

fn find(zone: &mut [u32], mut a: usize) -> usize {
    while zone[a] as usize != a {
        let up = zone[zone[a] as usize];
        zone[a] = up;
        a = up as usize;
    }
    a
}

fn union(zone: &mut [u32], a: usize, b: usize) {
    let (ra, rb) = (find(zone, a), find(zone, b));
    // The smaller index is the root: the zones do not depend on the order
    // of the unions.
    let (lo, hi) = (ra.min(rb), ra.max(rb));
    zone[hi] = lo as u32;
}

/// Replaces the velocities of every zone of more than one particle by the
/// rigid motion with the same linear and angular momentum; returns the
/// number of such zones.
fn rigidify(zone: &mut [u32], m: &Motion<'_>, u: &mut [Vec3]) -> usize {
    let n = u.len();
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); n];
    for k in 0..n {
        let r = find(zone, k);
        members[r].push(k);
    }
    let weight = |k: usize| {
        m.mass[k]
            * if m.held[k].is_held() {
                HELD_WEIGHT
            } else {
                1.0
            }
    };
    let mut zones = 0;
    for group in members.iter().filter(|g| g.len() > 1) {
        zones += 1;
        let total: Real = group.iter().map(|&k| weight(k)).sum();
        let xc: Vec3 = group.iter().map(|&k| m.x0[k] * weight(k)).sum::<Vec3>() / total;
        let vc: Vec3 = group.iter().map(|&k| u[k] * weight(k)).sum::<Vec3>() / total;
        let mut l = Vec3::zeros();
        let mut inertia = Mat3::zeros();
        for &k in group {
            let r = m.x0[k] - xc;
            l += r.cross(&(u[k] - vc)) * weight(k);
            inertia += (Mat3::identity() * r.norm_squared() - r * r.transpose()) * weight(k);
        }
        // Collinear zones have no inertia about their line: a small
        // isotropic part keeps the inverse finite and that spin zero.
        let reg = Mat3::identity() * (1e-9 * inertia.trace()).max(Real::MIN_POSITIVE);
        let omega = (inertia + reg)
            .try_inverse()
            .map_or(Vec3::zeros(), |i| i * l);
        // A zone that would drive a particle into the obstacle it rests
        // on (a pin lowering cloth onto cloth that lies on the floor: no
        // rigid motion keeps both, and the weighted one drove the resting
        // cloth 2.9 mm into the floor) keeps its start for this step,
        // held members included; a pin that lags is brought back by the
        // next step's correction `y`.
        let tolerance = COLLISION_PAD * m.thickness / m.h;
        let rigid = |k: usize| vc + omega.cross(&(m.x0[k] - xc));
        let pushes_in = group.iter().any(|&k| match m.held[k] {
            Hold::Lift(n) => n.dot(&(rigid(k) - u[k])) < -tolerance,
            _ => false,
        });
        for &k in group {
            u[k] = if pushes_in { Vec3::zeros() } else { rigid(k) };
        }
    }
    zones
}
