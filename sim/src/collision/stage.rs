//! The collision stage of a step (method.md §3, §4): before the solve it
//! turns the contact set, and the particles whose predicted path crosses an
//! obstacle's offset surface, into constraints; after the solve it tests
//! the path actually taken (asking for the step to be redone with the new
//! contacts if one crossed), then releases contacts whose constraint force
//! turned adhesive and moves the rest between static and kinetic friction.
//!
//! Every test runs in the obstacle's own frame: a particle's start is
//! mapped by the inverse pose at the step's start, its end by the inverse
//! pose at its end, which makes the test exact for rigid relative motion
//! and leaves each hierarchy untouched.
//!
//! What a scene does not need costs nothing: without obstacles there is no
//! stage; a static obstacle has no poses to compute; an obstacle whose box
//! misses the cloth's box (over the whole step) is skipped before its
//! hierarchy is touched, and so is each particle whose path box misses it.

use super::aabb::Aabb;
use super::collider::Collider;
use super::contact::{self, Contact, Plan};
use super::pose::Pose;
use crate::math::{Real, Vec3};
use crate::mesh::MeshError;
use crate::solver::Constraints;
use crate::spec::Obstacle;

/// A crossing found after the solve that ends less than this fraction of
/// the offset inside the offset surface is left for the next step's
/// inside test instead of redoing the step: it is still well outside the
/// true surface.
const SHALLOW: Real = 0.25;

/// A particle within this fraction of the offset inside the offset surface
/// counts as on it, not inside.
const ON_SURFACE: Real = 1e-3;

/// A contact is released when its normal impulse pulls inward by more
/// than this fraction of the particle's weight impulse `m |g| h`: the
/// hysteresis keeps cloth hanging along a wall (normal force ~ 0) from
/// being released and re-made every step on solver noise.
const RELEASE_HYSTERESIS: Real = 0.05;

/// Most a particle is pushed out along the surface normal in one step, as
/// a fraction of the particle spacing: a deep initial overlap is resolved
/// over a few steps instead of in one jolt that would overstretch the
/// springs to its free neighbours.
const MAX_PUSH: Real = 0.1;

/// Counters of one step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CollisionCounters {
    /// Hierarchy nodes visited.
    pub nodes: u64,
    /// Contacts made.
    pub new: usize,
    /// Contacts released.
    pub released: usize,
    /// Solves redone because a particle crossed a surface.
    pub redone: usize,
}

/// The obstacles and the contact set of a running simulation.
#[derive(Debug)]
pub struct CollisionStage {
    colliders: Vec<Collider>,
    contacts: Vec<Contact>,
    /// This step's geometry of each contact (parallel to `contacts`).
    plans: Vec<Plan>,
    /// This step's poses (start, end) and the box each obstacle sweeps
    /// over the step.
    poses: Vec<(Pose, Pose)>,
    swept: Vec<Aabb>,
    /// Predicted end positions.
    predicted: Vec<Vec3>,
    /// Largest push-out per step (see [`MAX_PUSH`]).
    max_push: Real,
    /// Counters since the last [`Self::take_counters`].
    counters: CollisionCounters,
}

impl CollisionStage {
    /// The stage for `obstacles`, or `None` when there are none.
    pub fn new(obstacles: &[Obstacle], spacing: Real) -> Result<Option<Self>, (usize, MeshError)> {
        if obstacles.is_empty() {
            return Ok(None);
        }
        let colliders = obstacles
            .iter()
            .enumerate()
            .map(|(k, o)| Collider::new(o, spacing).map_err(|e| (k, e)))
            .collect::<Result<Vec<_>, _>>()?;
        for (k, c) in colliders.iter().enumerate() {
            tracing::debug!(
                obstacle = k,
                offset = c.surface.offset(),
                "collision offset"
            );
        }
        let n = colliders.len();
        Ok(Some(Self {
            colliders,
            contacts: Vec::new(),
            plans: Vec::new(),
            poses: vec![(Pose::identity(), Pose::identity()); n],
            swept: vec![Aabb::empty(); n],
            predicted: Vec::new(),
            max_push: MAX_PUSH * spacing,
            counters: CollisionCounters::default(),
        }))
    }

    /// The obstacles.
    pub fn colliders(&self) -> &[Collider] {
        &self.colliders
    }

