//! Collision scenarios (method.md §3, §4): every example scene with
//! obstacles stays outside the true surfaces and within the stretch bound,
//! and the physical facts of contact hold — resting without a gap, sharp
//! edges tested against cloth edges and triangles, Coulomb friction on a slope against the
//! closed form, friction carrying cloth round a turning sphere, no
//! tunnelling through a fast obstacle, and under BDF2 a strip swung onto
//! a sphere stays outside it.

mod common;

use common::{example_scene, run_frames, scene_from_json};
use drapery_sim::math::{Real, Vec3};
use drapery_sim::sim::{Control, FrameStats, Simulation};
use drapery_sim::spec::Scene;

/// The issue's bound on penetration of a true surface.
const MAX_PENETRATION: Real = 1e-3;
/// The issue's bound on stretch.
const MAX_STRETCH: Real = 1.05;

/// Runs `scene`, checking every frame for finiteness, penetration of the
/// true surfaces (at the frame and within its steps, through the frame's
/// `min_signed_distance`) and, until `stretch_until`, stretch.
fn run_checked(scene: &Scene, stretch_until: Real) -> (Simulation, Vec<Vec<Vec3>>) {
    let (sim, frames, _) = run_checked_with_stats(scene, stretch_until);
    (sim, frames)
}

/// [`run_checked`], also returning every frame's statistics.
fn run_checked_with_stats(
    scene: &Scene,
    stretch_until: Real,
) -> (Simulation, Vec<Vec<Vec3>>, Vec<FrameStats>) {
    let mut sim = Simulation::new(scene).expect("simulation builds");
    let mut frames = vec![sim.state().x.clone()];
    let mut stats: Vec<FrameStats> = vec![sim.snapshot_stats()];
    while !sim.is_done() {
        let s = sim.advance_frame(&Control::default()).expect("no NaN");
        frames.push(sim.state().x.clone());
        stats.push(s);
    }
    for s in &stats {
        let d = s.min_signed_distance.expect("scene has obstacles");
        assert!(
            d > -MAX_PENETRATION,
            "{}: frame {} is {:.2} mm inside an obstacle",
            scene.name,
            s.frame,
            -d * 1e3
        );
        if s.time <= stretch_until {
            assert!(
                s.max_stretch < MAX_STRETCH,
                "{}: frame {} stretched {:.2} %",
                scene.name,
                s.frame,
                (s.max_stretch - 1.0) * 100.0
            );
        }
    }
    (sim, frames, stats)
}

/// No obstacle edge passes through a cloth triangle at any frame.
fn assert_no_obstacle_crossings(stats: &[FrameStats]) {
    for s in stats {
        assert_eq!(
            s.obstacle_crossings, 0,
            "frame {}: obstacle edges through the cloth",
            s.frame
        );
    }
}

/// The heights above `level` of the particles `over` selects, ascending.
fn heights_above(x: &[Vec3], level: Real, over: impl Fn(&Vec3) -> bool) -> Vec<Real> {
    let mut h: Vec<Real> = x.iter().filter(|p| over(p)).map(|p| p.z - level).collect();
    h.sort_by(Real::total_cmp);
    h
}

fn sphere_distance(p: &Vec3, center: Vec3, radius: Real) -> Real {
    (p - center).norm() - radius
}

#[test]
fn sphere_drape_30_rests_on_the_sphere_and_drapes_below_the_equator() {
    let scene = example_scene("sphere-drape-30.json");
    let (_, frames, stats) = run_checked_with_stats(&scene, Real::INFINITY);
    // Little contact chatter in its second second, while it settles: 153
    // contacts made or released (432 before the contact state had
    // hysteresis). Chatter at rest is
    // `a_drape_on_a_sphere_comes_to_rest_and_stays`'s.
    let last_second = &stats[stats.len() - 60..];
    let changes: usize = last_second
        .iter()
        .map(|s| s.new_contacts + s.released_contacts)
        .sum();
    assert!(
        changes <= 3 * 60,
        "{changes} contacts made or released in the last second"
    );
    let last = frames.last().expect("frames");
    // The particle nearest the pole's vertical: within 1 cm of the sphere,
    // so no floating gap; the offset is a few mm.
    let top = last
        .iter()
        .min_by(|a, b| a.xy().norm().total_cmp(&b.xy().norm()))
        .expect("particles");
    let gap = sphere_distance(top, Vec3::zeros(), 0.25);
    assert!(gap > 0.0 && gap < 0.01, "gap above the pole {gap}");
    // Below the equator (z = 0) by a good margin.
    assert!(common::lowest_z(last) < -0.2);
}

