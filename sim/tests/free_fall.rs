//! Free fall (`examples/scenes/free-fall.json`): with no pins, no drag and no
//! damping, internal forces vanish for a rigidly translating cloth, so the
//! integrator's exact discrete law must hold for the centre of mass to
//! round-off, and no edge may change length. From rest, after `n` steps
//! of `h`:
//!
//! - backward Euler: `x_n = x0 + g h² n (n + 1) / 2` (`g t (t + h) / 2`);
//! - BDF2 (`"integrator": "bdf2"`), whose first step is backward Euler: `v_n = n h g` exactly (the velocity
//!   increments `d_n` obey `d_{n+1} = d_n / 3 + 2 h g / 3` from
//!   `d_1 = h g`, whose fixed point that is), and the position increments
//!   `e_n = x_n - x_{n-1}` obey `e_{n+1} = e_n / 3 + 2 h v_{n+1} / 3` from
//!   `e_1 = h v_1`, so `e_n = h v_n - h² g (1 - 3^(1-n)) / 2` and
//!   `x_n = x0 + g h² (n² / 2 + 3 (1 - 3^-n) / 4)`.

mod common;

use drapery_sim::sim::{Control, Simulation};
use drapery_sim::spec::{IntegratorKind, Scene, TimeStepping};

/// The centre of mass's fall after `n` steps of `h` from rest, in units
/// of `g` (module doc).
fn fall(kind: IntegratorKind, n: f64, h: f64) -> f64 {
    match kind {
        IntegratorKind::Euler => h * h * n * (n + 1.0) / 2.0,
        IntegratorKind::Bdf2 => h * h * (n * n / 2.0 + 0.75 * (1.0 - 3f64.powf(-n))),
    }
}

#[test]
fn free_fall_matches_the_discrete_law_and_cloth_does_not_deform() {
    let scene = common::example_scene("free-fall.json");
    assert_eq!(
        scene.solver.integrator,
        IntegratorKind::Euler,
        "the default"
    );
    check(&scene);
    let mut bdf2 = scene.clone();
    bdf2.solver.integrator = IntegratorKind::Bdf2;
    check(&bdf2);
}

fn check(scene: &Scene) {
    let TimeStepping::Fixed { substeps } = scene.solver.stepping else {
        panic!("free-fall uses a fixed step");
    };
    let h = scene.frame_dt() / substeps as f64;
    let mut sim = Simulation::new(scene).expect("builds");
    let m = sim.grid().mass.clone();
    let x0 = common::center_of_mass(&sim.state().x, &m);
    let g = scene.gravity;
    while !sim.is_done() {
        let stats = sim.advance_frame(&Control::default()).expect("steps");
        let n = (stats.time / h).round();
        let expected = x0 + g * fall(scene.solver.integrator, n, h);
        let com = common::center_of_mass(&sim.state().x, &m);
        // Round-off: ~1e-16 relative per operation over a few hundred steps
        // on coordinates of order 2 m; 1e-9 m is six orders above that and
        // far below any discretisation effect (h g t ~ 1e-2 m).
        assert!(
            (com - expected).norm() < 1e-9,
            "{:?} t={}: {com:?} vs {expected:?}",
            scene.solver.integrator,
            stats.time
        );
        assert!(
            (stats.max_stretch - 1.0).abs() < 1e-9,
            "cloth deformed: {}",
            stats.max_stretch
        );
        let v = sim.state().v[0];
        // Each particle carries the solver's error (tolerance 1e-8 relative
        // per step), the centre of mass does not: momentum is exact.
        let v_exact = g * (sim.steps() as f64 * h);
        assert!(
            (v - v_exact).norm() <= 1e-7 * v_exact.norm(),
            "{v:?} vs {v_exact:?}"
        );
    }
}