    /// The contact set (sorted by particle, then obstacle).
    pub fn contacts(&self) -> &[Contact] {
        &self.contacts
    }

    /// Replaces the contact set (restoring a backup).
    pub fn set_contacts(&mut self, contacts: Vec<Contact>) {
        self.contacts = contacts;
    }

    /// Counters accumulated since the last call, reset.
    pub fn take_counters(&mut self) -> CollisionCounters {
        std::mem::take(&mut self.counters)
    }

    fn set_poses(&mut self, t: Real, h: Real) {
        for (k, c) in self.colliders.iter().enumerate() {
            if !c.is_static {
                self.poses[k] = (c.trajectory.pose(t), c.trajectory.pose(t + h));
            }
            let (p0, p1) = &self.poses[k];
            self.swept[k] = c.world_bounds(p0).union(&c.world_bounds(p1));
        }
    }

    fn has_contact(&self, i: usize, k: usize) -> bool {
        let (i, k) = (i as u32, k as u32);
        self.contacts
            .binary_search_by(|c| (c.particle, c.obstacle).cmp(&(i, k)))
            .is_ok()
    }

    /// The offset-surface point nearest to `x` (at the step's start) on
    /// obstacle `k`, and how it moves over the step.
    fn plan(&self, k: usize, x: &Vec3, v: &Vec3, h: Real) -> (Plan, u64) {
        let c = &self.colliders[k];
        let (p0, p1) = &self.poses[k];
        let mut nodes = 0;
        let local = p0.inverse_transform_point(&(*x).into());
        let pr = c.surface.project(&local.coords, &mut nodes);
        let w0 = p0.transform_point(&pr.point.into()).coords;
        let w1 = p1.transform_point(&pr.point.into()).coords;
        let normal = p1.transform_vector(&pr.normal);
        let velocity = (w1 - w0) / h;
        let rel = v - velocity;
        let plan = Plan {
            normal,
            point: w0,
            velocity,
            slip: rel - normal * normal.dot(&rel),
        };
        (plan, nodes)
    }

    /// Tests every free particle's path `a[i] -> b[i]` against every
    /// obstacle whose swept box meets the paths' box. Returns `(particle, obstacle)` for each crossing
    /// that `accept(obstacle, end)` keeps, where `end` is the path's end
    /// in the obstacle's frame.
    fn crossings(
        &mut self,
        a: &[Vec3],
        b: &[Vec3],
        pinned: &[bool],
        inside_start: bool,
        mut accept: impl FnMut(&Collider, &Vec3, &mut u64) -> bool,
    ) -> Vec<(u32, u32)> {
        let mut found = Vec::new();
        // The paths' box: an obstacle sweeping clear of it is skipped whole.
        let cloth = Aabb::of_points(a).union(&Aabb::of_points(b));
        for k in 0..self.colliders.len() {
            if !self.swept[k].overlaps(&cloth) {
                continue;
            }
            let c = &self.colliders[k];
            let (p0, p1) = self.poses[k];
            let world = self.swept[k];
            let local_bounds = c.surface.bounds();
            for i in 0..a.len() {
                if pinned[i]
                    || !Aabb::of_segment(&a[i], &b[i]).overlaps(&world)
                    || self.has_contact(i, k)
                {
                    continue;
                }
                let la = p0.inverse_transform_point(&a[i].into()).coords;
                let lb = p1.inverse_transform_point(&b[i].into()).coords;
                let mut nodes = 0;
                let hit = c.surface.first_hit(&la, &lb, &mut nodes).is_some();
                let keep = if hit {
                    accept(c, &lb, &mut nodes)
                } else {
                    // Already inside (initial overlap, or a miss): the
                    // nearest offset-surface point pushes it out.
                    // A particle left exactly on the surface (a released
                    // contact) is not inside: round-off must not re-make it.
                    inside_start
                        && local_bounds.contains(&la)
                        && c.surface.project(&la, &mut nodes).distance
                            < -ON_SURFACE * c.surface.offset() - 1e-12
                };
                self.counters.nodes += nodes;
                if keep {
                    found.push((i as u32, k as u32));
                }
            }
        }
        found
    }

