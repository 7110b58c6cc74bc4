//! `drapery bench precision`: a work-precision study of one scene, the way
//! ODE suites measure integrators: how much wall time buys how much
//! accuracy.
//!
//! - The **reference** is the same scene at a much smaller step (default:
//!   the smallest swept step / 8) and a tight CG tolerance (1e-10), or one
//!   saved by an earlier study (`--reference DIR`).
//! - The **time-step sweep** halves the step from `--dt-max` at the tight
//!   tolerance: its error is the time discretisation's (method.md §4,
//!   implicit Euler, first order), plus whatever the contact events add.
//! - The **tolerance sweep** varies the CG tolerance at a fixed step: its
//!   error against the tight run at that step is the solver's alone
//!   (`solver_error_rms`); against the reference it is the total.
//!
//! Errors are position differences over the frames both runs have (frame 0
//! excluded: it is the same initial state), RMS over particles and frames
//! and the maximum, divided by the cloth's diagonal so scenes compare. All
//! runs write frames at the same rate, so their frames coincide: the
//! scene's fps, lowered to `1 / dt_max` if that is longer, since a step
//! cannot be longer than a frame.

use std::fmt::Write as _;
use std::io::{Read, Write};
use std::path::Path;
use std::process::ExitCode;

use anyhow::Context;
use drapery_sim::math::Vec3;
use drapery_sim::spec::{Scene, Spec, TimeStep, TimeStepping};

use super::fit::power_law;
use super::plot::{Series, Style, loglog};
use super::runner::{self, median};
use crate::cli::PrecisionArgs;

/// One run of a sweep.
#[derive(Debug, Clone)]
struct Row {
    sweep: &'static str,
    /// The step actually taken (the frame divided into whole steps).
    dt: f64,
    tolerance: f64,
    steps: usize,
    wall_seconds: f64,
    cg_iterations: usize,
    unconverged_solves: usize,
    finite: bool,
    error_rms: f64,
    error_max: f64,
    /// Against the tight-tolerance run at the same step (tolerance sweep).
    solver_error_rms: Option<f64>,
    pareto: bool,
    /// RMS error of each frame after the first, over the diagonal.
    per_frame: Vec<f64>,
}

/// Positions of every frame of a reference run, with how it was made.
#[derive(Debug, Clone, PartialEq)]
struct Reference {
    frame_dt: f64,
    dt: f64,
    tolerance: f64,
    frames: Vec<Vec<Vec3>>,
}

