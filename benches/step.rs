//! Whole-step benchmark: one implicit step of `hanging-corners` at 30², 100²
//! and 200² particles (issue 2's baseline). The cloth first falls for 20
//! steps so the bench measures a deformed, moving cloth, not the flat start.
//! CG iterations per step are printed beside the times.

use criterion::{Criterion, criterion_group, criterion_main};
use drapery_sim::sim::Simulation;
use drapery_sim::spec::{Limits, PreconditionerKind, Spec};

fn scene(n: u32, preconditioner: PreconditionerKind) -> (Simulation, f64) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/hanging-corners.json"
    );
    let text = std::fs::read_to_string(path).expect("example scene");
    let mut spec: Spec = serde_json::from_str(&text).expect("parses");
    spec.cloth.grid = [n, n];
    spec.cloth.pinned = vec![[0, 0], [n - 1, 0]];
    spec.solver.preconditioner = preconditioner;
    let scene = spec.validate(&Limits::default()).expect("valid");
    let h = 1.0 / 120.0;
    let mut sim = Simulation::new(&scene).expect("builds");
    for _ in 0..20 {
        sim.step_once(h).expect("steps");
    }
    (sim, h)
}

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("hanging_corners_step");
    group.sample_size(10);
    for n in [30u32, 100, 200] {
        for p in [PreconditionerKind::Lines, PreconditionerKind::BlockJacobi] {
            let (mut sim, h) = scene(n, p);
            let iterations = sim.step_once(h).expect("steps").solve.iterations;
            eprintln!("{n}x{n} {p:?}: {iterations} CG iterations per step");
            group.bench_function(format!("{n}x{n}/{p:?}"), |b| {
                b.iter(|| sim.step_once(h).expect("steps"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
