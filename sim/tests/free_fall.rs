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

/// A ribbon whose spacing across is a fraction of its spacing along falls
/// freely too, with the default preconditioner: its bending across the
/// fine spacing is stiff against the particles' masses, and the line
/// smoother, had it put the couplings two lines across back on the
/// diagonal as it does on a square grid, would resist the fall itself
/// (cotton without air drag, whose pull would slow the fall) —
/// at 16:1 the first step took over a thousand CG iterations and the
/// ribbon hardly moved (docs/benchmarks.md 1z). The centre of mass obeys
/// backward Euler's law to the solver's tolerance, every solve converges
/// within a few iterations, and the ribbon keeps its shape.
#[test]
fn a_narrow_ribbon_falls_freely() {
    for aspect in [1.0, 4.0, 8.0, 16.0, 48.0] {
        let scene = common::scene_from_json(&format!(
            r#"{{"cloth": {{"grid": [20, 20], "size": [1.0, {w}], "origin": [-0.5, 0.0, 1.0]}},
                "material": {{"density": 0.15, "stretch": 20000.0, "shear": 50.0, "bend": 1e-05,
                              "damping": 0.002, "air_drag": 0.0}},
                "gravity": [0, 0, -9.81], "duration": 0.1, "fps": 30,
                "solver": {{"dt": 0.004166666666666667}}}}"#,
            w = 1.0 / aspect
        ));
        let h = scene.frame_dt() / 8.0;
        let mut sim = Simulation::new(&scene).expect("builds");
        let m = sim.grid().mass.clone();
        let x0 = common::center_of_mass(&sim.state().x, &m);
        while !sim.is_done() {
            let stats = sim.advance_frame(&Control::default()).expect("steps");
            assert_eq!(stats.unconverged_solves, 0, "aspect {aspect}");
            // A step needs a handful at most: the fall is the last step's
            // change of velocity again, the warm start, except on the
            // first, which starts from zero.
            assert!(
                stats.cg_iterations <= 4 * stats.steps,
                "aspect {aspect}: {} CG iterations in {} steps",
                stats.cg_iterations,
                stats.steps
            );
            let n = (stats.time / h).round();
            let expected = x0 + scene.gravity * fall(IntegratorKind::Euler, n, h);
            let com = common::center_of_mass(&sim.state().x, &m);
            // The error rule leaves at most a few per cent of a step's
            // motion to the solver (`error_floor`); the fall after `n`
            // steps is `n (n + 1) / 2` steps' worth, so a micrometre is
            // far inside what a missed fall would show (the failing
            // preconditioner left the ribbon 2 cm high at 0.1 s).
            assert!(
                (com - expected).norm() < 1e-6,
                "aspect {aspect} t={}: {com:?} vs {expected:?}",
                stats.time
            );
            assert!(
                (stats.max_stretch - 1.0).abs() < 1e-6,
                "aspect {aspect}: stretch {}",
                stats.max_stretch
            );
        }
    }
}