/// Runs the study; writes `precision.csv` and `precision.svg`, the
/// per-frame `precision-frames.csv` and `.svg`, and (unless it was given)
/// `reference.bin`.
pub fn run(args: &PrecisionArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(args.repeat >= 1, "--repeat: at least 1");
    anyhow::ensure!(args.halvings <= 12, "--halvings: at most 12");
    anyhow::ensure!(
        args.tight_tolerance > 0.0 && args.tight_tolerance < 0.5,
        "--tight-tolerance: between 0 and 0.5"
    );
    anyhow::ensure!(
        args.tolerances.iter().all(|t| *t > 0.0 && *t < 0.5),
        "--tolerances: each between 0 and 0.5"
    );
    let mut base = runner::read_spec(&args.spec)?;
    if let Some(d) = args.duration {
        anyhow::ensure!(d > 0.0 && d.is_finite(), "--duration: must be positive");
        base.duration = d;
    }
    // Every run writes frames at this rate, so all share every frame.
    if base.fps * args.dt_max > 1.0 + 1e-9 {
        base.fps = 1.0 / args.dt_max;
    }
    let diagonal = base.cloth.size[0].hypot(base.cloth.size[1]);
    let name = base.name.clone().unwrap_or_else(|| "scene".into());
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;

    let dts: Vec<f64> = (0..=args.halvings)
        .map(|k| args.dt_max / f64::from(1u32 << k))
        .collect();
    let smallest = dts.last().copied().unwrap_or(args.dt_max);
    let reference = match &args.reference {
        Some(dir) => {
            let r = read_reference(&dir.join("reference.bin"))?;
            let scene = runner::scene(&with(&base, smallest, args.tight_tolerance), "reference")?;
            anyhow::ensure!(
                (r.frame_dt - scene.frame_dt()).abs() < 1e-12 * scene.frame_dt(),
                "--reference: frames every {} s, this study needs {} s",
                r.frame_dt,
                scene.frame_dt()
            );
            anyhow::ensure!(
                r.frames.len() > scene.frames
                    && r.frames[0].len() == scene.cloth.nu * scene.cloth.nv,
                "--reference: {} frames of {} particles, this study needs {} of {}",
                r.frames.len(),
                r.frames.first().map_or(0, Vec::len),
                scene.frames + 1,
                scene.cloth.nu * scene.cloth.nv
            );
            eprintln!("reference: {} (dt {:.3e} s)", dir.display(), r.dt);
            r
        }
        None => {
            let dt = args.reference_dt.unwrap_or(smallest / 8.0);
            let scene = runner::scene(&with(&base, dt, args.tight_tolerance), "reference")?;
            eprintln!(
                "reference: dt {:.3e} s, tolerance {:e}, {} frames ...",
                step_of(&scene),
                args.tight_tolerance,
                scene.frames
            );
            let out = runner::simulate(&scene, true)?;
            if let Some(e) = out.error {
                anyhow::bail!("the reference run failed: {e}");
            }
            eprintln!("reference: {:.1} s wall", out.stats.wall_seconds);
            let r = Reference {
                frame_dt: scene.frame_dt(),
                dt: step_of(&scene),
                tolerance: args.tight_tolerance,
                frames: out.frames,
            };
            write_reference(&args.out.join("reference.bin"), &r)?;
            r
        }
    };

    // The tolerance sweep's step, and its tight run: the time-step sweep's
    // run at that step if it has one.
    let fixed_dt = args.tolerance_dt.unwrap_or(match base.solver.dt {
        TimeStep::Fixed(dt) => dt,
        TimeStep::Adaptive => smallest,
    });
    let fixed = runner::scene(
        &with(&base, fixed_dt, args.tight_tolerance),
        "tolerance sweep",
    )?;
    let h = step_of(&fixed);
    let mut baseline = None;
    let mut rows = Vec::new();
    for &dt in &dts {
        let scene = runner::scene(&with(&base, dt, args.tight_tolerance), "time-step sweep")?;
        let (row, frames) = measure("dt", &scene, args.repeat, &reference.frames, diagonal)?;
        print_row(&row);
        if (row.dt - h).abs() <= 1e-12 * h {
            baseline = Some(frames);
        }
        rows.push(row);
    }
    let baseline = match baseline {
        Some(frames) => frames,
        None => measure("baseline", &fixed, 1, &reference.frames, diagonal)?.1,
    };
    for &tol in &args.tolerances {
        let scene = runner::scene(&with(&base, fixed_dt, tol), "tolerance sweep")?;
        let (mut row, frames) = measure(
            "tolerance",
            &scene,
            args.repeat,
            &reference.frames,
            diagonal,
        )?;
        // A run that stopped early has no solver error either.
        row.solver_error_rms = row
            .error_rms
            .is_finite()
            .then(|| position_error(&frames, &baseline, diagonal).rms);
        print_row(&row);
        rows.push(row);
    }
    mark_pareto(&mut rows);

    std::fs::write(args.out.join("precision.csv"), csv(&rows))?;
    std::fs::write(
        args.out.join("precision-frames.csv"),
        frames_csv(&rows, reference.frame_dt),
    )?;
    plot(&args.out.join("precision.svg"), &name, &rows, args)?;
    plot_frames(
        &args.out.join("precision-frames.svg"),
        &name,
        &rows,
        reference.frame_dt,
    )?;
    report(&rows, reference.frame_dt);
    eprintln!(
        "wrote {}/precision.csv, precision.svg, precision-frames.csv and precision-frames.svg",
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// `base` with a fixed step `dt` and CG tolerance `tolerance`.
fn with(base: &Spec, dt: f64, tolerance: f64) -> Spec {
    let mut s = base.clone();
    s.solver.dt = TimeStep::Fixed(dt);
    s.solver.tolerance = tolerance;
    s
}

/// The step a validated scene takes (its frame in whole steps).
fn step_of(scene: &Scene) -> f64 {
    match scene.solver.stepping {
        TimeStepping::Fixed { substeps } => scene.frame_dt() / substeps as f64,
        TimeStepping::Adaptive { .. } => f64::NAN,
    }
}

/// Runs `scene` `repeat` times: the median wall time, the first run's
/// frames and its error against `reference`.
fn measure(
    sweep: &'static str,
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
            "  {sweep} dt {:.3e} tol {:e}: failed: {e}",
            row.dt, row.tolerance
        );
    }
    Ok((row, first.frames))
}

