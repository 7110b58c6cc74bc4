//! `drapery bench scale`: how cost grows with the cloth.
//!
//! The sphere drape (or `--spec`) at `n` x `n` particles for each size,
//! ascending, each for `--duration` simulated seconds, with every
//! preconditioner of `--preconditioners` and in a pool of each of
//! `--threads` threads: time per step and per simulated second, mean CG
//! iterations per step, each stage's share of the step, and the process's
//! peak memory after that size (sizes run smallest first, so the peak
//! belongs to the size just run). The growth exponent `p` of time per
//! step ~ particles^p is fitted by least squares on the log-log points of
//! each preconditioner and thread count.

use anyhow::Context;
use drapery_sim::sim::{Stage, StageTimes};
use drapery_sim::spec::{PinEntry, PreconditionerKind, Spec};
use std::process::ExitCode;

use super::csvfile::write_csv;
use super::fit::power_law;
use super::plot::{Series, Style, loglog};
use super::runner::{self, peak_rss_mib};
use crate::cli::ScaleArgs;

/// The default scene: `examples/scenes/sphere-drape-30.json`.
const SPHERE_DRAPE: &str = include_str!("../../../examples/scenes/sphere-drape-30.json");

/// One run's measurements.
#[derive(Debug, Clone)]
struct Row {
    n: u32,
    preconditioner: PreconditionerKind,
    threads: u16,
    particles: usize,
    steps: usize,
    sim_seconds: f64,
    wall_seconds: f64,
    cg_iterations: usize,
    stages: StageTimes,
    peak_rss_mib: Option<f64>,
}

impl Row {
    fn seconds_per_step(&self) -> f64 {
        self.wall_seconds / self.steps.max(1) as f64
    }

    fn share(&self, stages: &[Stage]) -> f64 {
        let total = self.stages.total();
        if total > 0.0 {
            stages.iter().map(|s| self.stages.get(*s)).sum::<f64>() / total
        } else {
            0.0
        }
    }

    fn series(&self) -> String {
        format!(
            "{}, {} thread{}",
            self.preconditioner.name(),
            self.threads,
            if self.threads == 1 { "" } else { "s" }
        )
    }
}

/// Runs the study and writes `scale.csv` and `scale.svg`.
pub fn run(args: &ScaleArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(!args.sizes.is_empty(), "--sizes: give at least one size");
    anyhow::ensure!(
        args.sizes.iter().all(|&n| n >= 2) && args.sizes.windows(2).all(|w| w[0] < w[1]),
        "--sizes: each at least 2, ascending (peak memory is read in that order)"
    );
    anyhow::ensure!(
        args.duration > 0.0 && args.duration.is_finite(),
        "--duration: must be positive"
    );
    anyhow::ensure!(
        !args.preconditioners.is_empty(),
        "--preconditioners: give at least one"
    );
    anyhow::ensure!(
        !args.threads.is_empty(),
        "--threads: give at least one count"
    );
    let base: Spec = match &args.spec {
        Some(p) => runner::read_spec(p)?,
        None => serde_json::from_str(SPHERE_DRAPE).context("the built-in sphere drape")?,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;

    let mut rows = Vec::new();
    for &n in &args.sizes {
        for &preconditioner in &args.preconditioners {
            for &threads in &args.threads {
                let row = measure(&base, n, preconditioner, threads, args.duration)?;
                eprintln!(
                    "{n:>4}x{n:<4} {:<24} {:.4} s/step, {:.2} s per simulated s, {:.1} CG its/step, solve {:.0}%, assemble {:.0}%, collision {:.1}%, self-collision {:.1}%",
                    row.series(),
                    row.seconds_per_step(),
                    row.wall_seconds / row.sim_seconds.max(1e-12),
                    row.cg_iterations as f64 / row.steps.max(1) as f64,
                    100.0 * row.share(&[Stage::Precondition, Stage::Solve]),
                    100.0 * row.share(&[Stage::Assemble]),
                    100.0 * row.share(&[Stage::CollisionPrepare, Stage::CollisionResolve]),
                    100.0 * row.share(&[Stage::SelfCollision]),
                );
                rows.push(row);
            }
        }
    }
    write_csv(&args.out.join("scale.csv"), rows.iter().map(CsvRow::from))?;
    let name = base.name.as_deref().unwrap_or("scene");
    plot(&args.out.join("scale.svg"), name, &rows)?;
    eprintln!("wrote {}/scale.csv and scale.svg", args.out.display());
    Ok(ExitCode::SUCCESS)
}

/// One run of `base` at `n` x `n` with `preconditioner`, in a pool of
/// `threads` threads.
fn measure(
    base: &Spec,
    n: u32,
    preconditioner: PreconditionerKind,
    threads: u16,
    duration: f64,
) -> anyhow::Result<Row> {
    let mut spec = resized(base, n, duration);
    spec.solver.preconditioner = preconditioner;
    let scene = runner::scene(&spec, &format!("{n}x{n}"))?;
    let out = drapery_sim::parallel::with_threads(usize::from(threads), || {
        runner::simulate(&scene, false)
    })?;
    if let Some(e) = out.error {
        anyhow::bail!("{n}x{n} with {}: {e}", preconditioner.name());
    }
    let stats = out.stats;
    Ok(Row {
        n,
        preconditioner,
        threads,
        particles: stats.particles,
        steps: stats.steps,
        sim_seconds: stats.sim_seconds,
        wall_seconds: stats.wall_seconds,
        cg_iterations: stats.cg_iterations_total,
        stages: stats.stage_seconds,
        peak_rss_mib: peak_rss_mib(),
    })
}

/// Time per step against particles, one series per preconditioner and
/// thread count, each with its fitted power law (also printed).
fn plot(path: &std::path::Path, name: &str, rows: &[Row]) -> anyhow::Result<()> {
    let mut keys: Vec<String> = rows.iter().map(Row::series).collect();
    keys.dedup();
    let mut series = Vec::new();
    for key in keys {
        let points: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.series() == key)
            .map(|r| (r.particles as f64, r.seconds_per_step()))
            .collect();
        match power_law(&points) {
            Some((p, c)) => {
                eprintln!("growth exponent, {key}: time per step ~ N^{p:.2}");
                series.push(Series {
                    name: format!("{key}: {c:.2e} · N^{p:.2}"),
                    points: points.iter().map(|&(x, _)| (x, c * x.powf(p))).collect(),
                    style: Style::Line,
                });
            }
            None => eprintln!("growth exponent, {key}: needs at least two sizes"),
        }
        series.push(Series {
            name: format!("{key} (measured)"),
            points,
            style: Style::Points,
        });
    }
    loglog(
        path,
        &format!("{name}: time per step against particles"),
        ("particles N", "wall seconds per step"),
        &series,
    )
}

