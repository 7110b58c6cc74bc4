//! Free fall (`examples/scenes/free-fall.json`): with no pins, no drag and no
//! damping, internal forces vanish for a rigidly translating cloth, so
//! backward Euler's discrete law `x_n = x0 + v0 t + g t (t + h) / 2` must
//! hold for the centre of mass to round-off, and no edge may change length.

mod common;

use drapery_sim::sim::{Control, Simulation};
use drapery_sim::spec::TimeStepping;

#[test]
fn free_fall_matches_backward_euler_law_and_cloth_does_not_deform() {
    let scene = common::example_scene("free-fall.json");
    let TimeStepping::Fixed { substeps } = scene.solver.stepping else {
        panic!("free-fall uses a fixed step");
    };
    let h = scene.frame_dt() / substeps as f64;
    let mut sim = Simulation::new(&scene).expect("builds");
    let m = sim.grid().mass.clone();
    let x0 = common::center_of_mass(&sim.state().x, &m);
    let g = scene.gravity;
    while !sim.is_done() {
        let stats = sim.advance_frame(&Control::default()).expect("steps");
        let t = stats.time;
        let expected = x0 + g * (t * (t + h) / 2.0);
        let com = common::center_of_mass(&sim.state().x, &m);
        // Round-off: ~1e-16 relative per operation over a few hundred steps
        // on coordinates of order 2 m; 1e-9 m is six orders above that and
        // far below any discretisation effect (h g t ~ 1e-2 m).
        assert!(
            (com - expected).norm() < 1e-9,
            "t={t}: {com:?} vs {expected:?}"
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
