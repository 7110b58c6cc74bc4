//! The stress cases, at any cloth resolution `n` (`n` x `n` particles).
//!
//! Each family pushes one thing past where cloth solvers usually break:
//! the step (1e-4 .. 1/30 s), the stiffness ratio (stretch/bend 1e3 ..
//! 1e8), the start (a crumpled cloth), speed (a 10 m/s impact, a table
//! cloth pulled at 0.5 .. 8 m/s), and geometry finer than the cloth (a
//! 2 mm blade, a bed of needles, a spinning sphere with friction), and
//! self-collision (a cloth folded onto itself in 0.3 s, a strip twisted
//! twice a second), where no frame may have a cloth edge through the
//! cloth.

use super::case::Case;
use drapery_sim::spec::{
    BoxShape, ClothSpec, Keyframe, MaterialParams, MaterialSpec, MeshSource, Motion, Obstacle,
    PinEntry, PinGroup, Plane, SolverSpec, Spec, Sphere, TimeStep,
};

/// Steps of the step sweeps, seconds.
pub const STEPS: [f64; 6] = [1e-4, 1e-3, 1.0 / 240.0, 1.0 / 120.0, 1.0 / 60.0, 1.0 / 30.0];
/// Stretch over bend stiffness (in SI units, 1/m²) of the ratio sweep.
pub const RATIOS: [f64; 6] = [1e3, 1e4, 1e5, 1e6, 1e7, 1e8];
/// Pull speeds of the table-cloth case, m/s.
pub const PULL_SPEEDS: [f64; 5] = [0.5, 1.0, 2.0, 4.0, 8.0];

/// Default stretch bound: 10 %, far outside a woven fabric's linear range
/// (the presets' 2..8 % elongation at 500 gf/cm), so only a failure of the
/// solver, not a hard but physical load, exceeds it.
const STRETCH_BOUND: f64 = 1.10;
/// The scene step of the cases that do not sweep it.
const DT: f64 = 1.0 / 240.0;

/// Every case at `n` x `n` particles, `n >= 4`.
pub fn cases(n: u32) -> Vec<Case> {
    let n = n.max(4);
    let mut out = Vec::new();
    for dt in STEPS {
        // The smallest step covers less time: 3000 steps already hold the
        // first swing (hanging) and the landing (drape), where stress peaks.
        let duration = if dt < 1e-3 { 0.3 } else { 1.0 };
        out.push(case(
            format!("hanging dt {dt:.2e}"),
            hanging(n, dt, duration),
        ));
        out.push(case(
            format!("sphere-drape dt {dt:.2e}"),
            sphere_drape(n, dt, duration),
        ));
    }
    for ratio in RATIOS {
        let mut s = sphere_drape(n, DT, 0.8);
        s.material = MaterialSpec::Params(with_bend(2.0e4 / ratio));
        out.push(case(format!("stiffness-ratio {ratio:.0e}"), s));
    }
    let mut crumpled = case("crumpled over sphere".into(), sphere_drape(n, DT, 1.0));
    crumpled.crumple_seed = Some(2026);
    out.push(crumpled);
    out.push(case("impact 10 m/s".into(), impact(n)));
    out.push(case("thin blade".into(), blade(n)));
    out.push(case("needle bed".into(), needle_bed(n)));
    out.push(case("rotating sphere".into(), rotating_sphere(n)));
    for v in PULL_SPEEDS {
        out.push(case(
            format!("tablecloth-pull {v} m/s"),
            tablecloth_pull(n, v),
        ));
    }
    out.push(case("fast fold".into(), fast_fold(n)));
    out.push(case("tight twist".into(), tight_twist(n)));
    out
}

fn case(name: String, spec: Spec) -> Case {
    Case {
        name,
        spec,
        crumple_seed: None,
        max_stretch: STRETCH_BOUND,
    }
}

/// A 1 m cotton square at `origin`, `n` x `n`.
fn cloth(n: u32, origin: [f64; 3], pinned: Vec<PinEntry>) -> ClothSpec {
    ClothSpec {
        grid: [n, n],
        size: [1.0, 1.0],
        origin,
        u: None,
        v: None,
        pinned,
        thickness: None,
        self_collision: true,
    }
}

fn scene(name: &str, cloth: ClothSpec, obstacles: Vec<Obstacle>, dt: f64, duration: f64) -> Spec {
    Spec {
        name: Some(name.into()),
        cloth,
        material: MaterialSpec::Preset("cotton".into()),
        obstacles,
        gravity: [0.0, 0.0, -9.81],
        duration,
        // A frame every 1/60 s (or every step, when steps are longer):
        // the checks read every frame.
        fps: (1.0 / dt).min(60.0),
        solver: SolverSpec {
            dt: TimeStep::Fixed(dt),
            ..SolverSpec::default()
        },
    }
}

