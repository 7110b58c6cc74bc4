//! Collision benchmarks (issue 3): the hierarchy's query throughput and
//! the segment–triangle test's, on a unit sphere mesh of ~175k triangles, and
//! whole steps of the sphere drape at 30² and 100² with the cloth resting
//! on the sphere (after 0.25 s of falling), with the collision share.

mod common;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use drapery_sim::collision::{Aabb, MeshSurface, Surface, segment_hit};
use drapery_sim::math::{Real, Vec3};
use drapery_sim::mesh::tessellate_sphere;

/// Deterministic pseudo-random segments: short particle paths near the
/// surface of a unit sphere, as a draped cloth makes.
fn segments(n: usize) -> Vec<(Vec3, Vec3)> {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as Real / (1u64 << 53) as Real
    };
    (0..n)
        .map(|_| {
            let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let a = d * (1.0 + 0.02 * next());
            let b = a + Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 0.02;
            (a, b)
        })
        .collect()
}

fn hierarchy(c: &mut Criterion) {
    let mesh = tessellate_sphere(Vec3::zeros(), 1.0, 0.015).expect("tessellates");
    let triangles = mesh.triangles().len();
    let surface = MeshSurface::new(mesh.clone(), Some(0.005), 0.03);
    let segs = segments(10_000);
    let mut group = c.benchmark_group("collision");
    group.throughput(Throughput::Elements(segs.len() as u64));
    eprintln!("sphere mesh: {triangles} triangles");
    group.bench_function("bvh_first_hit_10k_segments", |b| {
        b.iter(|| {
            let mut nodes = 0;
            segs.iter()
                .filter(|(a, e)| surface.first_hit(a, e, &mut nodes).is_some())
                .count()
        })
    });
    group.bench_function("bvh_query_10k_boxes", |b| {
        b.iter(|| {
            let mut found = 0usize;
            for (a, e) in &segs {
                surface.bvh().query(&Aabb::of_segment(a, e), |_| found += 1);
            }
            found
        })
    });
    let tris: Vec<[Vec3; 3]> = (0..segs.len())
        .map(|k| mesh.corners(k % triangles))
        .collect();
    group.bench_function("segment_triangle_10k", |b| {
        b.iter(|| {
            segs.iter()
                .zip(&tris)
                .filter(|((a, e), t)| {
                    let n = (t[1] - t[0]).cross(&(t[2] - t[0])).normalize();
                    segment_hit(a, e, t, &n, 0.0).is_some()
                })
                .count()
        })
    });
    group.finish();
}

fn drape_steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("sphere_drape_step");
    group.sample_size(10);
    for n in [30u32, 100] {
        let h = 1.0 / 240.0;
        let mut sim = common::example_sim("sphere-drape-30", n, |_| {}, h, 60);
        let r = sim.step_once(h).expect("steps");
        eprintln!(
            "{n}x{n}: {} CG iterations, {} contacts, collision {:.1} % of the step",
            r.solve.iterations,
            sim.contacts().len(),
            100.0 * r.times.collision() / r.times.total()
        );
        group.bench_function(format!("{n}x{n}"), |b| {
            b.iter(|| sim.step_once(h).expect("steps"))
        });
    }
    group.finish();
}

criterion_group!(benches, hierarchy, drape_steps);
criterion_main!(benches);