/// Static friction holds a drape: sphere-drape-30 run on to 5 s comes to
/// rest on the sphere and stays there. Every particle on the cap carries
/// a steady tangential load well inside its friction cone (μ = 0.4; the
/// drape's imbalance is a few percent of its weight), so nothing may
/// creep: the particle at the middle of the cloth moves less than 1 mm
/// from 2 s to 5 s, in the last second no frame makes or releases more
/// than 2 contacts (the speed issue's settled drape), and the kinetic
/// energy, averaged over the last second, falls below 2 % of its value
/// at 1 s (0.9–1.1 %). Averaged: a single frame's is set by the free
/// edge's flicks, up to 5 % of it for a frame (13–17 µJ, seen at 4.2 s
/// on one trajectory and at 5 s on another that differs from it only in
/// round-off, docs/benchmarks.md 1ah). While sliding
/// contacts kept the load that had broken them loose in the landing, they
/// never stuck again, and the drape crept off the sphere: 16 mm in those
/// 3 s, 65 mm by 8 s, faster and faster (docs/benchmarks.md 1m).
#[test]
fn a_drape_on_a_sphere_comes_to_rest_and_stays() {
    let mut spec = common::example_spec("sphere-drape-30.json");
    spec.duration = 5.0;
    let scene = spec.validate(&Default::default()).expect("valid");
    let (_, frames, stats) = run_checked_with_stats(&scene, Real::INFINITY);
    let middle = 15 + 15 * 30;
    let at = |t: Real| &frames[(t * 60.0).round() as usize][middle];
    let crept = (at(5.0) - at(2.0)).norm();
    assert!(crept < 1e-3, "the middle crept {:.2} mm", crept * 1e3);
    for s in &stats[stats.len() - 60..] {
        assert!(
            s.new_contacts <= 2 && s.released_contacts <= 2,
            "frame {}: {} contacts made, {} released",
            s.frame,
            s.new_contacts,
            s.released_contacts
        );
    }
    let at_one = stats[60].kinetic_energy;
    let last = &stats[stats.len() - 60..];
    let mean = last.iter().map(|f| f.kinetic_energy).sum::<Real>() / last.len() as Real;
    assert!(
        mean < 0.02 * at_one,
        "kinetic energy {mean:e} J over the last second against {at_one:e} J at 1 s"
    );
}

#[test]
fn sphere_drape_100_stays_outside() {
    run_checked(&example_scene("sphere-drape-100.json"), Real::INFINITY);
}

/// Issue 15, item 6: the table's edges and corners are tested against
/// the cloth's edges and triangles, so the offset shrinks to its margin
/// (it was 0.41 spacings, 11.1 mm) and the cloth rests on the table
/// without a visible gap, while no part of the cloth between particles
/// cuts into the table.
#[test]
fn table_drape_rests_on_the_table_and_nothing_cuts_into_it() {
    let scene = example_scene("table-drape.json");
    let (sim, frames, stats) = run_checked_with_stats(&scene, Real::INFINITY);
    let (nu, nv) = (sim.grid().nu, sim.grid().nv);
    let (center, half) = (Vec3::new(0.0, 0.0, 0.375), Vec3::new(0.5, 0.5, 0.375));
    let sdf = |p: &Vec3| {
        let q = (p - center).abs() - half;
        q.sup(&Vec3::zeros()).norm() + q.max().min(0.0)
    };
    // Every cloth edge, the quads' diagonals included, sampled at 16
    // points: none inside the true box, at any frame. (The sampling can
    // miss a cut shallower than an edge's sixteenth times its slope;
    // the exact count below does not.)
    let mut worst = Real::INFINITY;
    for x in &frames {
        for j in 0..nv {
            for i in 0..nu {
                let a = x[i + j * nu];
                let mut ends = Vec::new();
                if i + 1 < nu {
                    ends.push(x[i + 1 + j * nu]);
                }
                if j + 1 < nv {
                    ends.push(x[i + (j + 1) * nu]);
                }
                if i + 1 < nu && j + 1 < nv {
                    ends.push(x[i + 1 + (j + 1) * nu]);
                }
                for b in ends {
                    for k in 1..16 {
                        let t = k as Real / 16.0;
                        worst = worst.min(sdf(&(a * (1.0 - t) + b * t)));
                    }
                }
            }
        }
    }
    assert!(worst > 0.0, "a cloth edge is {:.3} mm inside", -worst * 1e3);
    assert_no_obstacle_crossings(&stats);
    // Resting on the top: the particles over the table's middle lie on it
    // at the offset (1.36 mm at 60²), under the issue's 3 mm, except
    // where the cloth wrinkles (at most 3.3 mm at the last frame).
    let last = frames.last().expect("frames");
    let top = heights_above(last, 0.75, |p| p.x.abs() < 0.45 && p.y.abs() < 0.45);
    assert!(top.len() > 1000);
    let (lo, median, p90) = (top[0], top[top.len() / 2], top[top.len() * 9 / 10]);
    assert!(
        lo > 0.0 && median <= 3e-3 && p90 <= 3e-3,
        "gap above the table: least {lo}, median {median}, 90th percentile {p90}"
    );
    // And the cloth hangs down the sides.
    assert!(common::lowest_z(last) < 0.6);
}

