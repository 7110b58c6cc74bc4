//! Running a case and checking it: finite, stretch within its bound, no
//! particle more than [`MAX_PENETRATION`] inside a true surface, no cloth
//! edge through the cloth at any frame (cases with self-collision on), no
//! obstacle edge through a cloth triangle at any frame, every solve
//! converged.

use drapery_sim::spec::{Limits, TimeStep};

use super::case::Case;
use crate::runner::{RunOptions, Start, simulate};

/// How far inside a true surface a particle may be, metres: the user's
/// bound ("no particle more than 1 mm inside an obstacle").
pub const MAX_PENETRATION: f64 = 1e-3;

/// What a case did, and whether it passed.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The case's name.
    pub case: String,
    /// The step the scene asked for, seconds.
    pub dt: f64,
    /// No NaN or infinity anywhere.
    pub finite: bool,
    /// Largest edge length over rest length at any frame.
    pub max_stretch: f64,
    /// Smallest signed distance of any particle to any obstacle's true
    /// surface at any frame, metres (negative: inside); `None` without
    /// obstacles.
    pub min_signed_distance: Option<f64>,
    /// Most cloth edges through cloth triangles at any frame; `None` with
    /// self-collision off.
    pub self_crossings: Option<usize>,
    /// Most obstacle edges (boxes', meshes' sharp edges) through cloth
    /// triangles at any frame.
    pub obstacle_crossings: usize,
    /// Most CG iterations of any one solve.
    pub cg_iterations_max: usize,
    /// Solves that stopped at the iteration cap.
    pub unconverged_solves: usize,
    /// Wall time of the run, seconds.
    pub wall_seconds: f64,
    /// Every check that failed, in words; empty when the case passed.
    pub failures: Vec<String>,
}

impl Outcome {
    /// Whether every check held.
    pub fn pass(&self) -> bool {
        self.failures.is_empty()
    }
}

/// Runs `case` to its end and checks it.
pub fn run(case: &Case) -> Outcome {
    let mut out = Outcome {
        case: case.name.clone(),
        dt: match case.spec.solver.dt {
            TimeStep::Fixed(dt) => dt,
            TimeStep::Adaptive => f64::NAN,
        },
        finite: false,
        max_stretch: f64::NAN,
        min_signed_distance: None,
        self_crossings: None,
        obstacle_crossings: 0,
        cg_iterations_max: 0,
        unconverged_solves: 0,
        wall_seconds: 0.0,
        failures: Vec::new(),
    };
    let scene = match case.spec.validate(&Limits::default()) {
        Ok(s) => s,
        Err(e) => {
            out.failures.push(format!("invalid scene: {e}"));
            return out;
        }
    };
    let options = RunOptions {
        start: case.crumple_seed.map_or(Start::Rest, Start::Crumpled),
        capture: false,
    };
    let (stats, result) = match simulate(&scene, options) {
        Ok(o) => (o.stats, o.error.map_or(Ok(()), Err)),
        Err(e) => {
            out.failures.push(format!("cannot build: {e}"));
            return out;
        }
    };
    out.finite = stats.finite;
    out.max_stretch = stats.max_stretch_any_frame;
    out.min_signed_distance = stats.min_signed_distance;
    out.self_crossings = scene.cloth.self_thickness.map(|_| stats.self_crossings_max);
    out.obstacle_crossings = stats.obstacle_crossings_max;
    out.cg_iterations_max = stats.cg_iterations_max;
    out.unconverged_solves = stats.unconverged_solves;
    out.wall_seconds = stats.wall_seconds;
    if let Err(e) = result {
        out.failures.push(format!("stopped: {e}"));
    }
    if !stats.finite {
        out.failures.push("non-finite numbers".into());
    }
    // Written as "within the bound" so a NaN fails.
    let stretch_ok = stats.max_stretch_any_frame <= case.max_stretch;
    if !stretch_ok {
        out.failures.push(format!(
            "stretch {:.2} % over the bound of {:.0} %",
            100.0 * (stats.max_stretch_any_frame - 1.0),
            100.0 * (case.max_stretch - 1.0)
        ));
    }
    let outside = stats
        .min_signed_distance
        .is_none_or(|d| d >= -MAX_PENETRATION);
    if let (false, Some(d)) = (outside, stats.min_signed_distance) {
        out.failures
            .push(format!("a particle {:.2} mm inside an obstacle", -d * 1e3));
    }
    if let Some(n) = out.self_crossings.filter(|&n| n > 0) {
        out.failures
            .push(format!("{n} cloth edges through the cloth at a frame"));
    }
    if out.obstacle_crossings > 0 {
        out.failures.push(format!(
            "{} obstacle edges through cloth triangles at a frame",
            out.obstacle_crossings
        ));
    }
    if stats.unconverged_solves > 0 {
        out.failures.push(format!(
            "{} solves hit the cap of {} CG iterations",
            stats.unconverged_solves, scene.solver.max_iterations
        ));
    }
    out
}
