//! `duration`, `fps` and `solver`: how many frames, how they are stepped.

use super::check::{ADAPTIVE_MAX_LEVEL, Check};
use crate::spec::limits::Limits;
use crate::spec::scene::{SolverScene, TimeStepping};
use crate::spec::types::{Spec, TimeStep};

/// Returns the number of frames after frame 0.
pub(super) fn validate_timing(spec: &Spec, limits: &Limits, c: &mut Check) -> Option<usize> {
    let d = c.range("duration", spec.duration, true, limits.max_duration);
    let f = c.range("fps", spec.fps, true, 10_000.0);
    if !(d && f) {
        return None;
    }
    // NOTE: a small slack so 2.0 s at 60 fps gives 120 frames despite round-off.
    let frames = (spec.duration * spec.fps + 1e-9).floor() as usize;
    if frames == 0 {
        c.fail(
            "duration",
            "must cover at least one frame (duration * fps >= 1)",
        );
        return None;
    }
    // The output holds frame 0 too.
    if frames + 1 > limits.max_frames {
        c.fail(
            "fps",
            format!(
                "{} frames (frame 0 included) exceeds the limit of {}",
                frames + 1,
                limits.max_frames
            ),
        );
        return None;
    }
    Some(frames)
}

/// The adaptive controller's position error per frame when the spec
/// names none, metres.
pub const DEFAULT_ERROR: f64 = 1e-3;

pub(super) fn validate_solver(
    spec: &Spec,
    limits: &Limits,
    frames: Option<usize>,
    c: &mut Check,
) -> Option<SolverScene> {
    let s = &spec.solver;
    let mut ok = c.range("solver.tolerance", s.tolerance, true, 0.5);
    if s.max_iterations == 0 || s.max_iterations > 1_000_000 {
        c.fail("solver.max_iterations", "must be between 1 and 1000000");
        ok = false;
    }
    let stepping = match s.dt {
        TimeStep::Adaptive => {
            let error = s.error.unwrap_or(DEFAULT_ERROR);
            c.range("solver.error", error, true, 1.0)
                .then_some(TimeStepping::Adaptive {
                    max_level: ADAPTIVE_MAX_LEVEL,
                    error,
                })
        }
        TimeStep::Fixed(dt) => {
            if s.error.is_some() {
                c.fail("solver.error", "needs solver.dt \"adaptive\"");
                ok = false;
            }
            if !c.range("solver.dt", dt, true, 1.0) {
                None
            } else if dt < 1e-7 {
                c.fail("solver.dt", "must be >= 1e-7 s");
                None
            } else if spec.fps.is_finite() && spec.fps > 0.0 {
                let frame_dt = 1.0 / spec.fps;
                // The largest step that divides the frame and is not above dt.
                let substeps = ((frame_dt / dt) - 1e-6).ceil().max(1.0) as usize;
                let total = frames.map_or(0, |f| f.saturating_mul(substeps));
                if total > limits.max_steps {
                    c.fail(
                        "solver.dt",
                        format!("{total} steps exceeds the limit of {}", limits.max_steps),
                    );
                    None
                } else {
                    Some(TimeStepping::Fixed { substeps })
                }
            } else {
                None
            }
        }
    };
    let stepping = stepping?;
    ok.then_some(SolverScene {
        stepping,
        tolerance: s.tolerance,
        stopping: s.stopping,
        max_iterations: s.max_iterations as usize,
        preconditioner: s.preconditioner,
        integrator: s.integrator,
        warm_start: s.warm_start,
        collision: s.collision,
    })
}