/// A round table: a cylinder's rims are traced as features too, so its
/// offset is the margin plus the side's curvature (3.3 mm at this
/// spacing; 16.9 mm when the rims set it) and nothing crosses a rim.
#[test]
fn cloth_over_a_round_table_rests_on_it_and_no_rim_cuts_it() {
    let scene = scene_from_json(
        r#"{"name": "round-table",
            "cloth": {"grid": [30, 30], "size": [1.2, 1.2], "origin": [-0.6, -0.6, 0.8]},
            "material": "cotton",
            "obstacles": [{"cylinder": {"center": [0, 0, 0.375], "axis": [0, 0, 1],
                                        "radius": 0.35, "height": 0.75}, "friction": 0.3}],
            "duration": 1.0, "fps": 30, "solver": {"dt": 0.004166666666666667}}"#,
    );
    let (sim, frames, stats) = run_checked_with_stats(&scene, Real::INFINITY);
    let offset = sim.obstacles()[0].surface.offset();
    assert!(offset < 4e-3, "offset {offset}");
    assert_no_obstacle_crossings(&stats);
    let last = frames.last().expect("frames");
    let top = heights_above(last, 0.75, |p| p.xy().norm() < 0.3);
    let median = top[top.len() / 2];
    assert!(
        top[0] > 0.0 && median <= 1.1 * offset,
        "gap {} … median {median}",
        top[0]
    );
    // Hanging down round the rim.
    assert!(common::lowest_z(last) < 0.6);
}

/// A tablecloth pulled off its table by one edge, accelerated to 8 m/s in
/// 0.1 s (the stress suite's fastest pull): particles leaving the table
/// over its edge are let go, not held to the edge's rounded offset for a
/// step. Held, a particle sliding over the edge at 2.4 m/s was pulled
/// back onto the surface along a normal tilted 75° from the vertical and
/// went 5 cm down into the table in that step; full steps stretched
/// springs 57–180 %, halved steps still 10–20 %, and the frames 8.4 % (up
/// to 21.7 % with other damping). Every frame now stays within the
/// issue's 5 % and outside the table, with hardly a step halved.
#[test]
fn a_tablecloth_pulled_off_at_8_m_s_leaves_the_edge_without_overstretching() {
    // The far edge, pulled at 80 m/s² for 0.1 s (keyframes every 0.02 s
    // on x = 40 t²), then at 8 m/s.
    let edge: Vec<String> = (0..30).map(|j| format!("[29, {j}]")).collect();
    let mut keys: Vec<String> = (0..=5)
        .map(|k| {
            let t = 0.02 * k as Real;
            format!(
                r#"{{"time": {t}, "translation": [{}, 0, 0]}}"#,
                40.0 * t * t
            )
        })
        .collect();
    keys.push(r#"{"time": 0.2375, "translation": [1.5, 0, 0]}"#.into());
    let scene = scene_from_json(&format!(
        r#"{{"cloth": {{"grid": [30, 30], "size": [1, 1], "origin": [-0.3, -0.5, 0.755],
                       "pinned": [{{"particles": [{}], "motion": {{"keyframes": [{}]}}}}]}},
            "material": "cotton",
            "obstacles": [{{"box": {{"center": [0, 0, 0.375], "size": [1, 1, 0.75]}}, "friction": 0.3}}],
            "duration": 0.2375, "fps": 60, "solver": {{"dt": 0.004166666666666667}}}}"#,
        edge.join(", "),
        keys.join(", ")
    ));
    let (_, frames, stats) = run_checked_with_stats(&scene, Real::INFINITY);
    let halved: usize = stats.iter().map(|s| s.subdivided_steps).sum();
    // Before, the guard halved steps 98 times, four levels deep at worst;
    // now one step at most takes one halving.
    assert!(halved <= 2, "{halved} steps halved by the stretch guard");
    // The cloth has left the table's top: its middle is past the edge.
    let middle = &frames.last().expect("frames")[15 + 15 * 30];
    assert!(middle.x > 0.5, "middle at {middle:?}");
}

