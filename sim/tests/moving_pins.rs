//! Pinned groups that follow a rigid motion (`cloth.pinned` entries
//! `{"particles": [...], "motion": {...}}`): the pinned particles land
//! exactly on their moving anchors every frame, and the cloth follows.

mod common;

use common::{run_frames, scene_from_json};
use drapery_sim::math::Vec3;
use drapery_sim::sim::Simulation;
use drapery_sim::spec::{Limits, Spec};

/// Two corners carried sideways at 0.5 m/s for 1 s: each frame the pins
/// sit at rest + 0.5 t x̂ to round-off, and the hanging cloth's centre of
/// mass has followed them by the end (within the swing it still has).
#[test]
fn translating_pins_carry_the_cloth() {
    let scene = scene_from_json(
        r#"{"cloth": {"grid": [12, 12], "size": [0.5, 0.5], "origin": [0, 0, 1],
                      "u": [1, 0, 0], "v": [0, 0, -1],
                      "pinned": [{"particles": [[0, 0], [11, 0]], "motion": {"velocity": [0.5, 0, 0]}}]},
            "material": "cotton", "duration": 1.0, "fps": 20}"#,
    );
    let mut sim = Simulation::new(&scene).expect("builds");
    let rest = sim.state().x.clone();
    let frames = run_frames(&mut sim);
    for (k, x) in frames.iter().enumerate() {
        let t = k as f64 / 20.0;
        for &i in &[0usize, 11] {
            let want = rest[i] + Vec3::new(0.5 * t, 0.0, 0.0);
            assert!(
                (x[i] - want).norm() < 1e-9,
                "frame {k}, pin {i}: {:?}",
                x[i] - want
            );
        }
    }
    let last = frames.last().expect("frames");
    let mean = |x: &[Vec3]| x.iter().map(|p| p.x).sum::<f64>() / x.len() as f64;
    let moved = mean(last) - mean(&rest);
    assert!((moved - 0.5).abs() < 0.05, "centre of mass moved {moved} m");
    assert!(last.iter().flatten().all(|c| c.is_finite()));
}

/// An edge held by keyframes that turn it 90° about z over 1 s: the pinned
/// particles follow the slerp exactly.
#[test]
fn keyframed_pins_follow_the_rotation() {
    let s = (0.5f64).sqrt();
    let scene = scene_from_json(&format!(
        r#"{{"cloth": {{"grid": [8, 8], "size": [0.4, 0.4], "origin": [0, 0, 1],
                      "u": [1, 0, 0], "v": [0, 0, -1],
                      "pinned": [{{"particles": [[0, 0], [3, 0], [7, 0]],
                                   "motion": {{"keyframes": [
                                      {{"time": 0, "rotation": [0, 0, 0, 1]}},
                                      {{"time": 1, "rotation": [0, 0, {s}, {s}]}}]}}}}]}},
            "material": "cotton", "gravity": [0, 0, -9.81], "duration": 1.0, "fps": 10}}"#
    ));
    let mut sim = Simulation::new(&scene).expect("builds");
    let rest = sim.state().x.clone();
    let frames = run_frames(&mut sim);
    let last = frames.last().expect("frames");
    for i in [0usize, 3, 7] {
        // 90° about z: (x, y, z) -> (-y, x, z).
        let want = Vec3::new(-rest[i].y, rest[i].x, rest[i].z);
        assert!(
            (last[i] - want).norm() < 1e-9,
            "pin {i}: {:?}",
            last[i] - want
        );
    }
    assert!(last.iter().flatten().all(|c| c.is_finite()));
}

/// Bad groups are refused with the path of the offending field.
#[test]
fn bad_pin_groups_are_refused_with_paths() {
    let errors = |pinned: &str| {
        let spec: Spec = serde_json::from_str(&format!(
            r#"{{"cloth": {{"grid": [4, 4], "size": [1, 1], "pinned": {pinned}}},
                "material": "cotton", "duration": 1, "fps": 10}}"#
        ))
        .expect("parses");
        spec.validate(&Limits::default())
            .expect_err("refused")
            .0
            .into_iter()
            .map(|e| e.path)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        errors(r#"[{"particles": [[0, 9]], "motion": {"velocity": [1, 0, 0]}}]"#),
        ["cloth.pinned[0].particles[0][1]"]
    );
    assert_eq!(
        errors(r#"[[0, 0], {"particles": [[0, 0]], "motion": {"velocity": [1, 0, 0]}}]"#),
        ["cloth.pinned[1]"]
    );
    assert_eq!(
        errors(r#"[{"particles": [[1, 1]], "motion": {}}]"#),
        ["cloth.pinned[0].motion"]
    );
    assert_eq!(
        errors(r#"[{"particles": []}]"#),
        ["cloth.pinned[0].particles"]
    );
    let parse = serde_json::from_str::<Spec>(
        r#"{"cloth": {"grid": [4, 4], "size": [1, 1], "pinned": [{"particle": [0, 0]}]},
            "material": "cotton", "duration": 1, "fps": 10}"#,
    );
    let message = parse.expect_err("unknown field").to_string();
    assert!(message.contains("unknown field `particle`"), "{message}");
}
