//! The plans' tests: the pairs a plan gives hold every pair a refit finds.

use super::*;
use rand::{RngExt, SeedableRng, rngs::StdRng};

impl Plan {
    /// The largest particle bound.
    fn reach(&self) -> Real {
        self.reach_of.iter().copied().fold(0.0, Real::max)
    }

    /// The largest edge bound.
    fn bend(&self) -> Real {
        self.bend_of.iter().copied().fold(0.0, Real::max)
    }
}

/// Columns of the strip [`folded`] makes.
const NU: usize = 16;

/// A 16 x 6 strip folded back over itself 0.1 spacings above, at 0.3
/// of its length, and its mesh.
fn folded() -> (ClothMesh, Vec<Vec3>) {
    let nv = 6;
    let grid = crate::testing::flat_grid(NU, nv, [1.5, 0.5]);
    let mesh = ClothMesh::new(&grid);
    let x = crate::testing::folded_strip(NU, nv, mesh.spacing, 0.3, 0.1);
    (mesh, x)
}

/// Asserts that `plan` serves the motion from `x0` to `x1` with pad `pad`
/// and that its pairs hold every pair a refit over that motion finds;
/// returns how many the refit found.
fn holds_a_refit(
    plan: &Plan,
    mesh: &mut ClothMesh,
    (x0, x1): (&[Vec3], &[Vec3]),
    pad: Real,
) -> usize {
    let (mut vf, mut ee, mut vf1, mut ee1) = (vec![], vec![], vec![], vec![]);
    assert!(plan.pairs(mesh, (x0, x1), pad, &mut vf, &mut ee));
    mesh.refit(x0, x1, pad);
    mesh.feature_pairs(&mut vf1, &mut ee1);
    for pair in &vf1 {
        assert!(vf.contains(pair), "vertex-face {pair:?} missing");
    }
    for pair in &ee1 {
        assert!(ee.contains(pair), "edge-edge {pair:?} missing");
    }
    vf1.len() + ee1.len()
}

