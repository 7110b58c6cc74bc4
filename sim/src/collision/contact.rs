//! Contacts and their response inside the solve (method.md §4): each
//! contact becomes a filter `S`, a target `z` and a correction `y` of the
//! modified PCG (eqs. [15]-[20]), never a force.
//!
//! For a contact with world normal `n`, offset-surface point `p0` now,
//! obstacle velocity `w` there (so the point is at `p0 + w h` when the
//! step ends), and the particle's signed gap `g = n·(x - p0)`; the step's
//! scheme ends the particle at `x + p + h' v1 + y` ([`Scheme::end`]; for
//! backward Euler `p = 0`, `h' = h`):
//!
//! - sliding: `S = I - n nᵀ`; for a particle outside (`g > 0`) the normal
//!   velocity `n·v1` that lands it on the moving surface when the step
//!   ends, no correction; for one inside `n·v1 = n·w` and the correction
//!   `y` along `n` of eq. [20] that puts it back on the surface (§4,
//!   "position"); `z = n (n·v1 - n·v)`;
//! - sticking (static friction): `S = 0`, the same split with the whole
//!   vectors: the particle moves with the obstacle.
//!
//! Closing a gap through the velocity rather than through `y` keeps the
//! constraint force honest: if the particle was not really going to reach
//! the surface, holding it to the landing velocity pulls, the normal
//! impulse turns negative, and the contact is released.
//!
//! A particle touching two surfaces is blocked along both normals, with
//! `z` and `y` solving both conditions in the span of the normals.

use crate::math::{Real, Vec3};
use crate::solver::{Constraints, Filter, Scheme};

/// A particle held by an obstacle.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    /// The particle.
    pub particle: u32,
    /// The obstacle (index into the scene's obstacles).
    pub obstacle: u32,
    /// Static friction holds it (it moves with the obstacle).
    pub sticking: bool,
    /// Normal force of the last solve, N (0 for a new contact).
    pub normal_force: Real,
    /// The tangential force static friction failed to hold when the
    /// contact last broke loose, N, fading while it slides
    /// (`collision::stage`'s `LOAD_MEMORY`; 0 if it never broke loose): a
    /// sliding contact sticks again only when friction could hold that
    /// load as well as stop the slide (the hysteresis that keeps a
    /// particle whose load exceeds the cone from flipping between
    /// sticking and sliding every step).
    #[serde(default)]
    pub load: Real,
}

/// A contact's geometry for the current step, in the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan {
    /// Outward unit normal of the offset surface.
    pub normal: Vec3,
    /// Offset-surface point nearest the particle, at the start of the step.
    pub point: Vec3,
    /// Obstacle velocity at that point over the step.
    pub velocity: Vec3,
    /// The particle's tangential velocity relative to the obstacle at the
    /// start of the step.
    pub slip: Vec3,
}

impl Plan {
    /// Whether a particle at `x` moving at `v` is leaving the surface: on
    /// or outside it and moving away from it, relative to the obstacle,
    /// by more than the surface's `offset` over the step of `h`. A
    /// resting particle's round-off never comes near that; a particle
    /// flung off an edge or lifted by the cloth does.
    pub fn leaving(&self, x: &Vec3, v: &Vec3, h: Real, offset: Real) -> bool {
        let gap = self.normal.dot(&(x - self.point));
        let away = self.normal.dot(&(v - self.velocity)) * h;
        gap >= 0.0 && away > offset
    }
}

