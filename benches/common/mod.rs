//! Shared bench setup: an example scene at another grid size, stepped a
//! while so the bench measures a deformed, moving cloth.

use drapery_sim::sim::Simulation;
use drapery_sim::spec::{Limits, Spec};

/// `examples/scenes/{name}.json` on an `n x n` grid, edited by `edit`,
/// after `warmup` steps of `h`.
pub fn example_sim(
    name: &str,
    n: u32,
    edit: impl FnOnce(&mut Spec),
    h: f64,
    warmup: usize,
) -> Simulation {
    let path = format!("{}/examples/scenes/{name}.json", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(path).expect("example scene");
    let mut spec: Spec = serde_json::from_str(&text).expect("parses");
    spec.cloth.grid = [n, n];
    edit(&mut spec);
    let scene = spec.validate(&Limits::default()).expect("valid");
    let mut sim = Simulation::new(&scene).expect("builds");
    for _ in 0..warmup {
        sim.step_once(h).expect("steps");
    }
    sim
}