fn with_bend(bend: f64) -> MaterialParams {
    let cotton = drapery_sim::spec::preset("cotton").expect("cotton is a preset");
    MaterialParams { bend, ..cotton }
}

fn sphere(center: [f64; 3], radius: f64, friction: f64) -> Obstacle {
    Obstacle {
        sphere: Some(Sphere { center, radius }),
        friction,
        ..Obstacle::default()
    }
}

fn floor(z: f64) -> Obstacle {
    Obstacle {
        plane: Some(Plane {
            point: [0.0, 0.0, z],
            normal: [0.0, 0.0, 1.0],
        }),
        friction: 0.5,
        ..Obstacle::default()
    }
}

/// `hanging-corners`: a horizontal cloth held by two corners, swinging down.
fn hanging(n: u32, dt: f64, duration: f64) -> Spec {
    let pins = vec![[0, 0].into(), [n - 1, 0].into()];
    scene(
        "hanging",
        cloth(n, [-0.5, -0.5, 1.5], pins),
        vec![],
        dt,
        duration,
    )
}

/// `sphere-drape-30`: 10 cm above a 0.25 m sphere, friction 0.4.
fn sphere_drape(n: u32, dt: f64, duration: f64) -> Spec {
    scene(
        "sphere-drape",
        cloth(n, [-0.5, -0.5, 0.35], vec![]),
        vec![sphere([0.0, 0.0, 0.0], 0.25, 0.4)],
        dt,
        duration,
    )
}

/// A 0.25 m sphere rising at 10 m/s into a falling cloth: it moves 4 cm a
/// step, more than a grid spacing at n = 30, so only continuous tests keep
/// the cloth outside.
fn impact(n: u32) -> Spec {
    let mut ball = sphere([0.0, 0.0, -0.5], 0.25, 0.4);
    ball.motion = Some(Motion {
        velocity: Some([0.0, 0.0, 10.0]),
        ..Motion::default()
    });
    scene(
        "impact",
        cloth(n, [-0.5, -0.5, 0.35], vec![]),
        vec![ball],
        DT,
        0.25,
    )
}

/// A blade 2 mm thick and 30 cm tall under the middle column of particles:
/// far thinner than the grid spacing, so a particle sitting on its edge
/// has a 2 mm face to stand on.
fn blade(n: u32) -> Spec {
    let column = -0.5 + f64::from(n / 2) / f64::from(n - 1);
    let blade = Obstacle {
        box_: Some(BoxShape {
            center: [column, 0.0, 0.15],
            size: [0.002, 1.2, 0.3],
        }),
        friction: 0.5,
        ..Obstacle::default()
    };
    scene(
        "blade",
        cloth(n, [-0.5, -0.5, 0.32], vec![]),
        vec![blade, floor(0.0)],
        DT,
        1.0,
    )
}

/// A 9 x 9 bed of square needles, 6 mm at the base and 20 cm tall, 10 cm
/// apart, on a floor: sharp tips poke between and into the particles.
fn needle_bed(n: u32) -> Spec {
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    let (half, height) = (0.003, 0.2);
    for a in 0..9 {
        for b in 0..9 {
            let (x, y) = (-0.4 + 0.1 * f64::from(a), -0.4 + 0.1 * f64::from(b));
            let base = vertices.len() as u32;
            vertices.extend([
                [x - half, y - half, 0.0],
                [x + half, y - half, 0.0],
                [x + half, y + half, 0.0],
                [x - half, y + half, 0.0],
                [x, y, height],
            ]);
            // Four sides outward (counter-clockwise seen from outside),
            // and the base facing down.
            for [p, q, r] in [
                [0, 1, 4],
                [1, 2, 4],
                [2, 3, 4],
                [3, 0, 4],
                [0, 2, 1],
                [0, 3, 2],
            ] {
                triangles.push([base + p, base + q, base + r]);
            }
        }
    }
    let needles = Obstacle {
        mesh: Some(MeshSource {
            obj: None,
            stl: None,
            vertices: Some(vertices),
            triangles: Some(triangles),
        }),
        friction: 0.5,
        ..Obstacle::default()
    };
    scene(
        "needle-bed",
        cloth(n, [-0.5, -0.5, 0.22], vec![]),
        vec![needles, floor(0.0)],
        DT,
        1.0,
    )
}