/// Writes particle `i`'s constraints from its contacts this step (all
/// with `particle == i`, plans alongside) given its velocity `v` and
/// position `x`, for a step of `scheme`. A push out of the solid longer
/// than `max_push` is shortened to it (the rest follows in later steps);
/// the part of the correction that only cancels what the scheme carries
/// into the surface is not (`carried_in`).
pub fn constrain(
    i: usize,
    contacts: &[(Contact, Plan)],
    x: &Vec3,
    v: &Vec3,
    scheme: &Scheme<'_>,
    max_push: Real,
    c: &mut Constraints,
) {
    // `y = push + carried`: only the push is capped.
    let cap = |y: Vec3, carried: Vec3| {
        let push = y - carried;
        let n = push.norm();
        let push = if n > max_push {
            push * (max_push / n)
        } else {
            push
        };
        push + carried
    };
    let h = scheme.h;
    if let Some((_, p)) = contacts.iter().find(|(k, _)| k.sticking) {
        let target = p.point + p.velocity * h;
        let (v1, y) = if p.normal.dot(&(p.point - x)) < 0.0 {
            (scheme.velocity_to(i, x, &target), Vec3::zeros())
        } else {
            let carried = carried_in(i, p, scheme);
            (
                p.velocity,
                cap(target - scheme.end(i, x, &p.velocity), carried),
            )
        };
        c.fix(i, v1 - v, y);
        return;
    }
    // Conditions n·dv = a, n·y = e per contact (e = n·(push + carried),
    // the carried part `k`); keep the two that push out hardest if more
    // touch at once.
    let mut rows: Vec<(Vec3, Real, Real, Real)> = contacts
        .iter()
        .map(|(_, p)| {
            let n = p.normal;
            let target = p.point + p.velocity * h;
            if n.dot(&(p.point - x)) < 0.0 {
                let v1n = n.dot(&scheme.velocity_to(i, x, &target));
                (n, v1n - n.dot(v), 0.0, 0.0)
            } else {
                let v1n = n.dot(&p.velocity);
                let e = n.dot(&(target - scheme.end(i, x, &(n * v1n))));
                (n, v1n - n.dot(v), e, n.dot(&carried_in(i, p, scheme)))
            }
        })
        .collect();
    rows.sort_by(|a, b| b.2.total_cmp(&a.2));
    let (z, y, carried, filter) = match rows.as_slice() {
        [] => return,
        [(n, a, e, k)] => (n * *a, n * *e, n * *k, Filter::Plane(*n)),
        [(n1, a1, e1, k1), (n2, a2, e2, k2), ..] => {
            let g = n1.dot(n2);
            let det = 1.0 - g * g;
            if det < 1e-6 {
                (n1 * *a1, n1 * *e1, n1 * *k1, Filter::Plane(*n1))
            } else {
                // Gram system [1 g; g 1] α = rhs, solution α1 n1 + α2 n2.
                let solve = |r1: Real, r2: Real| {
                    let a = (r1 - g * r2) / det;
                    let b = (r2 - g * r1) / det;
                    n1 * a + n2 * b
                };
                (
                    solve(*a1, *a2),
                    solve(*e1, *e2),
                    solve(*k1, *k2),
                    Filter::blocking(&[*n1, *n2]),
                )
            }
        }
    };
    c.filter[i] = filter;
    c.z[i] = z;
    c.y[i] = cap(y, carried);
}

/// The part of a held particle's correction that cancels what the scheme
/// alone would carry it over the step, relative to the surface: `w (h -
/// h') - p` for a particle moving with the surface at `w`. Zero under
/// backward Euler (`p = 0`, `h' = h`). Under BDF2 the last step's motion
/// `p` of a particle that has just landed points into the surface, up to
/// a third of that step's fall; capped like a push out of the solid, it
/// was carried in: a table-drape under BDF2 had cloth 3.4 mm inside the
/// box's side, held there by contacts whose corrections were cut to the
/// cap.
fn carried_in(i: usize, p: &Plan, scheme: &Scheme<'_>) -> Vec3 {
    p.velocity * (scheme.h - scheme.h_eff()) - scheme.carry(i)
}