#[test]
fn rotating_sphere_carries_the_cloth_round() {
    let scene = example_scene("rotating-sphere.json");
    let (_, frames) = run_checked(&scene, Real::INFINITY);
    // Mean angular velocity about z of particles on the sphere's cap over
    // the last 10 frames, against the sphere's π rad/s.
    let (a, b) = (&frames[frames.len() - 11], &frames[frames.len() - 1]);
    let mut sum = 0.0;
    let mut n = 0;
    for (p, q) in a.iter().zip(b) {
        if p.z > 0.1 && p.xy().norm() > 0.05 {
            let d = q.y.atan2(q.x) - p.y.atan2(p.x);
            sum +=
                (d + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
            n += 1;
        }
    }
    let omega = sum / n as Real / (10.0 / scene.fps);
    assert!(
        n > 100 && (omega - std::f64::consts::PI).abs() < 0.1 * std::f64::consts::PI,
        "ω = {omega} over {n}"
    );
}

#[test]
fn cantilever_rests_on_its_box() {
    run_checked(&example_scene("cantilever.json"), Real::INFINITY);
}

#[test]
fn pedestal_mesh_rests_on_its_mesh() {
    run_checked(&example_scene("pedestal-mesh.json"), Real::INFINITY);
}

/// The pedestal's OBJ as another tool may write it: every face wound the
/// other way (inward) and triangles of no area among them. The mesh is
/// repaired to the same triangles, so the drape is the same bit for bit.
#[test]
fn an_inward_mesh_with_slivers_drapes_as_the_outward_one() {
    let text = std::fs::read_to_string(common::example_path("pedestal-mesh.json")).expect("reads");
    let short = text
        .replace("\"grid\": [61, 61]", "\"grid\": [15, 15]")
        .replace("\"duration\": 3.0", "\"duration\": 0.4");
    let mut spec: serde_json::Value = serde_json::from_str(&short).expect("JSON");
    let obj = &mut spec["obstacles"][0]["mesh"]["obj"];
    let mut inward: String = obj
        .as_str()
        .expect("OBJ text")
        .lines()
        .map(|l| match l.split_whitespace().collect::<Vec<_>>()[..] {
            ["f", a, b, c] => format!("f {a} {c} {b}\n"),
            _ => format!("{l}\n"),
        })
        .collect();
    inward.push_str("f 1 1 2\nf 49 50 49\n");
    *obj = serde_json::Value::String(inward);
    let run =
        |json: &str| run_frames(&mut Simulation::new(&scene_from_json(json)).expect("builds"));
    let (outward, repaired) = (run(&short), run(&spec.to_string()));
    assert_eq!(outward.len(), 13);
    assert_eq!(outward, repaired);
}

/// The sphere rises 0.8 m under a cloth pinned at its four corners. Once
/// its top is 0.3 m above the pins, no configuration keeps the stretch
/// under 5 %: the free edges between pins are as long as the pins are
/// apart, so they stay straight at the pins' height, and the 0.5 m of
/// cloth from an edge's middle to the centre must reach the sphere's top
/// (distance ≥ √(0.5² + 0.3²) = 0.58 m, +17 %). The stretch bound is
/// checked while it is attainable (sphere top 0.15 m above the pins).
#[test]
fn rising_sphere_lifts_the_cloth_without_passing_through() {
    let scene = example_scene("rising-sphere.json");
    let (_, frames) = run_checked(&scene, 1.25);
    let last = frames.last().expect("frames");
    let top = last.iter().map(|p| p.z).fold(Real::NEG_INFINITY, Real::max);
    // The sphere's top is at 1.0 m at t = 2 s; the cloth rests on it.
    assert!((top - 1.0).abs() < 0.01, "cloth top {top}");
}

fn slope_scene(mu: Real, theta: Real) -> Scene {
    let n = Vec3::new(theta.sin(), 0.0, theta.cos());
    let down = Vec3::new(theta.cos(), 0.0, -theta.sin());
    let delta = 1e-3;
    let origin = n * delta;
    scene_from_json(&format!(
        r#"{{
        "cloth": {{"grid": [5, 5], "size": [0.05, 0.05],
                   "origin": [{}, {}, {}], "u": [{}, {}, {}], "v": [0, 1, 0]}},
        "material": {{"density": 0.2, "stretch": 1e5, "shear": 1e3, "bend": 1e-3,
                      "damping": 0.0, "air_drag": 0.0}},
        "obstacles": [{{"plane": {{"point": [0, 0, 0], "normal": [{}, {}, {}]}},
                        "friction": {mu}, "offset": {delta}}}],
        "duration": 0.5, "fps": 20,
        "solver": {{"dt": 0.002, "tolerance": 1e-8}}
    }}"#,
        origin.x, origin.y, origin.z, down.x, down.y, down.z, n.x, n.y, n.z
    ))
}