/// Position error of a run against another, over the diagonal.
#[derive(Debug, Clone, PartialEq)]
struct Errors {
    /// RMS distance over particles and frames.
    rms: f64,
    /// Largest distance of any particle in any frame.
    max: f64,
    /// RMS distance of each frame.
    per_frame: Vec<f64>,
}

/// Distances between matching particles over the frames both runs have,
/// frame 0 excluded (both start from the same state), each divided by
/// `diagonal`.
fn position_error(run: &[Vec<Vec3>], reference: &[Vec<Vec3>], diagonal: f64) -> Errors {
    let (mut sum, mut count, mut max) = (0.0, 0usize, 0.0f64);
    let mut per_frame = Vec::new();
    for (a, b) in run.iter().zip(reference).skip(1) {
        let mut frame = 0.0;
        for (p, q) in a.iter().zip(b) {
            let d2 = (p - q).norm_squared();
            frame += d2;
            max = max.max(d2);
        }
        per_frame.push((frame / a.len().max(1) as f64).sqrt() / diagonal);
        sum += frame;
        count += a.len();
    }
    if count == 0 {
        return Errors {
            rms: f64::NAN,
            max: f64::NAN,
            per_frame,
        };
    }
    Errors {
        rms: (sum / count as f64).sqrt() / diagonal,
        max: max.sqrt() / diagonal,
        per_frame,
    }
}

/// Marks the runs no other run beats in both wall time and RMS error.
fn mark_pareto(rows: &mut [Row]) {
    let mut order: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].error_rms.is_finite())
        .collect();
    order.sort_by(|&a, &b| {
        rows[a]
            .wall_seconds
            .total_cmp(&rows[b].wall_seconds)
            .then(rows[a].error_rms.total_cmp(&rows[b].error_rms))
    });
    let mut best = f64::INFINITY;
    for i in order {
        if rows[i].error_rms < best {
            best = rows[i].error_rms;
            rows[i].pareto = true;
        }
    }
}

/// Observed order `p` in `error ~ dt^p`: the least-squares slope over the
/// time-step sweep, and the slope between each pair of neighbours.
fn orders(rows: &[Row]) -> (Option<f64>, Vec<(f64, f64)>) {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.sweep == "dt" && r.error_rms.is_finite() && r.error_rms > 0.0)
        .map(|r| (r.dt, r.error_rms))
        .collect();
    let pairs = pts
        .windows(2)
        .map(|w| (w[1].0, (w[0].1 / w[1].1).ln() / (w[0].0 / w[1].0).ln()))
        .collect();
    (power_law(&pts).map(|(p, _)| p), pairs)
}

fn print_row(r: &Row) {
    eprintln!(
        "  {:<9} dt {:.3e} tol {:.0e}: {:>6} steps, {:>8.3} s, {:>7} CG its, error rms {:.3e} max {:.3e}{}",
        r.sweep,
        r.dt,
        r.tolerance,
        r.steps,
        r.wall_seconds,
        r.cg_iterations,
        r.error_rms,
        r.error_max,
        r.solver_error_rms
            .map_or(String::new(), |e| format!(", solver error rms {e:.3e}"))
    );
}

