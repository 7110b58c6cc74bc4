//! What a study writes: `precision.csv`, `precision-frames.csv`, the two
//! plots, and the summary on standard error.

use std::path::Path;

use serde::Serialize;

use super::analysis::{orders, orders_over_time, solver_error_exponent};
use super::row::{Row, Sweep};
use crate::cli::PrecisionArgs;
use crate::commands::bench::csvfile::write_csv;
use crate::commands::bench::plot::{Series, Style, loglog};
use drapery_sim::spec::{IntegratorKind, StoppingRule};

/// A line of `precision.csv`.
#[derive(Serialize)]
struct CsvRow {
    sweep: Sweep,
    integrator: &'static str,
    stopping: StoppingRule,
    dt: f64,
    error_target: Option<f64>,
    error_estimate: f64,
    tolerance: f64,
    steps: usize,
    wall_seconds: f64,
    cg_iterations: usize,
    unconverged_solves: usize,
    finite: bool,
    error_rms: f64,
    error_max: f64,
    solver_error_rms: Option<f64>,
    pareto: bool,
}

/// A line of `precision-frames.csv`: the error of one frame of one run.
#[derive(Serialize)]
struct FrameRow {
    sweep: Sweep,
    integrator: &'static str,
    dt: f64,
    tolerance: f64,
    frame: usize,
    time: f64,
    error_rms: f64,
}

/// Writes both CSV files and both plots into `dir`.
pub fn write(
    dir: &Path,
    name: &str,
    rows: &[Row],
    frame_dt: f64,
    args: &PrecisionArgs,
) -> anyhow::Result<()> {
    write_csv(
        &dir.join("precision.csv"),
        rows.iter().map(|r| CsvRow {
            sweep: r.sweep,
            integrator: r.integrator.name(),
            stopping: r.stopping,
            dt: r.dt,
            error_target: r.error_target,
            error_estimate: r.error_estimate,
            tolerance: r.tolerance,
            steps: r.steps,
            wall_seconds: r.wall_seconds,
            cg_iterations: r.cg_iterations,
            unconverged_solves: r.unconverged_solves,
            finite: r.finite,
            error_rms: r.error_rms,
            error_max: r.error_max,
            solver_error_rms: r.solver_error_rms,
            pareto: r.pareto,
        }),
    )?;
    write_csv(
        &dir.join("precision-frames.csv"),
        rows.iter().flat_map(|r| {
            r.per_frame.iter().enumerate().map(move |(k, e)| FrameRow {
                sweep: r.sweep,
                integrator: r.integrator.name(),
                dt: r.dt,
                tolerance: r.tolerance,
                frame: k + 1,
                time: (k + 1) as f64 * frame_dt,
                error_rms: *e,
            })
        }),
    )?;
    plot_front(&dir.join("precision.svg"), name, rows, args)?;
    plot_frames(&dir.join("precision-frames.svg"), name, rows, frame_dt)
}

/// One run's line in the log.
pub fn print_row(r: &Row) {
    eprintln!(
        "  {:<9} {:<5} dt {:.3e} tol {:.0e}{}: {:>6} steps, {:>8.3} s, {:>7} CG its, error rms {:.3e} max {:.3e}{}{}",
        r.sweep.name(),
        r.integrator.name(),
        r.dt,
        r.tolerance,
        match r.stopping {
            StoppingRule::Error => " (error rule)",
            StoppingRule::Residual => "",
        },
        r.steps,
        r.wall_seconds,
        r.cg_iterations,
        r.error_rms,
        r.error_max,
        r.solver_error_rms
            .map_or(String::new(), |e| format!(", solver error rms {e:.3e}")),
        r.error_target.map_or(String::new(), |e| format!(
            ", asked {e:.1e} m/frame, estimated max {:.2e} m/frame",
            r.error_estimate
        ))
    );
}