/// A crumpled cloth and random motions within a plan's bounds: the
/// plan's pairs for each motion hold every pair a refit over that
/// motion finds, and a motion out of bounds is refused.
#[test]
fn planned_pairs_hold_every_pair_of_a_motion_within_the_bounds() {
    // The folded strip, jittered.
    let mut rng = StdRng::seed_from_u64(13);
    let (mut mesh, x) = folded();
    let s = mesh.spacing;
    let x: Vec<Vec3> = x
        .into_iter()
        .map(|p| {
            let jitter = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ) * 0.05;
            p + jitter * s
        })
        .collect();
    let pad = 0.2 * mesh.spacing;
    let step = 0.003 * mesh.spacing;
    let last: Vec<Vec3> = (0..x.len())
        .map(|_| Vec3::new(rng.random_range(-1.0..1.0), 0.0, 0.0) * step)
        .collect();
    let mut plan = Plan::default();
    assert!(plan.make(&mut mesh, &x, pad, &last));
    let (reach, bend) = (plan.reach(), plan.bend());
    // Each particle's own bounds are at least a share of the largest.
    let least = |v: &[Real]| v.iter().copied().fold(Real::INFINITY, Real::min);
    let (reach_least, bend_least) = (least(&plan.reach_of), least(&plan.bend_of));
    assert!(reach_least >= SHARE_OF_LARGEST * reach && reach_least < reach);
    assert!(bend_least >= SHARE_OF_LARGEST * bend);
    let (mut vf, mut ee) = (vec![], vec![]);
    let mut compared = 0;
    // Positions within every particle's bounds: a common drift plus a
    // small part per particle, so neighbours stay within `bend_least` of
    // each other.
    let mut near = |drift: Vec3| -> Vec<Vec3> {
        x.iter()
            .map(|p| {
                let own = Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                ) * (0.25 * bend_least.min(reach_least));
                p + drift * (0.5 * reach_least) + own
            })
            .collect()
    };
    for round in 0..20 {
        // From the plan's base, or (the steps after it) from elsewhere
        // within the bounds.
        let x0 = if round % 3 == 0 {
            x.clone()
        } else {
            near(Vec3::new(-0.2, 0.7, 0.3).normalize())
        };
        let x1 = near(Vec3::new(0.6, -0.3, 0.5).normalize());
        let p = if round % 2 == 0 { pad } else { 0.05 * pad };
        compared += holds_a_refit(&plan, &mut mesh, (&x0, &x1), p);
    }
    // A later step near the base, moving slowly, keeps the plan; one
    // whose next motion could leave the bounds plans again.
    let later: Vec<Vec3> = x
        .iter()
        .map(|p| p + Vec3::z() * (0.5 * reach_least))
        .collect();
    let slow: Vec<Vec3> = last.iter().map(|d| d * 0.1).collect();
    assert!(plan.make(&mut mesh, &later, pad, &slow));
    assert_eq!((plan.base.as_slice(), plan.reach()), (x.as_slice(), reach));
    let quick: Vec<Vec3> = last.iter().map(|d| d * 4.0).collect();
    assert!(plan.make(&mut mesh, &later, pad, &quick));
    assert_eq!(plan.base, later);
    plan = Plan::default();
    assert!(plan.make(&mut mesh, &x, pad, &last));
    assert_eq!(plan.reach(), reach);
    assert!(compared > 100, "only {compared} pairs compared");
    // Out of bounds: a particle moved by twice the reach.
    let mut far = x.clone();
    far[5].z += 2.0 * reach;
    assert!(!plan.pairs(&mut mesh, (&x, &far), pad, &mut vf, &mut ee));
    // A larger pad, or another start, is refused too.
    assert!(!plan.pairs(&mut mesh, (&x, &x), 2.0 * pad, &mut vf, &mut ee));
    assert!(!plan.pairs(&mut mesh, (&far, &far), pad, &mut vf, &mut ee));
    // The response covers a motion the plan did not: planned again
    // around it, its pairs hold a refit's.
    let moved: Vec<Vec3> = far.iter().zip(&x).map(|(a, b)| a - b).collect();
    plan.cover(&mut mesh, &x, pad, &moved);
    assert!(plan.reach() >= 2.0 * reach, "planned around the new motion");
    holds_a_refit(&plan, &mut mesh, (&x, &far), pad);
    // A motion the plan holds keeps it.
    let before = plan.reach();
    let half: Vec<Vec3> = moved.iter().map(|d| d * 0.5).collect();
    plan.cover(&mut mesh, &x, pad, &half);
    assert_eq!(plan.reach(), before);
}

/// A strip folded over itself whose free end flaps while the rest
/// creeps: the flapping particles get bounds of their own, larger than
/// the rest's, and motions that take them that far (past the others'
/// bounds) keep the plan, whose pairs hold every pair a refit finds; the
/// same distance for a creeping particle does not.
#[test]
fn a_flapping_end_has_bounds_of_its_own() {
    let (mut mesh, x) = folded();
    let (s, nu) = (mesh.spacing, NU);
    let flaps = |k: usize| k % nu == nu - 1;
    let last: Vec<Vec3> = (0..x.len())
        .map(|k| Vec3::new(0.0, 0.0, if flaps(k) { 0.02 } else { 0.001 }) * s)
        .collect();
    let pad = 0.2 * s;
    let mut plan = Plan::default();
    assert!(plan.make(&mut mesh, &x, pad, &last));
    // The last column flaps; the first does not.
    let (fast, slow) = (plan.reach_of[nu - 1], plan.reach_of[0]);
    assert!(fast > 3.0 * slow, "bounds {fast} and {slow}");
    assert!(slow >= SHARE_OF_LARGEST * plan.reach());
    let mut compared = 0;
    for round in 0..6 {
        // The end up or down by most of its own bound, the rest by a
        // little, so the edges beside the end bend by its motion.
        let sign = if round % 2 == 0 { 1.0 } else { -1.0 };
        let x1: Vec<Vec3> = x
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let by = if flaps(k) { 0.45 * fast } else { 0.1 * slow };
                p + Vec3::z() * (sign * by)
            })
            .collect();
        compared += holds_a_refit(&plan, &mut mesh, (&x, &x1), pad);
    }
    assert!(compared > 50, "only {compared} pairs compared");
    // A creeping particle moved as far as the end may: out of bounds.
    let mut far = x.clone();
    far[nu / 2].z += 0.9 * fast;
    let (mut vf, mut ee) = (vec![], vec![]);
    assert!(!plan.pairs(&mut mesh, (&x, &far), pad, &mut vf, &mut ee));
}