/// The observed order at single frames, at eight times spread over the
/// run: `(time, order)`. Where a problem is smooth it stays near one; where
/// runs settle into different states (a symmetric drape choosing its
/// folds) it falls to zero from the time they part.
fn orders_over_time(rows: &[Row], frame_dt: f64) -> Vec<(f64, f64)> {
    let sweep: Vec<&Row> = rows
        .iter()
        .filter(|r| r.sweep == "dt" && r.error_rms.is_finite())
        .collect();
    let frames = sweep.iter().map(|r| r.per_frame.len()).min().unwrap_or(0);
    (1..=8)
        .map(|k| (k * frames).div_ceil(8).max(1))
        .filter(|&f| f <= frames)
        .filter_map(|f| {
            let pts: Vec<(f64, f64)> = sweep.iter().map(|r| (r.dt, r.per_frame[f - 1])).collect();
            power_law(&pts).map(|(p, _)| (f as f64 * frame_dt, p))
        })
        .collect()
}

fn report(rows: &[Row], frame_dt: f64) {
    let (fit, pairs) = orders(rows);
    match fit {
        Some(p) => eprintln!("observed order in dt (least squares): {p:.2}"),
        None => eprintln!("observed order in dt: needs two finite points"),
    }
    for (dt, p) in pairs {
        eprintln!("  order down to dt {dt:.3e}: {p:.2}");
    }
    let over_time = orders_over_time(rows, frame_dt);
    if !over_time.is_empty() {
        eprintln!(
            "observed order at single frames: {}",
            over_time
                .iter()
                .map(|(t, p)| format!("t={t:.2} s: {p:.2}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let tol: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| Some((r.tolerance, r.solver_error_rms?)))
        .filter(|(_, e)| *e > 0.0)
        .collect();
    if let Some((p, _)) = power_law(&tol) {
        eprintln!("solver error ~ tolerance^{p:.2}");
    }
    eprintln!("Pareto front (wall s, error rms):");
    let mut front: Vec<&Row> = rows.iter().filter(|r| r.pareto).collect();
    front.sort_by(|a, b| a.wall_seconds.total_cmp(&b.wall_seconds));
    for r in front {
        eprintln!(
            "  {:>8.3} s  {:.3e}  ({} sweep: dt {:.3e} s, tol {:.0e})",
            r.wall_seconds, r.error_rms, r.sweep, r.dt, r.tolerance
        );
    }
}

fn csv(rows: &[Row]) -> String {
    let mut out = String::from(
        "sweep,dt,tolerance,steps,wall_seconds,cg_iterations,unconverged_solves,finite,error_rms,error_max,solver_error_rms,pareto\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{},{:.9e},{:e},{},{:.6},{},{},{},{:.6e},{:.6e},{},{}",
            r.sweep,
            r.dt,
            r.tolerance,
            r.steps,
            r.wall_seconds,
            r.cg_iterations,
            r.unconverged_solves,
            r.finite,
            r.error_rms,
            r.error_max,
            r.solver_error_rms
                .map_or(String::new(), |e| format!("{e:.6e}")),
            r.pareto
        );
    }
    out
}

/// The error of every frame of every run: where runs part ways.
fn frames_csv(rows: &[Row], frame_dt: f64) -> String {
    let mut out = String::from("sweep,dt,tolerance,frame,time,error_rms\n");
    for r in rows {
        for (k, e) in r.per_frame.iter().enumerate() {
            let _ = writeln!(
                out,
                "{},{:.9e},{:e},{},{:.6},{:.6e}",
                r.sweep,
                r.dt,
                r.tolerance,
                k + 1,
                (k + 1) as f64 * frame_dt,
                e
            );
        }
    }
    out
}

/// Error against simulated time for the time-step sweep: a smooth problem
/// keeps its curves apart by the factor of each halving; a chaotic one
/// (a symmetric drape choosing its folds) sees them merge once the runs
/// have chosen differently.
fn plot_frames(path: &Path, name: &str, rows: &[Row], frame_dt: f64) -> anyhow::Result<()> {
    let series: Vec<Series> = rows
        .iter()
        .filter(|r| r.sweep == "dt")
        .map(|r| Series {
            name: format!("dt {:.2e} s", r.dt),
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

fn plot(path: &Path, name: &str, rows: &[Row], args: &PrecisionArgs) -> anyhow::Result<()> {
    let curve = |sweep: &str| -> Vec<(f64, f64)> {
        rows.iter()
            .filter(|r| r.sweep == sweep)
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
        .find(|r| r.sweep == "tolerance")
        .map_or(f64::NAN, |r| r.dt);
    loglog(
        path,
        &format!("{name}: position error against wall time"),
        (
            "wall seconds (median)",
            "RMS position error / cloth diagonal",
        ),
        &[
            Series {
                name: format!(
                    "time-step sweep {:.2e}…{:.2e} s, tol {:.0e}",
                    args.dt_max,
                    args.dt_max / f64::from(1u32 << args.halvings),
                    args.tight_tolerance
                ),
                points: curve("dt"),
                style: Style::Line,
            },
            Series {
                name: format!("tolerance sweep at dt {fixed:.2e} s"),
                points: curve("tolerance"),
                style: Style::Line,
            },
            Series {
                name: "Pareto front".into(),
                points: front,
                style: Style::Band,
            },
        ],
    )
}

const MAGIC: &[u8; 8] = b"DRPREF01";

/// `reference.bin`: magic, then little-endian u64 particles, u64 frames,
/// f64 frame interval, step and tolerance, then every frame's positions as
/// f64 xyz. Binary f64, not text: the tight runs agree with the reference
/// to far more digits than an OBJ keeps.
fn write_reference(path: &Path, r: &Reference) -> anyhow::Result<()> {
    let file =
        std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
    let mut w = std::io::BufWriter::new(file);
    w.write_all(MAGIC)?;
    let particles = r.frames.first().map_or(0, Vec::len);
    w.write_all(&(particles as u64).to_le_bytes())?;
    w.write_all(&(r.frames.len() as u64).to_le_bytes())?;
    for v in [r.frame_dt, r.dt, r.tolerance] {
        w.write_all(&v.to_le_bytes())?;
    }
    for frame in &r.frames {
        for p in frame {
            for c in p.iter() {
                w.write_all(&c.to_le_bytes())?;
            }
        }
    }
    w.flush()?;
    Ok(())
}

fn read_reference(path: &Path) -> anyhow::Result<Reference> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .with_context(|| format!("reading {}", path.display()))?;
    let bad = || anyhow::anyhow!("{}: not a drapery reference", path.display());
    if bytes.len() < 48 || &bytes[..8] != MAGIC {
        return Err(bad());
    }
    let word = |k: usize| -> [u8; 8] { bytes[8 + 8 * k..16 + 8 * k].try_into().expect("8 bytes") };
    let particles = u64::from_le_bytes(word(0)) as usize;
    let frames = u64::from_le_bytes(word(1)) as usize;
    let [frame_dt, dt, tolerance] = [2, 3, 4].map(|k| f64::from_le_bytes(word(k)));
    let expected = particles
        .checked_mul(frames)
        .and_then(|n| n.checked_mul(24))
        .and_then(|n| n.checked_add(48));
    if expected != Some(bytes.len()) || particles == 0 || frames == 0 {
        return Err(bad());
    }
    let values: Vec<f64> = bytes[48..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
        .collect();
    let frames = values
        .chunks_exact(3 * particles)
        .map(|f| {
            f.chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2]))
                .collect()
        })
        .collect();
    Ok(Reference {
        frame_dt,
        dt,
        tolerance,
        frames,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(sweep: &'static str, dt: f64, wall: f64, err: f64) -> Row {
        Row {
            sweep,
            dt,
            tolerance: 1e-10,
            steps: 1,
            wall_seconds: wall,
            cg_iterations: 1,
            unconverged_solves: 0,
            finite: true,
            error_rms: err,
            error_max: err,
            solver_error_rms: None,
            pareto: false,
            per_frame: Vec::new(),
        }
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_runs() {
        let mut rows = vec![
            row("dt", 0.1, 1.0, 1e-2),
            row("dt", 0.05, 2.0, 5e-3),
            row("tolerance", 0.1, 1.5, 2e-2), // slower and worse than the first
            row("tolerance", 0.1, 3.0, 1e-3),
            row("dt", 0.025, 4.0, f64::NAN), // failed: never on the front
        ];
        mark_pareto(&mut rows);
        let front: Vec<bool> = rows.iter().map(|r| r.pareto).collect();
        assert_eq!(front, [true, true, false, true, false]);
    }

    #[test]
    fn the_observed_order_of_a_first_order_sequence_is_one() {
        let rows: Vec<Row> = (0..5)
            .map(|k| {
                let dt = 0.1 / f64::from(1 << k);
                row("dt", dt, 1.0, 3.0 * dt)
            })
            .collect();
        let (fit, pairs) = orders(&rows);
        assert!((fit.expect("fits") - 1.0).abs() < 1e-12);
        assert!(pairs.iter().all(|(_, p)| (p - 1.0).abs() < 1e-12));
    }

    #[test]
    fn the_order_over_time_follows_each_frame() {
        // Frame errors proportional to dt at first, then equal (the runs
        // settled into different states): order 1, then 0.
        let rows: Vec<Row> = (0..3)
            .map(|k| {
                let dt = 0.1 / f64::from(1 << k);
                let mut r = row("dt", dt, 1.0, dt);
                r.per_frame = (0..8).map(|f| if f < 4 { dt * 0.5 } else { 0.3 }).collect();
                r
            })
            .collect();
        let over = orders_over_time(&rows, 0.5);
        assert_eq!(over.len(), 8);
        assert!((over[0].0 - 0.5).abs() < 1e-12 && (over[0].1 - 1.0).abs() < 1e-12);
        assert!((over[7].0 - 4.0).abs() < 1e-12 && over[7].1.abs() < 1e-12);
    }

    #[test]
    fn errors_are_relative_to_the_diagonal_and_skip_frame_zero() {
        let a = vec![
            vec![Vec3::zeros(); 2],
            vec![Vec3::new(0.3, 0.0, 0.0), Vec3::zeros()],
        ];
        let b = vec![vec![Vec3::new(9.0, 0.0, 0.0); 2], vec![Vec3::zeros(); 2]];
        let e = position_error(&a, &b, 2.0);
        assert!((e.rms - (0.09f64 / 2.0).sqrt() / 2.0).abs() < 1e-15);
        assert!((e.max - 0.15).abs() < 1e-15);
        assert_eq!(e.per_frame, [e.rms]);
    }

    #[test]
    fn a_reference_round_trips_and_a_truncated_one_is_refused() {
        let dir = std::env::temp_dir().join(format!("drapery-ref-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("reference.bin");
        let r = Reference {
            frame_dt: 1.0 / 30.0,
            dt: 1e-4,
            tolerance: 1e-10,
            frames: vec![
                vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(-1.0, 1e-17, 7.0)],
                vec![Vec3::new(0.4, 0.5, 0.6), Vec3::new(2.0, 3.0, f64::MAX)],
            ],
        };
        write_reference(&path, &r).expect("writes");
        assert_eq!(read_reference(&path).expect("reads"), r);
        let bytes = std::fs::read(&path).expect("bytes");
        std::fs::write(&path, &bytes[..bytes.len() - 8]).expect("truncate");
        assert!(read_reference(&path).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
