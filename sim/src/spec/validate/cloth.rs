//! `cloth`: the grid, its size and directions, the pins.

use super::check::{Check, MAX_CLOTH_SIDE};
use super::obstacle::validate_motion;
use crate::spec::limits::Limits;
use crate::spec::scene::ClothScene;
use crate::spec::types::{PinEntry, Spec};

pub(super) fn validate_cloth(spec: &Spec, limits: &Limits, c: &mut Check) -> Option<ClothScene> {
    let cl = &spec.cloth;
    let mut ok = true;
    for k in 0..2 {
        if cl.grid[k] < 2 {
            c.fail(format!("cloth.grid[{k}]"), "must be >= 2");
            ok = false;
        }
        if !c.range(
            &format!("cloth.size[{k}]"),
            cl.size[k],
            true,
            MAX_CLOTH_SIDE,
        ) {
            ok = false;
        }
    }
    let particles = u64::from(cl.grid[0]) * u64::from(cl.grid[1]);
    if particles > limits.max_particles as u64 {
        c.fail(
            "cloth.grid",
            format!(
                "{particles} particles exceeds the limit of {}",
                limits.max_particles
            ),
        );
        ok = false;
    }
    let origin = c.point("cloth.origin", cl.origin);
    let u = c.direction("cloth.u", cl.u.unwrap_or([1.0, 0.0, 0.0]));
    let v = c.direction("cloth.v", cl.v.unwrap_or([0.0, 1.0, 0.0]));
    if let (Some(u), Some(v)) = (u, v)
        && u.dot(&v).abs() > 1e-6
    {
        c.fail("cloth.v", "must be perpendicular to cloth.u");
        ok = false;
    }
    let (nu, nv) = (cl.grid[0] as usize, cl.grid[1] as usize);
    // (particle, motion group, entry index), then sorted by particle.
    let mut pins: Vec<(usize, Option<usize>, usize)> = Vec::with_capacity(cl.pinned.len());
    let mut pin_motions = Vec::new();
    let mut pin = |at: String, p: &[u32; 2], group: Option<usize>, k: usize, c: &mut Check| {
        let mut inside = true;
        for (axis, n) in [(0, nu), (1, nv)] {
            if p[axis] as usize >= n {
                c.fail(
                    format!("{at}[{axis}]"),
                    format!("must be < {n} (cloth.grid[{axis}])"),
                );
                inside = false;
            }
        }
        if inside {
            pins.push((p[0] as usize + p[1] as usize * nu, group, k));
        }
        inside
    };
    for (k, entry) in cl.pinned.iter().enumerate() {
        match entry {
            PinEntry::Particle(p) => ok &= pin(format!("cloth.pinned[{k}]"), p, None, k, c),
            PinEntry::Group(g) => {
                if g.particles.is_empty() {
                    c.fail(format!("cloth.pinned[{k}].particles"), "must not be empty");
                    ok = false;
                }
                let group = g.motion.as_ref().map(|m| {
                    validate_motion(&format!("cloth.pinned[{k}].motion"), m, c);
                    pin_motions.push(m.clone());
                    pin_motions.len() - 1
                });
                for (m, p) in g.particles.iter().enumerate() {
                    ok &= pin(format!("cloth.pinned[{k}].particles[{m}]"), p, group, k, c);
                }
            }
        }
    }
    pins.sort_unstable();
    pins.dedup_by_key(|p| (p.0, p.1));
    for w in pins.windows(2) {
        if w[0].0 == w[1].0 {
            c.fail(
                format!("cloth.pinned[{}]", w[1].2),
                format!(
                    "particle [{}, {}] is also pinned by cloth.pinned[{}] with another motion",
                    w[1].0 % nu,
                    w[1].0 / nu,
                    w[0].2
                ),
            );
            ok = false;
        }
    }
    let pinned = pins.iter().map(|p| p.0).collect();
    let pin_group = pins.iter().map(|p| p.1).collect();
    let self_thickness = thickness(cl, c);
    let (origin, u, v) = (origin?, u?, v?);
    ok.then_some(ClothScene {
        nu,
        nv,
        size: cl.size,
        origin,
        u,
        v,
        pinned,
        pin_group,
        pin_motions,
        self_thickness: self_thickness?,
    })
}

/// `cloth.thickness` against the grid's finer spacing (selfcollision's
/// default and bound); `Some(None)` when self-collision is off.
fn thickness(cl: &crate::spec::types::ClothSpec, c: &mut Check) -> Option<Option<f64>> {
    use crate::selfcollision::{MAX_THICKNESS_SHARE, THICKNESS_SHARE};
    let spacing = (0..2)
        .map(|k| cl.size[k] / (f64::from(cl.grid[k].max(2)) - 1.0))
        .fold(f64::INFINITY, f64::min);
    let Some(t) = cl.thickness else {
        return Some(cl.self_collision.then_some(THICKNESS_SHARE * spacing));
    };
    let most = MAX_THICKNESS_SHARE * spacing;
    if !c.range("cloth.thickness", t, true, f64::INFINITY) {
        return None;
    }
    // Unused with self-collision off: a spec that turns it off for one
    // run keeps its thickness for the next.
    if !cl.self_collision {
        return Some(None);
    }
    if spacing.is_finite() && t > most {
        c.fail(
            "cloth.thickness",
            format!(
                "{t} m exceeds a quarter of the grid spacing ({most:.6} m): neighbouring particles would push each other apart"
            ),
        );
        return None;
    }
    Some(Some(t))
}