/// `rotating-sphere`, faster: one turn a second with friction 0.8, so the
/// cloth is dragged round and flung outwards; a floor catches it.
fn rotating_sphere(n: u32) -> Spec {
    let mut ball = sphere([0.0, 0.0, 0.0], 0.25, 0.8);
    ball.motion = Some(Motion {
        angular_velocity: Some([0.0, 0.0, std::f64::consts::TAU]),
        pivot: Some([0.0, 0.0, 0.0]),
        ..Motion::default()
    });
    scene(
        "rotating-sphere",
        cloth(n, [-0.5, -0.5, 0.35], vec![]),
        vec![ball, floor(-0.5)],
        DT,
        1.5,
    )
}

/// A cloth on a 1 m table, 20 cm over its edge, pulled off by that edge at
/// `speed`: the held edge speeds up uniformly over 0.1 s (a hand, not an
/// impulse), then moves at `speed` until the cloth has left the table.
fn tablecloth_pull(n: u32, speed: f64) -> Spec {
    let table = Obstacle {
        box_: Some(BoxShape {
            center: [0.0, 0.0, 0.375],
            size: [1.0, 1.0, 0.75],
        }),
        friction: 0.3,
        ..Obstacle::default()
    };
    let ramp = 0.1;
    let duration = (ramp + 1.1 / speed).max(0.4);
    let keyframe = |t: f64| {
        // Uniform acceleration to `speed` over the ramp, then steady.
        let x = if t <= ramp {
            0.5 * speed / ramp * t * t
        } else {
            0.5 * speed * ramp + speed * (t - ramp)
        };
        Keyframe {
            time: t,
            translation: [x, 0.0, 0.0],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    };
    let mut keys: Vec<Keyframe> = (0..=5)
        .map(|k| keyframe(ramp * f64::from(k) / 5.0))
        .collect();
    keys.push(keyframe(duration));
    let edge = PinEntry::Group(PinGroup {
        particles: (0..n).map(|j| [n - 1, j]).collect(),
        motion: Some(Motion {
            keyframes: Some(keys),
            ..Motion::default()
        }),
    });
    scene(
        "tablecloth-pull",
        cloth(n, [-0.3, -0.5, 0.755], vec![edge]),
        vec![table],
        DT,
        duration,
    )
}

/// A cloth lying on the floor whose far edge is lifted and laid over the
/// near one in 0.3 s (up to ~4 m/s): half the cloth lands on the other
/// half, with self-collision on.
fn fast_fold(n: u32) -> Spec {
    let key = |time: f64, translation: [f64; 3]| Keyframe {
        time,
        translation,
        rotation: [0.0, 0.0, 0.0, 1.0],
    };
    let edge = PinEntry::Group(PinGroup {
        particles: (0..n).map(|i| [i, n - 1]).collect(),
        motion: Some(Motion {
            keyframes: Some(vec![
                key(0.0, [0.0, 0.0, 0.0]),
                key(0.15, [0.0, -0.5, 0.35]),
                key(0.3, [0.0, -0.97, 0.03]),
            ]),
            ..Motion::default()
        }),
    });
    let c = cloth(n, [-0.5, -0.5, 0.02], vec![edge]);
    scene("fast-fold", c, vec![floor(0.0)], DT, 0.8)
}

/// A 1 m x 0.2 m silk strip, one short edge held, the other turned about
/// the long axis twice a second while it moves 0.3 m in: it twists, then
/// coils onto itself, with self-collision on.
fn tight_twist(n: u32) -> Spec {
    let m = (n / 5).max(4);
    let mut pins: Vec<PinEntry> = (0..m).map(|j| [0, j].into()).collect();
    pins.push(PinEntry::Group(PinGroup {
        particles: (0..m).map(|j| [n - 1, j]).collect(),
        motion: Some(Motion {
            velocity: Some([-0.3, 0.0, 0.0]),
            angular_velocity: Some([2.0 * std::f64::consts::TAU, 0.0, 0.0]),
            pivot: Some([0.5, 0.0, 0.5]),
            ..Motion::default()
        }),
    }));
    let strip = ClothSpec {
        grid: [n, m],
        size: [1.0, 0.2],
        origin: [-0.5, -0.1, 0.5],
        ..cloth(n, [0.0; 3], pins)
    };
    let mut s = scene("tight-twist", strip, vec![], DT, 1.0);
    s.material = MaterialSpec::Preset("silk".into());
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use drapery_sim::spec::Limits;

    #[test]
    fn every_case_is_a_valid_scene_at_small_and_full_size() {
        for n in [6, 30] {
            let all = cases(n);
            assert_eq!(all.len(), 12 + 6 + 1 + 4 + 5 + 2);
            for c in &all {
                if let Err(e) = c.spec.validate(&Limits::default()) {
                    panic!("{}: {e}", c.name);
                }
            }
        }
    }
}