/// The kinetic friction impulse on a sliding particle over a step of `h`:
/// `μ |f_n| h` against its tangential velocity relative to the obstacle,
/// no more than stops it (friction never reverses the slide).
pub fn kinetic_impulse(k: &Contact, p: &Plan, mu: Real, mass: Real, h: Real) -> Vec3 {
    if k.sticking || mu <= 0.0 || k.normal_force <= 0.0 {
        return Vec3::zeros();
    }
    let speed = p.slip.norm();
    if speed <= 0.0 {
        return Vec3::zeros();
    }
    let magnitude = (mu * k.normal_force * h).min(mass * speed);
    -p.slip * (magnitude / speed)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A contact's plan with no slip.
    fn plan_at(normal: Vec3, point: Vec3, velocity: Vec3) -> Plan {
        Plan {
            normal,
            point,
            velocity,
            slip: Vec3::zeros(),
        }
    }

    /// On a table's top (normal `+z`, offset 2 mm, step 1/240 s): resting
    /// or sliding along the top it stays; flung up or off faster than an
    /// offset a step it leaves; moving away from inside the surface (being
    /// pushed out) it stays; on a table moving up with it, it stays.
    #[test]
    fn a_particle_leaves_when_it_moves_away_faster_than_an_offset_a_step() {
        let (h, offset) = (1.0 / 240.0, 0.002);
        let plan = |velocity: Vec3| plan_at(Vec3::z(), Vec3::zeros(), velocity);
        let still = plan(Vec3::zeros());
        let on = Vec3::zeros();
        let fast = offset / h * 1.5;
        assert!(!still.leaving(&on, &Vec3::new(3.0, 0.0, 1e-6), h, offset));
        assert!(!still.leaving(&on, &Vec3::new(0.0, 0.0, 0.5 * offset / h), h, offset));
        assert!(still.leaving(&on, &Vec3::new(2.0, 0.0, fast), h, offset));
        assert!(!still.leaving(
            &(on - Vec3::z() * 1e-4),
            &Vec3::new(0.0, 0.0, fast),
            h,
            offset
        ));
        let rising = plan(Vec3::new(0.0, 0.0, fast));
        assert!(!rising.leaving(&on, &Vec3::new(0.0, 0.0, fast), h, offset));
    }

    fn contact(sticking: bool) -> Contact {
        Contact {
            particle: 0,
            obstacle: 0,
            sticking,
            normal_force: 1.0,
            load: 0.0,
        }
    }

    #[test]
    fn sliding_contact_sets_the_normal_velocity_and_lands_on_the_surface() {
        let mut c = Constraints::free(1);
        let n = Vec3::new(0.0, 0.6, 0.8);
        let plan = plan_at(n, Vec3::new(0.0, 0.0, 0.1), Vec3::new(0.5, 0.0, 1.0));
        let (x, v, h) = (Vec3::new(0.3, -0.2, 0.05), Vec3::new(1.0, 2.0, -3.0), 0.01);
        constrain(
            0,
            &[(contact(false), plan)],
            &x,
            &v,
            &Scheme::euler(h),
            1.0,
            &mut c,
        );
        // Any free dv leaves the normal parts where z puts them.
        let dv = c.z[0] + c.filter[0].apply(&Vec3::new(0.7, -0.4, 0.2));
        assert!(((v + dv).dot(&n) - plan.velocity.dot(&n)).abs() < 1e-14);
        let x1 = x + (v + dv) * h + c.y[0];
        let p1 = plan.point + plan.velocity * h;
        assert!((x1 - p1).dot(&n).abs() < 1e-14);

        // Outside, the gap closes through the velocity: no correction, and
        // the step still ends on the surface.
        let above = plan.point + n * 0.02;
        let mut c = Constraints::free(1);
        constrain(
            0,
            &[(contact(false), plan)],
            &above,
            &v,
            &Scheme::euler(h),
            1.0,
            &mut c,
        );
        assert_eq!(c.y[0], Vec3::zeros());
        let x1 = above + (v + c.z[0]) * h;
        assert!((x1 - p1).dot(&n).abs() < 1e-14);
    }

    #[test]
    fn two_surfaces_block_both_normals() {
        let mut c = Constraints::free(1);
        let n1 = Vec3::z();
        let n2 = Vec3::new(1.0, 0.0, 1.0).normalize();
        let p1 = plan_at(n1, Vec3::new(0.0, 0.0, 0.0), Vec3::zeros());
        let p2 = plan_at(n2, Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.2));
        let (x, v, h) = (Vec3::new(0.0, 0.0, -0.01), Vec3::new(0.0, 1.0, -1.0), 0.01);
        constrain(
            0,
            &[(contact(false), p1), (contact(false), p2)],
            &x,
            &v,
            &Scheme::euler(h),
            1.0,
            &mut c,
        );
        assert_eq!(c.filter[0].blocked(), 2);
        let dv = c.z[0] + c.filter[0].apply(&Vec3::new(0.3, 0.3, 0.3));
        let x1 = x + (v + dv) * h + c.y[0];
        for p in [p1, p2] {
            assert!(((v + dv).dot(&p.normal) - p.velocity.dot(&p.normal)).abs() < 1e-12);
            assert!((x1 - p.point - p.velocity * h).dot(&p.normal).abs() < 1e-12);
        }
    }

    #[test]
    fn sticking_moves_with_the_obstacle_and_friction_never_reverses() {
        let mut c = Constraints::free(1);
        let mut plan = plan_at(
            Vec3::z(),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        );
        let (x, v, h) = (Vec3::new(1.0, 0.0, 0.001), Vec3::zeros(), 0.01);
        constrain(
            0,
            &[(contact(true), plan)],
            &x,
            &v,
            &Scheme::euler(h),
            1.0,
            &mut c,
        );
        assert_eq!(c.filter[0], Filter::Fixed);
        let x1 = x + (v + c.z[0]) * h + c.y[0];
        assert!((x1 - (plan.point + plan.velocity * h)).norm() < 1e-15);

        plan.slip = Vec3::new(0.0, 1e-3, 0.0);
        let j = kinetic_impulse(&contact(false), &plan, 0.5, 2.0, h);
        assert!(
            (j - Vec3::new(0.0, -2e-3, 0.0)).norm() < 1e-15,
            "stops, does not reverse"
        );
        plan.slip = Vec3::new(3.0, 0.0, 0.0);
        let j = kinetic_impulse(&contact(false), &plan, 0.5, 2.0, h);
        assert!(
            (j - Vec3::new(-0.005, 0.0, 0.0)).norm() < 1e-15,
            "μ |f_n| h against the slide"
        );
    }

    /// Under BDF2 (`x1 = x0 + p + h' v1 + y`) a particle that landed on a
    /// moving surface last step carries `p = β (x0 - x_prev)` into it,
    /// here four times the cap on a push: sliding or sticking, the step
    /// still ends on the surface, and only a push out from inside is
    /// capped (1 mm inside, the cap 0.5 mm: it ends 0.5 mm inside).
    #[test]
    fn what_bdf2_carries_into_the_surface_is_cancelled_whatever_the_cap() {
        let (h, max_push) = (0.01, 5e-4);
        let n = Vec3::new(0.0, 0.6, 0.8);
        let plan = plan_at(n, Vec3::new(0.0, 0.0, 0.1), Vec3::new(0.5, 0.0, 0.2));
        let dx = [Vec3::new(0.001, 0.0, 0.0) - n * (12.0 * max_push)];
        let dvs = [Vec3::zeros()];
        let bdf2 = Scheme::bdf2(h, h, &dx, &dvs);
        assert!(bdf2.carry(0).dot(&n) < -3.9 * max_push);
        let v = Vec3::new(1.0, 0.5, -2.0);
        for (depth, sticking) in [(0.0, false), (0.0, true), (1e-3, false), (1e-3, true)] {
            let x = plan.point - n * depth;
            let mut c = Constraints::free(1);
            constrain(
                0,
                &[(contact(sticking), plan)],
                &x,
                &v,
                &bdf2,
                max_push,
                &mut c,
            );
            let dv = c.z[0] + c.filter[0].apply(&Vec3::new(0.7, -0.4, 0.2));
            let x1 = bdf2.end(0, &x, &(v + dv)) + c.y[0];
            let gap = (x1 - plan.point - plan.velocity * h).dot(&n);
            let expected = -(depth - max_push).max(0.0);
            assert!(
                (gap - expected).abs() < 1e-14,
                "depth {depth}, sticking {sticking}: ends {gap} from the surface"
            );
        }
    }
}
