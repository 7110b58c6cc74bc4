//! The impulses of the self-collision response (Bridson, Fedkiw &
//! Anderson 2002, §7.1): a change of a pair's relative velocity shared by
//! its four particles, and how each particle yields to it ([`Hold`]).

use crate::math::{Real, Vec3};

/// How a particle answers the response's impulses.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum Hold {
    /// It yields to impulses (its inverse mass).
    #[default]
    Free,
    /// A pin: it does not yield.
    Fixed,
    /// On an obstacle with this outward unit normal: it yields only to
    /// the part of an impulse that lifts it off.
    Lift(Vec3),
}

impl Hold {
    /// Whether it is held at all (its weight in a rigid zone).
    pub(super) fn is_held(&self) -> bool {
        *self != Hold::Free
    }
}

/// Applies the impulse that changes the pair's relative velocity by
/// `want`, shared by inverse mass and weight (`Δu_k = c_k w_k J`, `J =
/// want / Σ c_k² w_k`); nothing if every particle is held.
///
/// No particle's velocity changes by more than `|want|` (`J` is divided by
/// at least `max_k |c_k| w_k`). When held particles carry most of a pair,
/// the free ones have small coefficients and the exact impulse would move
/// them by `|want| / |c_k|`: in a curtain piling onto a floor, a free
/// corner of a triangle whose other corners rested on the floor
/// (`c = 0.0019`) was thrown at 450 m/s, and within ten steps the cloth
/// blew up. Such a pair keeps part of its approach; the next sweep and
/// the rigid zones, where held particles weigh finitely, stop it.
///
/// A particle on an obstacle (`Hold::Lift(n)`) takes only the impulse's
/// part along `n`, and only when that lifts it: its weight along the
/// impulse's direction `d` is `w (n·d)²` and its change `c w n (n·d) J`.
pub(super) fn apply(
    u: &mut [Vec3],
    idx: &[usize; 4],
    c: &[Real; 4],
    w: &[Mobility; 4],
    want: &Vec3,
) {
    impulse(u, idx, c, w, want, false);
}

/// [`apply`] for an inelastic collision, which must take kinetic energy
/// out: cut, if need be, to the impulse that leaves the energy as it was.
///
/// With free particles alone it never is cut (the impulse that stops the
/// approach takes out `½ vn² / Σ c_k² w_k`). A held particle yields only
/// along its normal, so an approach made by its sliding along the
/// obstacle can only be undone through the free particles and the held
/// ones' normals, and that can add energy: the sliding corners act as a
/// moving wall and throw a free vertex, or a held corner is thrown off
/// along its normal. In a fold over a 3 mm rod, the fastest particle's
/// step grew from 0.33 to 3.2, 9.5, 18 and 36 m over the four collision
/// sweeps, each sweep's pairs grew with the motion (2.4 million in the
/// last), and one frame took 22 s. An impulse `J` changes the energy by
/// `a J + ½ b J²`, with `b` the pair's weight and `a = Σ m_k u_k · Δu_k
/// / J`; it is cut to `J ≤ -2a/b` (none when `a ≥ 0`), and the approach
/// left goes to the next sweep and the rigid zones (which move the pair
/// as one, held particles weighing most).
pub(super) fn stop(
    u: &mut [Vec3],
    idx: &[usize; 4],
    c: &[Real; 4],
    w: &[Mobility; 4],
    want: &Vec3,
) {
    impulse(u, idx, c, w, want, true);
}