/// The study's conclusions: observed orders, solver error against
/// tolerance, the Pareto front.
pub fn report(rows: &[Row], frame_dt: f64) {
    for integrator in IntegratorKind::ALL {
        let mine: Vec<Row> = rows
            .iter()
            .filter(|r| r.integrator == integrator && r.sweep == Sweep::TimeStep)
            .cloned()
            .collect();
        if mine.is_empty() {
            continue;
        }
        let name = integrator.name();
        let (fit, pairs) = orders(&mine);
        match fit {
            Some(p) => eprintln!("{name}: observed order in dt (least squares): {p:.2}"),
            None => eprintln!("{name}: observed order in dt: needs two finite points"),
        }
        for (dt, p) in pairs {
            eprintln!("  order down to dt {dt:.3e}: {p:.2}");
        }
        let over_time = orders_over_time(&mine, frame_dt);
        if !over_time.is_empty() {
            eprintln!(
                "  at single frames: {}",
                over_time
                    .iter()
                    .map(|(t, p)| format!("t={t:.2} s: {p:.2}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    if let Some(p) = solver_error_exponent(rows) {
        eprintln!("solver error ~ tolerance^{p:.2}");
    }
    eprintln!("Pareto front (wall s, error rms):");
    let mut front: Vec<&Row> = rows.iter().filter(|r| r.pareto).collect();
    front.sort_by(|a, b| a.wall_seconds.total_cmp(&b.wall_seconds));
    for r in front {
        eprintln!(
            "  {:>8.3} s  {:.3e}  ({} sweep, {}: dt {:.3e} s, tol {:.0e})",
            r.wall_seconds,
            r.error_rms,
            r.sweep.name(),
            r.integrator.name(),
            r.dt,
            r.tolerance
        );
    }
}

/// Error against simulated time for the time-step sweep: a smooth problem
/// keeps its curves apart by the factor of each halving; a chaotic one
/// (a symmetric drape choosing its folds) sees them merge once the runs
/// have chosen differently.
fn plot_frames(path: &Path, name: &str, rows: &[Row], frame_dt: f64) -> anyhow::Result<()> {
    let series: Vec<Series> = rows
        .iter()
        .filter(|r| r.sweep == Sweep::TimeStep)
        .map(|r| Series {
            name: format!("{} dt {:.2e} s", r.integrator.name(), r.dt),
            points: r
                .per_frame
                .iter()
                .enumerate()
                .map(|(k, e)| ((k + 1) as f64 * frame_dt, *e))
                .collect(),
            style: Style::Line,
        })
        .collect();
    loglog(
        path,
        &format!("{name}: error of each frame, time-step sweep"),
        ("simulated time, s", "RMS position error / cloth diagonal"),
        &series,
    )
}

/// Error against wall time, one curve per sweep, the front as a band.
fn plot_front(path: &Path, name: &str, rows: &[Row], args: &PrecisionArgs) -> anyhow::Result<()> {
    let curve = |sweep: Sweep, integrator: Option<IntegratorKind>| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.sweep == sweep && integrator.is_none_or(|i| r.integrator == i))
            .map(|r| (r.wall_seconds, r.error_rms))
            .collect()
    };
    let mut front: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.pareto)
        .map(|r| (r.wall_seconds, r.error_rms))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let fixed = rows
        .iter()
        .find(|r| r.sweep == Sweep::Tolerance)
        .map_or(f64::NAN, |r| r.dt);
    let mut series = Vec::new();
    for &integrator in &args.integrators {
        let name = integrator.name();
        series.push(Series {
            name: format!(
                "{name}, time-step sweep {:.2e}…{:.2e} s, tol {:.0e}",
                args.dt_max,
                args.dt_max / f64::from(1u32 << args.halvings),
                args.tight_tolerance
            ),
            points: curve(Sweep::TimeStep, Some(integrator)),
            style: Style::Line,
        });
        if !args.errors.is_empty() {
            series.push(Series {
                name: format!("{name}, adaptive, error {:?} m/frame", args.errors),
                points: curve(Sweep::Adaptive, Some(integrator)),
                style: Style::Line,
            });
        }
    }
    series.push(Series {
        name: format!("tolerance sweep at dt {fixed:.2e} s"),
        points: curve(Sweep::Tolerance, None),
        style: Style::Line,
    });
    series.push(Series {
        name: "Pareto front".into(),
        points: front,
        style: Style::Band,
    });
    loglog(
        path,
        &format!("{name}: position error against wall time"),
        (
            "wall seconds (median)",
            "RMS position error / cloth diagonal",
        ),
        &series,
    )
}
