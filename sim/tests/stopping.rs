//! The error stopping rule (`solver.stopping: "error"`, the default): CG
//! stops once its error in the step's positions is a tenth of the step's
//! own local time error. On a swinging cloth the solver's error it leaves
//! must then be a small part of the time-discretisation error at the
//! same step, for far fewer iterations than a tight residual.

mod common;

use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, Simulation};

fn swing(dt: f64, integrator: &str, stopping: &str) -> String {
    format!(
        r#"{{"cloth": {{"grid": [16, 16], "size": [0.6, 0.6], "origin": [-0.3, -0.3, 1.0],
                     "pinned": [[0, 0], [15, 0]]}},
            "material": "cotton", "duration": 0.5, "fps": 30,
            "solver": {{"dt": {dt}, "integrator": "{integrator}", "tolerance": 1e-10,
                        "stopping": "{stopping}"}}}}"#
    )
}

/// Every frame's positions, and the CG iterations spent.
fn run(json: &str) -> (Vec<Vec<Vec3>>, usize) {
    let mut sim = Simulation::new(&common::scene_from_json(json)).expect("builds");
    let (mut frames, mut iterations) = (Vec::new(), 0);
    while !sim.is_done() {
        iterations += sim
            .advance_frame(&Control::default())
            .expect("steps")
            .cg_iterations;
        frames.push(sim.state().x.clone());
    }
    (frames, iterations)
}

#[test]
fn the_error_rule_leaves_a_small_part_of_the_time_error_for_fewer_iterations() {
    let h = 1.0 / 120.0;
    for integrator in ["euler", "bdf2"] {
        let (tight, tight_its) = run(&swing(h, integrator, "residual"));
        let (half, _) = run(&swing(h / 2.0, integrator, "residual"));
        let (ruled, ruled_its) = run(&swing(h, integrator, "error"));
        // The step's time error, to within the factor 2^p / (2^p - 1)
        // Richardson puts on the difference of a step and its half.
        let time_error = common::rms(&tight, &half);
        let solver_error = common::rms(&ruled, &tight);
        eprintln!(
            "{integrator}: time error {time_error:.3e}, solver error {solver_error:.3e}, \
             CG iterations {ruled_its} against {tight_its}"
        );
        assert!(
            solver_error < 0.2 * time_error,
            "{integrator}: solver error {solver_error:e} against time error {time_error:e}"
        );
        assert!(
            (ruled_its as f64) < 0.6 * tight_its as f64,
            "{integrator}: {ruled_its} CG iterations against {tight_its}"
        );
    }
}
