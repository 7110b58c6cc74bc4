//! What a study records of one run.

use drapery_sim::spec::{IntegratorKind, StoppingRule};
use serde::Serialize;

/// What a sweep varies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Sweep {
    /// The step, halved from `--dt-max`, at the tight tolerance: the time
    /// discretisation's error (plus what contact events add).
    #[serde(rename = "dt")]
    TimeStep,
    /// The CG tolerance at a fixed step (the residual rule alone, then the
    /// scene's tolerance under the error rule): against the tight run at
    /// that step, the solver's error alone.
    #[serde(rename = "tolerance")]
    Tolerance,
    /// `dt: "adaptive"` at a requested error per frame, at the tight
    /// tolerance: the controller's cost and its calibration.
    #[serde(rename = "adaptive")]
    Adaptive,
}

impl Sweep {
    /// The name in the CSV files and the log.
    pub fn name(self) -> &'static str {
        match self {
            Sweep::TimeStep => "dt",
            Sweep::Tolerance => "tolerance",
            Sweep::Adaptive => "adaptive",
        }
    }
}

/// One measured run of a sweep.
#[derive(Debug, Clone)]
pub struct Row {
    pub sweep: Sweep,
    pub integrator: IntegratorKind,
    /// What stopped CG.
    pub stopping: StoppingRule,
    /// The step actually taken (the frame divided into whole steps); for
    /// an adaptive run, the mean step.
    pub dt: f64,
    /// The adaptive run's `solver.error`, metres per frame.
    pub error_target: Option<f64>,
    /// The largest per-frame error the run's own estimate reported
    /// (`local_error`), metres.
    pub error_estimate: f64,
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
