//! Whole-step benchmark: one implicit step of `hanging-corners` at 30², 100²
//! and 200² particles (issue 2's baseline). The cloth first falls for 20
//! steps so the bench measures a deformed, moving cloth, not the flat start.
//! CG iterations per step are printed beside the times.

mod common;

use criterion::{Criterion, criterion_group, criterion_main};
use drapery_sim::spec::PreconditionerKind;

fn step(c: &mut Criterion) {
    let mut group = c.benchmark_group("hanging_corners_step");
    group.sample_size(10);
    for n in [30u32, 100, 200] {
        for p in [PreconditionerKind::Lines, PreconditionerKind::BlockJacobi] {
            let h = 1.0 / 120.0;
            let mut sim = common::example_sim(
                "hanging-corners",
                n,
                |spec| {
                    spec.cloth.pinned = vec![[0, 0].into(), [n - 1, 0].into()];
                    spec.solver.preconditioner = p;
                },
                h,
                20,
            );
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
