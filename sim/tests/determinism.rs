//! Results do not depend on the thread count, and a checkpoint resumes
//! exactly in a process with another thread count: every parallel loop of
//! the core cuts its work into fixed chunks and sums partials in order.
//!
//! The cloth is 80 x 80 so every parallel path runs (assembly bands,
//! chunked products and sums from 4,096 particles, the packs of a line
//! colour from 512 pack nodes, Galerkin rows); it lands on a sphere and on
//! a box, whose edges and corners the sharp-feature stage couples to the
//! cloth.

mod common;

use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, RunState, Simulation};
use drapery_sim::spec::Scene;

fn drape(preconditioner: &str) -> Scene {
    common::scene_from_json(&format!(
        r#"{{"cloth": {{"grid": [80, 80], "size": [1, 1], "origin": [-0.5, -0.5, 0.3]}},
            "material": "cotton",
            "obstacles": [{{"sphere": {{"center": [0, 0, 0], "radius": 0.25}}, "friction": 0.4}},
                          {{"box": {{"center": [0.35, 0, 0.1], "size": [0.2, 0.6, 0.2]}}}}],
            "duration": 0.2, "fps": 60,
            "solver": {{"dt": 0.004166667, "preconditioner": "{preconditioner}"}}}}"#
    ))
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    drapery_sim::parallel::with_threads(threads, f)
}

/// Every frame's positions, from frame `from` of a run resumed from
/// `start` (or from the beginning).
fn frames(scene: &Scene, start: Option<RunState>) -> Vec<Vec<Vec3>> {
    let mut sim = Simulation::new(scene).expect("builds");
    if let Some(s) = start {
        sim.resume(s).expect("fits");
    }
    let mut out = Vec::new();
    while !sim.is_done() {
        sim.advance_frame(&Control::default()).expect("steps");
        out.push(sim.state().x.clone());
    }
    out
}

#[test]
fn frames_are_bit_for_bit_the_same_on_one_two_and_three_threads() {
    for pc in ["lines", "multigrid"] {
        let scene = drape(pc);
        let one = in_pool(1, || frames(&scene, None));
        assert!(
            one.last().expect("frames").iter().any(|p| p.z < 0.25),
            "{pc}: the cloth reached the sphere, so contacts were in play"
        );
        assert!(
            one.last()
                .expect("frames")
                .iter()
                .any(|p| p.x > 0.25 && p.x < 0.45 && p.z < 0.21),
            "{pc}: the cloth reached the box, so its features were in play"
        );
        for threads in [2, 3] {
            let other = in_pool(threads, || frames(&scene, None));
            assert!(other == one, "{pc}: {threads} threads differ from one");
        }
    }
}

#[test]
fn a_checkpoint_taken_on_one_thread_resumes_exactly_on_two() {
    let scene = drape("multigrid");
    let whole = in_pool(2, || frames(&scene, None));
    let checkpoint = in_pool(1, || {
        let mut sim = Simulation::new(&scene).expect("builds");
        for _ in 0..5 {
            sim.advance_frame(&Control::default()).expect("steps");
        }
        serde_json::to_string(&sim.checkpoint()).expect("serialises")
    });
    let resumed = in_pool(2, || {
        frames(
            &scene,
            Some(serde_json::from_str(&checkpoint).expect("deserialises")),
        )
    });
    assert!(
        resumed == whole[5..],
        "the resumed run parts from the whole one"
    );
}