    fn add_contacts(&mut self, new: &[(u32, u32)]) {
        self.counters.new += new.len();
        self.contacts
            .extend(new.iter().map(|&(particle, obstacle)| Contact {
                particle,
                obstacle,
                sticking: false,
                normal_force: 0.0,
            }));
        self.contacts.sort_by_key(|c| (c.particle, c.obstacle));
        self.contacts.dedup_by_key(|c| (c.particle, c.obstacle));
    }

    /// Before the solve of a step from `t` to `t + h`: finds new contacts
    /// along the predicted path `x + h (v + dv_guess)` and among particles
    /// already inside, then writes every contact's `S`, `z`, `y` and
    /// kinetic friction into `c` (pinned particles are left alone).
    #[allow(clippy::too_many_arguments)]
    pub fn prepare(
        &mut self,
        x: &[Vec3],
        v: &[Vec3],
        dv_guess: &[Vec3],
        mass: &[Real],
        t: Real,
        h: Real,
        pinned: &[bool],
        c: &mut Constraints,
    ) {
        let mut predicted = std::mem::take(&mut self.predicted);
        predicted.clear();
        predicted.extend((0..x.len()).map(|i| x[i] + (v[i] + dv_guess[i]) * h));
        self.set_poses(t, h);
        let new = self.crossings(x, &predicted, pinned, true, |_, _, _| true);
        self.predicted = predicted;
        self.add_contacts(&new);

        self.plans.clear();
        for k in 0..self.contacts.len() {
            let ct = self.contacts[k];
            let i = ct.particle as usize;
            let (plan, nodes) = self.plan(ct.obstacle as usize, &x[i], &v[i], h);
            self.counters.nodes += nodes;
            self.plans.push(plan);
        }
        let mut group: Vec<(Contact, Plan)> = Vec::with_capacity(4);
        let mut k = 0;
        while k < self.contacts.len() {
            let i = self.contacts[k].particle as usize;
            group.clear();
            while k < self.contacts.len() && self.contacts[k].particle as usize == i {
                group.push((self.contacts[k], self.plans[k]));
                k += 1;
            }
            if pinned[i] {
                continue;
            }
            contact::constrain(i, &group, &x[i], &v[i], h, self.max_push, c);
            for (ct, plan) in &group {
                let mu = self.colliders[ct.obstacle as usize].friction;
                c.impulse[i] += contact::kinetic_impulse(ct, plan, mu, mass[i], h);
            }
        }
    }

    /// After the solve: tests the path actually taken `x0 -> x1` of every
    /// particle not already in contact, returning the crossings that end
    /// deeper than [`SHALLOW`] offsets inside or pass through and out again
    /// (tunnelling): the step should be redone with them as contacts
    /// ([`Self::redo_with`]).
    pub fn check(&mut self, x0: &[Vec3], x1: &[Vec3], pinned: &[bool]) -> Vec<(u32, u32)> {
        self.crossings(x0, x1, pinned, false, |c, end, nodes| {
            let d = c.surface.project(end, nodes).distance;
            d >= 0.0 || d < -SHALLOW * c.surface.offset()
        })
    }

    /// Adds the crossings [`Self::check`] found before the step is redone.
    pub fn redo_with(&mut self, crossings: &[(u32, u32)]) {
        self.add_contacts(crossings);
        self.counters.redone += 1;
    }

    /// Adds crossings found after the last allowed redo: they take effect
    /// from the next step (call after [`Self::update`]).
    pub fn add_late(&mut self, crossings: &[(u32, u32)]) {
        self.add_contacts(crossings);
    }

