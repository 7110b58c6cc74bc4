//! Helpers for the scenario tests.
#![allow(dead_code)]

use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, Simulation};
use drapery_sim::spec::{Limits, Scene, Spec};

pub fn scene_from_json(json: &str) -> Scene {
    let spec: Spec = serde_json::from_str(json).expect("spec parses");
    spec.validate(&Limits::default()).expect("spec validates")
}

/// The project's own copy of a canonical scene (`examples/scenes/`): the
/// tests need nothing from outside the repository.
pub fn example_path(name: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../examples/scenes")
        .join(name)
}

pub fn example_spec(name: &str) -> Spec {
    let path = example_path(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("example scene parses")
}

pub fn example_scene(name: &str) -> Scene {
    example_spec(name)
        .validate(&Limits::default())
        .expect("example scene validates")
}

/// Runs to the end, returning positions at every frame.
pub fn run_frames(sim: &mut Simulation) -> Vec<Vec<Vec3>> {
    let mut frames = vec![sim.state().x.clone()];
    while !sim.is_done() {
        sim.advance_frame(&Control::default())
            .expect("run succeeds");
        frames.push(sim.state().x.clone());
    }
    frames
}

pub fn center_of_mass(x: &[Vec3], m: &[f64]) -> Vec3 {
    let total: f64 = m.iter().sum();
    x.iter().zip(m).map(|(x, m)| x * *m).sum::<Vec3>() / total
}

pub fn lowest_z(x: &[Vec3]) -> f64 {
    x.iter().map(|p| p.z).fold(f64::INFINITY, f64::min)
}

/// RMS over particles and frames of the distance between two runs.
pub fn rms(a: &[Vec<Vec3>], b: &[Vec<Vec3>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0);
    for (fa, fb) in a.iter().zip(b) {
        for (p, q) in fa.iter().zip(fb) {
            sum += (p - q).norm_squared();
            n += 1;
        }
    }
    (sum / n as f64).sqrt()
}
