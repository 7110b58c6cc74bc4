//! The runs of a study: which settings each sweep varies, and one measured
//! run as a [`Row`].

use drapery_sim::math::Vec3;
use drapery_sim::spec::{Scene, Spec, TimeStep, TimeStepping};
use serde::Serialize;

use super::analysis::position_error;
use crate::commands::bench::runner::{self, median};

/// What a sweep varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Sweep {
    /// The step, halved from `--dt-max`, at the tight tolerance: the time
    /// discretisation's error (plus what contact events add).
    #[serde(rename = "dt")]
    TimeStep,
    /// The CG tolerance at a fixed step: against the tight run at that
    /// step, the solver's error alone.
    #[serde(rename = "tolerance")]
    Tolerance,
}

impl Sweep {
    /// The name in the CSV files and the log.
    pub fn name(self) -> &'static str {
        match self {
            Sweep::TimeStep => "dt",
            Sweep::Tolerance => "tolerance",
        }
    }
}

/// One measured run of a sweep.
#[derive(Debug, Clone)]
pub struct Row {
    pub sweep: Sweep,
    /// The step actually taken (the frame divided into whole steps).
    pub dt: f64,
    pub tolerance: f64,
    pub steps: usize,
    /// Median over the repeats.
    pub wall_seconds: f64,
    pub cg_iterations: usize,
    pub unconverged_solves: usize,
    pub finite: bool,
    /// RMS and largest position error against the reference, over the
    /// cloth's diagonal; NaN for a run that stopped early.
    pub error_rms: f64,
    pub error_max: f64,
    /// Against the tight-tolerance run at the same step (tolerance sweep).
    pub solver_error_rms: Option<f64>,
    /// No other run is both faster and more accurate.
    pub pareto: bool,
    /// RMS error of each frame after the first, over the diagonal.
    pub per_frame: Vec<f64>,
}

/// `base` with a fixed step `dt` and CG tolerance `tolerance`.
pub fn with(base: &Spec, dt: f64, tolerance: f64) -> Spec {
    let mut s = base.clone();
    s.solver.dt = TimeStep::Fixed(dt);
    s.solver.tolerance = tolerance;
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
    let row = Row {
        sweep,
        dt: step_of(scene),
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