    /// After an accepted step: with `lambda(i)` the constraint impulse on
    /// particle `i` (`A dv - b`), releases contacts whose normal impulse
    /// pulls the particle in (Baraff and Witkin), and switches friction:
    /// static while the tangential impulse holding it stays inside the cone
    /// `μ λn`,
    /// kinetic beyond; back to static when friction could stop the
    /// remaining slide within one step.
    pub fn update(
        &mut self,
        v1: &[Vec3],
        mass: &[Real],
        gravity: Real,
        h: Real,
        lambda: impl Fn(usize) -> Vec3,
    ) {
        let mut keep = vec![true; self.contacts.len()];
        for (k, ct) in self.contacts.iter_mut().enumerate() {
            let i = ct.particle as usize;
            let Some(plan) = self.plans.get(k) else {
                continue;
            };
            let l = lambda(i);
            let ln = plan.normal.dot(&l);
            if ln < -RELEASE_HYSTERESIS * mass[i] * gravity * h {
                keep[k] = false;
                continue;
            }
            ct.normal_force = ln.max(0.0) / h;
            let mu = self.colliders[ct.obstacle as usize].friction;
            if mu <= 0.0 {
                ct.sticking = false;
            } else if ct.sticking {
                // The tangential impulse that held it, less the one-off
                // impulse that stopped its slip at the start of the step.
                let hold = (l - plan.normal * ln + plan.slip * mass[i]).norm();
                ct.sticking = hold <= mu * ln;
            } else {
                let rel = v1[i] - plan.velocity;
                let slide = (rel - plan.normal * plan.normal.dot(&rel)).norm();
                ct.sticking = mass[i] * slide <= mu * ln;
            }
        }
        let before = self.contacts.len();
        let mut it = keep.iter();
        self.contacts.retain(|_| *it.next().unwrap_or(&true));
        self.counters.released += before - self.contacts.len();
        self.plans.clear();
    }

    /// The smallest signed distance from a particle to a true obstacle
    /// surface at time `t` (negative inside).
    pub fn min_true_distance(&self, x: &[Vec3], t: Real) -> Real {
        let mut best = Real::INFINITY;
        for c in &self.colliders {
            let pose = c.trajectory.pose(t);
            let bounds = c.surface.bounds();
            for p in x {
                let l = pose.inverse_transform_point(&(*p).into()).coords;
                // The bounds hold the true solid: a lower bound on distance.
                if bounds.distance_squared(&l).sqrt() >= best {
                    continue;
                }
                let mut nodes = 0;
                best = best.min(c.surface.true_distance(&l, &mut nodes));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{Motion, Sphere};

    fn sphere(velocity: [Real; 3]) -> Obstacle {
        Obstacle {
            sphere: Some(Sphere {
                center: [0.0, 0.0, -1.0],
                radius: 0.1,
            }),
            box_: None,
            plane: None,
            cylinder: None,
            mesh: None,
            friction: 0.0,
            offset: Some(0.01),
            motion: Some(Motion {
                velocity: Some(velocity),
                angular_velocity: None,
                pivot: None,
                keyframes: None,
            }),
        }
    }

    #[test]
    fn an_obstacle_passing_through_a_resting_particle_in_one_step_is_caught() {
        // 200 m/s for 0.01 s: the sphere's centre goes from z = -1 to 1,
        // through the particle at the origin. In the sphere's frame the
        // particle moves from (0, 0, 1) to (0, 0, -1) relative to the
        // centre: a crossing the test sees although neither end is inside.
        let h = 0.01;
        let mut stage = CollisionStage::new(&[sphere([0.0, 0.0, 200.0])], 0.1)
            .expect("builds")
            .expect("stage");
        let (x, v) = (vec![Vec3::zeros()], vec![Vec3::zeros()]);
        let mut c = Constraints::free(1);
        stage.prepare(&x, &v, &v, &[1.0], 0.0, h, &[false], &mut c);
        assert_eq!(stage.contacts().len(), 1);
        assert_eq!(c.filter[0].blocked(), 1);
        // Carried ahead of the sphere: the step ends on the offset surface
        // above its top (the 0.89 m gap at the start closed by velocity).
        let dv = c.z[0];
        assert!((dv.z - (200.0 - 0.89 / h)).abs() < 1e-9);
        let x1 = x[0] + (v[0] + dv) * h + c.y[0];
        assert!((x1.z - (1.0 + 0.11)).abs() < 1e-9, "{x1:?}");

        // The same particle next to a sphere moving sideways past it is
        // left alone, and a far obstacle is culled before any test.
        let mut stage = CollisionStage::new(&[sphere([200.0, 0.0, 0.0])], 0.1)
            .expect("builds")
            .expect("stage");
        let mut c = Constraints::free(1);
        stage.prepare(&x, &v, &v, &[1.0], 0.0, h, &[false], &mut c);
        assert!(stage.contacts().is_empty() && c.is_free());
        assert_eq!(stage.take_counters().nodes, 0);
    }
}
