//! The runs of a study: a spec set to a sweep's point, run and measured
//! into a [`Row`].

use super::analysis::position_error;
use super::row::{Row, Sweep};
use crate::commands::bench::runner::{self, median};
use drapery_sim::math::Vec3;
use drapery_sim::spec::{IntegratorKind, Scene, Spec, StoppingRule, TimeStep, TimeStepping};

/// `base` with `integrator`, a fixed step `dt` and CG tolerance
/// `tolerance`, the residual rule alone stopping CG (so a sweep measures
/// what it varies).
pub fn with(base: &Spec, integrator: IntegratorKind, dt: f64, tolerance: f64) -> Spec {
    let mut s = base.clone();
    s.solver.dt = TimeStep::Fixed(dt);
    s.solver.error = None;
    s.solver.integrator = integrator;
    s.solver.tolerance = tolerance;
    s.solver.stopping = StoppingRule::Residual;
    s
}

/// `base` with `integrator`, adaptive steps at `error` metres per frame
/// and CG tolerance `tolerance`.
pub fn adaptive(base: &Spec, integrator: IntegratorKind, error: f64, tolerance: f64) -> Spec {
    let mut s = with(base, integrator, 0.0, tolerance);
    s.solver.dt = TimeStep::Adaptive;
    s.solver.error = Some(error);
    s
}

/// The step a validated scene takes (its frame in whole steps).
pub fn step_of(scene: &Scene) -> f64 {
    match scene.solver.stepping {
        TimeStepping::Fixed { substeps } => scene.frame_dt() / substeps as f64,
        TimeStepping::Adaptive { .. } => f64::NAN,
    }
}

/// Runs `scene` `repeat` times: the median wall time, the first run's
/// frames and its error against `reference`.
pub fn measure(
    sweep: Sweep,
    scene: &Scene,
    repeat: usize,
    reference: &[Vec<Vec3>],
    diagonal: f64,
) -> anyhow::Result<(Row, Vec<Vec<Vec3>>)> {
    let first = runner::simulate(scene, true)?;
    let mut walls = vec![first.stats.wall_seconds];
    for _ in 1..repeat {
        walls.push(runner::simulate(scene, false)?.stats.wall_seconds);
    }
    let errors = position_error(&first.frames, reference, diagonal);
    // A run that stopped early has no error to report.
    let completed = first.error.is_none();
    let s = &first.stats;
    let (dt, error_target) = match scene.solver.stepping {
        TimeStepping::Fixed { .. } => (step_of(scene), None),
        TimeStepping::Adaptive { error, .. } => {
            (s.sim_seconds / s.steps.max(1) as f64, Some(error))
        }
    };
    let row = Row {
        sweep,
        integrator: scene.solver.integrator,
        stopping: scene.solver.stopping,
        dt,
        error_target,
        error_estimate: s.local_error_max,
        tolerance: scene.solver.tolerance,
        steps: s.steps,
        wall_seconds: median(&mut walls),
        cg_iterations: s.cg_iterations_total,
        unconverged_solves: s.unconverged_solves,
        finite: s.finite && completed,
        error_rms: if completed { errors.rms } else { f64::NAN },
        error_max: if completed { errors.max } else { f64::NAN },
        solver_error_rms: None,
        pareto: false,
        per_frame: errors.per_frame,
    };
    if let Some(e) = &first.error {
        eprintln!(
            "  {} dt {:.3e} tol {:e}: failed: {e}",
            sweep.name(),
            row.dt,
            row.tolerance
        );
    }
    Ok((row, first.frames))
}