/// [`apply`], and [`stop`] when `inelastic`.
fn impulse(
    u: &mut [Vec3],
    idx: &[usize; 4],
    c: &[Real; 4],
    w: &[Mobility; 4],
    want: &Vec3,
    inelastic: bool,
) {
    let size = want.norm();
    if size <= 0.0 {
        return;
    }
    let d = want / size;
    // Each particle's change per unit of `J`, and its weight along `d`.
    let per: [(Vec3, Real); 4] = std::array::from_fn(|k| match w[k] {
        Mobility::Free(w) => (d * (c[k] * w), c[k] * c[k] * w),
        Mobility::Lift(w, n) => {
            let nd = n.dot(&d);
            if c[k] * nd > 0.0 {
                (n * (c[k] * w * nd), c[k] * c[k] * w * nd * nd)
            } else {
                (Vec3::zeros(), 0.0)
            }
        }
    });
    let weight: Real = per.iter().map(|p| p.1).sum();
    if weight <= 0.0 {
        return;
    }
    let reach = per.iter().map(|p| p.0.norm()).fold(0.0, Real::max);
    let mut j = size / weight.max(reach);
    if inelastic {
        let a: Real = (0..4)
            .map(|k| match w[k].inverse_mass() {
                wk if wk > 0.0 => u[idx[k]].dot(&per[k].0) / wk,
                _ => 0.0,
            })
            .sum();
        j = j.min((-2.0 * a / weight).max(0.0));
    }
    for k in 0..4 {
        u[idx[k]] += per[k].0 * j;
    }
}

/// A particle's inverse mass as the impulses see it ([`Hold`]).
#[derive(Debug, Clone, Copy)]
pub(super) enum Mobility {
    /// Inverse mass in every direction (0 for a pin).
    Free(Real),
    /// Inverse mass along the outward normal only, outwards only.
    Lift(Real, Vec3),
}

impl Mobility {
    /// Its inverse mass where it yields (0 for a pin).
    fn inverse_mass(&self) -> Real {
        match *self {
            Mobility::Free(w) | Mobility::Lift(w, _) => w,
        }
    }

    /// How a particle of mass `mass` held by `hold` yields.
    pub(super) fn of(hold: Hold, mass: Real) -> Self {
        let w = if mass > 0.0 { 1.0 / mass } else { 0.0 };
        match hold {
            Hold::Free => Mobility::Free(w),
            Hold::Fixed => Mobility::Free(0.0),
            Hold::Lift(n) => Mobility::Lift(w, n),
        }
    }
}