/// A flat cloth at rest is planned with no pair at all; a motion too
/// large is not planned.
#[test]
fn a_flat_cloth_plans_nothing_and_fast_motion_is_not_planned() {
    let grid = crate::testing::flat_grid(20, 20, [1.0, 1.0]);
    let mut mesh = ClothMesh::new(&grid);
    let rest = vec![Vec3::zeros(); grid.len()];
    let mut plan = Plan::default();
    assert!(plan.make(&mut mesh, &grid.rest, 0.005, &rest));
    assert!(plan.vf.is_empty() && plan.ee.is_empty());
    let fast = vec![Vec3::new(0.0, 0.0, 0.2 * mesh.spacing); grid.len()];
    assert!(!plan.make(&mut mesh, &grid.rest, 0.005, &fast));
}

/// Motion too fast for a step's plan (a folded strip sliding by 0.3
/// spacings): the response plans for it alone, and that plan's pairs for
/// the motions a response may take within its bounds (the solve's, and
/// the solve's changed by impulses) hold every pair a refit finds; a
/// motion past its caps is not planned.
#[test]
fn a_response_plans_a_motion_too_fast_for_a_step() {
    let (mut mesh, x) = folded();
    let s = mesh.spacing;
    let mut rng = StdRng::seed_from_u64(29);
    let mut jitter = |size: Real| {
        Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) * size
    };
    let slide = Vec3::new(0.25, 0.1, -0.1) * s;
    let moved: Vec<Vec3> = x.iter().map(|_| slide + jitter(0.02 * s)).collect();
    let pad = 0.01 * s;
    let mut plan = Plan::default();
    assert!(
        !plan.make(&mut mesh, &x, pad, &moved),
        "too fast for a step"
    );
    assert!(plan.for_response(&mut mesh, &x, pad, &moved));
    let (mut vf, mut ee) = (vec![], vec![]);
    let mut compared = 0;
    for round in 0..10 {
        // Scaled, and shifted as a whole: each particle and edge within
        // its own bound (`Plan::reach_of`, `Plan::bend_of`).
        let scale = 0.5 + 0.06 * round as Real;
        let shift = jitter(0.005 * s);
        let x1: Vec<Vec3> = x
            .iter()
            .zip(&moved)
            .map(|(p, d)| p + d * scale + shift)
            .collect();
        let p = if round % 2 == 0 { pad } else { 0.1 * pad };
        compared += holds_a_refit(&plan, &mut mesh, (&x, &x1), p);
    }
    assert!(compared > 100, "only {compared} pairs compared");
    // Twice as far as planned for, and three times the motion: refused.
    let twice: Vec<Vec3> = x.iter().zip(&moved).map(|(p, d)| p + d * 2.0).collect();
    assert!(!plan.pairs(&mut mesh, (&x, &twice), pad, &mut vf, &mut ee));
    let fast: Vec<Vec3> = moved.iter().map(|d| d * 3.0).collect();
    assert!(!plan.for_response(&mut mesh, &x, pad, &fast));
}