/// Distance slid down the slope by the centre of mass.
fn slide(mu: Real, theta: Real) -> (Real, Real) {
    let scene = slope_scene(mu, theta);
    let mut sim = Simulation::new(&scene).expect("builds");
    let m = sim.grid().mass.clone();
    let frames = run_frames(&mut sim);
    let down = Vec3::new(theta.cos(), 0.0, -theta.sin());
    let c0 = common::center_of_mass(&frames[0], &m);
    let c1 = common::center_of_mass(frames.last().expect("frames"), &m);
    (down.dot(&(c1 - c0)), scene.duration)
}

#[test]
fn friction_on_a_slope_sticks_or_slides_as_coulomb_says() {
    let theta = 20f64.to_radians();
    // μ = 0.5 > tan 20° = 0.364: static friction holds.
    let (s, _) = slide(0.5, theta);
    eprintln!("slope μ = 0.5: slid {s:.2e} m");
    assert!(s.abs() < 1e-3, "slid {s} m with μ > tan θ");
    // μ = 0.1 and 0.25: slides with a = g (sin θ − μ cos θ).
    for mu in [0.1, 0.25] {
        let (s, t) = slide(mu, theta);
        let a = 9.81 * (theta.sin() - mu * theta.cos());
        let expected = 0.5 * a * t * t;
        eprintln!("slope μ = {mu}: slid {s:.5} m, Coulomb {expected:.5} m");
        assert!(
            (s - expected).abs() < 0.15 * expected,
            "μ = {mu}: slid {s} m, expected {expected} m"
        );
    }
}

#[test]
fn a_fast_sphere_does_not_tunnel_through_a_pinned_cloth() {
    // 8 m/s, radius 5 cm, dt 1/240: 3.3 cm per step against a cloth spaced
    // 3 cm, pinned at its corners.
    let scene = scene_from_json(
        r#"{
        "cloth": {"grid": [21, 21], "size": [0.6, 0.6], "origin": [-0.3, -0.3, 0.0],
                  "pinned": [[0, 0], [20, 0], [0, 20], [20, 20]]},
        "material": "cotton",
        "obstacles": [{"sphere": {"center": [0, 0, -0.1], "radius": 0.05},
                       "motion": {"velocity": [0, 0, 8.0]}}],
        "duration": 0.05, "fps": 100,
        "solver": {"dt": 0.004166666666666667}
    }"#,
    );
    let mut sim = Simulation::new(&scene).expect("builds");
    let frames = run_frames(&mut sim);
    for (k, x) in frames.iter().enumerate() {
        let center = Vec3::new(0.0, 0.0, -0.1 + 8.0 * k as Real / scene.fps);
        for p in x {
            let d = sphere_distance(p, center, 0.05);
            assert!(d > -MAX_PENETRATION, "frame {k}: {:.2} mm inside", -d * 1e3);
            // Nothing above the sphere's disk is left below it.
            if p.xy().norm() < 0.03 {
                assert!(p.z > center.z, "frame {k}: tunnelled at {p:?}");
            }
        }
    }
}

/// A strip held at one corner swings down onto a sphere under BDF2, at
/// 1/120 s. A particle its own solve found crossing used to be let go on
/// the redo as leaving (its velocity pointed away), crossed again on
/// every redo, and the last crossing was kept: 2.13 mm inside the
/// sphere (1.55 mm with the Jacobi preconditioner). Every frame, and
/// every step within it, now stays within the bound.
#[test]
fn under_bdf2_a_strip_swung_onto_a_sphere_stays_outside_it() {
    for preconditioner in ["block_jacobi", "jacobi"] {
        let scene = scene_from_json(&format!(
            r#"{{
            "name": "strip-{preconditioner}",
            "cloth": {{"grid": [30, 5], "size": [1.0, 0.05], "origin": [-0.5, -0.025, 0.3],
                      "pinned": [[0, 0]]}},
            "material": "cotton",
            "obstacles": [{{"sphere": {{"center": [0, 0, 0], "radius": 0.15}}, "friction": 0.4}}],
            "duration": 0.5, "fps": 30,
            "solver": {{"dt": 0.008333333333333333, "preconditioner": "{preconditioner}",
                       "integrator": "bdf2"}}
        }}"#
        ));
        run_checked(&scene, Real::INFINITY);
    }
}