pub(super) fn relative(u: &[Vec3], idx: &[usize; 4], c: &[Real; 4]) -> Vec3 {
    (0..4).map(|k| u[idx[k]] * c[k]).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    const C: [Real; 4] = [1.0, -0.25, -0.25, -0.5];

    fn run(holds: [Hold; 4], want: Vec3) -> Vec<Vec3> {
        let mut u = vec![Vec3::zeros(); 4];
        let w = holds.map(|h| Mobility::of(h, 0.5));
        apply(&mut u, &[0, 1, 2, 3], &C, &w, &want);
        u
    }

    /// Free particles: the relative velocity changes by exactly `want`
    /// (the vertex moves most), momentum is kept (equal masses, weights
    /// summing to zero).
    #[test]
    fn free_pair_gets_exactly_the_change_asked() {
        let want = Vec3::new(0.0, 0.0, 0.3);
        let u = run([Hold::Free; 4], want);
        assert!((relative(&u, &[0, 1, 2, 3], &C) - want).norm() < 1e-15);
        assert!(u.iter().sum::<Vec3>().norm() < 1e-15);
    }

    /// A triangle resting on the floor under a vertex that falls onto it:
    /// the floor does not let the triangle be pushed down, so the vertex
    /// takes the whole change; a pinned corner takes none.
    #[test]
    fn a_particle_on_an_obstacle_is_never_pushed_in() {
        let up = Vec3::z();
        let lift = Hold::Lift(up);
        let want = up * 0.3;
        let u = run([Hold::Free, lift, lift, Hold::Fixed], want);
        assert_eq!(u[1], Vec3::zeros());
        assert_eq!(u[2], Vec3::zeros());
        assert_eq!(u[3], Vec3::zeros());
        assert!((u[0] - want).norm() < 1e-15);
    }

    /// The same pair upside down (the vertex under the triangle, both on
    /// the floor): the triangle may leave the floor, only along its normal,
    /// and a sideways part of the change moves only the free vertex.
    #[test]
    fn a_particle_on_an_obstacle_is_lifted_off_along_its_normal() {
        let up = Vec3::z();
        let want = Vec3::new(0.1, 0.0, -0.3);
        let u = run(
            [Hold::Lift(up), Hold::Lift(up), Hold::Free, Hold::Free],
            want,
        );
        assert_eq!(u[0], Vec3::zeros(), "the vertex would go down: it stays");
        assert!(u[1].x == 0.0 && u[1].y == 0.0 && u[1].z > 0.0, "{:?}", u[1]);
        // The pair's relative velocity changes along `want`, by no more
        // than asked (the triangle alone carries it: capped so that no
        // particle moves faster than `|want|`).
        let d = want.normalize();
        let along = relative(&u, &[0, 1, 2, 3], &C).dot(&d);
        assert!(
            along > 0.5 * want.norm() && along <= want.norm() * (1.0 + 1e-12),
            "{along}"
        );
        assert!(u.iter().all(|v| v.norm() <= want.norm() * (1.0 + 1e-12)));
    }

    /// An inelastic impulse never adds kinetic energy: with free particles
    /// it is [`apply`]'s to the bit; where held corners sliding along
    /// their obstacle make the approach, [`apply`] would throw the free
    /// vertex ahead of them, and [`stop`] is cut.
    #[test]
    fn an_inelastic_impulse_takes_energy_out() {
        let energy = |u: &[Vec3]| u.iter().map(|v| 0.5 * 0.5 * v.norm_squared()).sum::<Real>();
        let idx = [0, 1, 2, 3];
        let free = [Hold::Free; 4].map(|h| Mobility::of(h, 0.5));
        let start = vec![
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::zeros(),
            Vec3::zeros(),
            Vec3::zeros(),
        ];
        let want = Vec3::z() * -relative(&start, &idx, &C).z;
        let (mut a, mut b) = (start.clone(), start.clone());
        apply(&mut a, &idx, &C, &free, &want);
        stop(&mut b, &idx, &C, &free, &want);
        assert_eq!(a, b);
        assert!(energy(&b) < energy(&start));
        // The triangle's corners rest on a floor (normal z) and slide
        // along x into a vertex beside them; the pair's normal is nearly
        // along x.
        let n = Vec3::new(1.0, 0.0, 0.05).normalize();
        let held = [
            Hold::Free,
            Hold::Lift(Vec3::z()),
            Hold::Lift(Vec3::z()),
            Hold::Lift(Vec3::z()),
        ]
        .map(|h| Mobility::of(h, 0.5));
        let sliding = vec![
            Vec3::zeros(),
            Vec3::x() * 2.0,
            Vec3::x() * 2.0,
            Vec3::x() * 2.0,
        ];
        let vn = relative(&sliding, &idx, &C).dot(&n);
        assert!(vn < 0.0, "they approach");
        let (mut a, mut b) = (sliding.clone(), sliding.clone());
        apply(&mut a, &idx, &C, &held, &(n * -vn));
        stop(&mut b, &idx, &C, &held, &(n * -vn));
        assert!(
            energy(&a) > energy(&sliding),
            "the uncut impulse adds energy"
        );
        assert!(energy(&b) <= energy(&sliding) * (1.0 + 1e-12));
    }

    /// Held corners carrying most of a pair cannot make the impulse throw
    /// the free one: no particle's change exceeds `|want|`.
    #[test]
    fn no_particle_moves_faster_than_the_change_asked() {
        let c = [1.0, -0.998, -0.001, -0.001];
        let mut u = vec![Vec3::zeros(); 4];
        let w = [Hold::Fixed, Hold::Fixed, Hold::Free, Hold::Free].map(|h| Mobility::of(h, 0.5));
        let want = Vec3::z() * 0.3;
        apply(&mut u, &[0, 1, 2, 3], &c, &w, &want);
        assert!(u.iter().all(|v| v.norm() <= want.norm() * (1.0 + 1e-12)));
        assert!(u[2].norm() > 0.0);
    }
}