/// `base` on an `n` x `n` grid for `duration` seconds, its pins moved to
/// the same place on the new grid (a corner stays a corner).
fn resized(base: &Spec, n: u32, duration: f64) -> Spec {
    let mut spec = base.clone();
    let [nu, nv] = base.cloth.grid;
    let map = |p: [u32; 2]| {
        let f = |i: u32, m: u32| {
            if m > 1 {
                ((f64::from(i) * f64::from(n - 1) / f64::from(m - 1)).round() as u32).min(n - 1)
            } else {
                0
            }
        };
        [f(p[0], nu), f(p[1], nv)]
    };
    for entry in &mut spec.cloth.pinned {
        match entry {
            PinEntry::Particle(p) => *p = map(*p),
            PinEntry::Group(g) => g.particles.iter_mut().for_each(|p| *p = map(*p)),
        }
    }
    spec.cloth.grid = [n, n];
    spec.duration = duration;
    spec
}

/// A line of `scale.csv`.
#[derive(serde::Serialize)]
struct CsvRow {
    n: u32,
    preconditioner: &'static str,
    threads: u16,
    particles: usize,
    steps: usize,
    sim_seconds: f64,
    wall_seconds: f64,
    seconds_per_step: f64,
    seconds_per_sim_second: f64,
    cg_iterations_per_step: f64,
    assemble_share: f64,
    precondition_share: f64,
    solve_share: f64,
    collision_share: f64,
    self_collision_share: f64,
    peak_rss_mib: Option<f64>,
}

impl From<&Row> for CsvRow {
    fn from(r: &Row) -> Self {
        Self {
            n: r.n,
            preconditioner: r.preconditioner.name(),
            threads: r.threads,
            particles: r.particles,
            steps: r.steps,
            sim_seconds: r.sim_seconds,
            wall_seconds: r.wall_seconds,
            seconds_per_step: r.seconds_per_step(),
            seconds_per_sim_second: r.wall_seconds / r.sim_seconds.max(1e-12),
            cg_iterations_per_step: r.cg_iterations as f64 / r.steps.max(1) as f64,
            assemble_share: r.share(&[Stage::Assemble]),
            precondition_share: r.share(&[Stage::Precondition]),
            solve_share: r.share(&[Stage::Solve]),
            collision_share: r.share(&[Stage::CollisionPrepare, Stage::CollisionResolve]),
            self_collision_share: r.share(&[Stage::SelfCollision]),
            peak_rss_mib: r.peak_rss_mib,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resizing_keeps_pins_at_the_same_place() {
        let mut base: Spec = serde_json::from_str(SPHERE_DRAPE).expect("parses");
        base.cloth.pinned = vec![[0, 0].into(), [29, 0].into(), [15, 29].into()];
        let s = resized(&base, 11, 0.1);
        assert_eq!(s.cloth.grid, [11, 11]);
        assert_eq!(
            s.cloth.pinned,
            vec![[0, 0].into(), [10, 0].into(), [5, 10].into()]
        );
        assert!(s.validate(&drapery_sim::spec::Limits::default()).is_ok());
    }
}
