//! `drapery bench scale`: how cost grows with the cloth.
//!
//! The sphere drape (or `--spec`) at `n` x `n` particles for each size,
//! ascending, each for `--duration` simulated seconds: time per step and
//! per simulated second, mean CG iterations per step, collision fraction,
//! and the process's peak memory after that size (sizes run smallest
//! first, so the peak belongs to the size just run). The growth exponent
//! `p` of time per step ~ particles^p is fitted by least squares on the
//! log-log points.

use anyhow::Context;
use drapery_sim::spec::{PinEntry, Spec};
use std::process::ExitCode;

use super::csvfile::write_csv;
use super::fit::power_law;
use super::plot::{Series, Style, loglog};
use super::runner::{self, peak_rss_mib};
use crate::cli::ScaleArgs;

/// The default scene: `examples/scenes/sphere-drape-30.json`.
const SPHERE_DRAPE: &str = include_str!("../../../examples/scenes/sphere-drape-30.json");

/// One size's measurements.
#[derive(Debug, Clone)]
struct Row {
    n: u32,
    particles: usize,
    steps: usize,
    sim_seconds: f64,
    wall_seconds: f64,
    cg_iterations: usize,
    collision_fraction: f64,
    peak_rss_mib: Option<f64>,
}

impl Row {
    fn seconds_per_step(&self) -> f64 {
        self.wall_seconds / self.steps.max(1) as f64
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
    let base: Spec = match &args.spec {
        Some(p) => runner::read_spec(p)?,
        None => serde_json::from_str(SPHERE_DRAPE).context("the built-in sphere drape")?,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;

    let mut rows = Vec::new();
    for &n in &args.sizes {
        let spec = resized(&base, n, args.duration);
        let scene = runner::scene(&spec, &format!("{n}x{n}"))?;
        let out = runner::simulate(&scene, false)?;
        if let Some(e) = out.error {
            anyhow::bail!("{n}x{n}: {e}");
        }
        let stats = out.stats;
        let row = Row {
            n,
            particles: stats.particles,
            steps: stats.steps,
            sim_seconds: stats.sim_seconds,
            wall_seconds: stats.wall_seconds,
            cg_iterations: stats.cg_iterations_total,
            collision_fraction: stats.collision_fraction,
            peak_rss_mib: peak_rss_mib(),
        };
        eprintln!(
            "{n:>4}x{n:<4} {:>7} particles: {:.4} s/step, {:.2} s per simulated s, {:.1} CG its/step, collision {:.1}%",
            row.particles,
            row.seconds_per_step(),
            row.wall_seconds / row.sim_seconds.max(1e-12),
            row.cg_iterations as f64 / row.steps.max(1) as f64,
            100.0 * row.collision_fraction
        );
        rows.push(row);
    }

    let fit = power_law(
        &rows
            .iter()
            .map(|r| (r.particles as f64, r.seconds_per_step()))
            .collect::<Vec<_>>(),
    );
    write_csv(&args.out.join("scale.csv"), rows.iter().map(CsvRow::from))?;
    let mut series = vec![Series {
        name: "time per step (measured)".into(),
        points: rows
            .iter()
            .map(|r| (r.particles as f64, r.seconds_per_step()))
            .collect(),
        style: Style::Points,
    }];
    if let Some((p, c)) = fit {
        series.push(Series {
            name: format!("fit: {c:.2e} · N^{p:.2}"),
            points: rows
                .iter()
                .map(|r| (r.particles as f64, c * (r.particles as f64).powf(p)))
                .collect(),
            style: Style::Line,
        });
    }
    loglog(
        &args.out.join("scale.svg"),
        &format!(
            "{}: time per step against particles",
            base.name.as_deref().unwrap_or("scene")
        ),
        ("particles N", "wall seconds per step"),
        &series,
    )?;
    match fit {
        Some((p, _)) => eprintln!("growth exponent: time per step ~ N^{p:.2}"),
        None => eprintln!("growth exponent: needs at least two sizes"),
    }
    eprintln!("wrote {}/scale.csv and scale.svg", args.out.display());
    Ok(ExitCode::SUCCESS)
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
    particles: usize,
    steps: usize,
    sim_seconds: f64,
    wall_seconds: f64,
    seconds_per_step: f64,
    seconds_per_sim_second: f64,
    cg_iterations_per_step: f64,
    collision_fraction: f64,
    peak_rss_mib: Option<f64>,
}

impl From<&Row> for CsvRow {
    fn from(r: &Row) -> Self {
        Self {
            n: r.n,
            particles: r.particles,
            steps: r.steps,
            sim_seconds: r.sim_seconds,
            wall_seconds: r.wall_seconds,
            seconds_per_step: r.seconds_per_step(),
            seconds_per_sim_second: r.wall_seconds / r.sim_seconds.max(1e-12),
            cg_iterations_per_step: r.cg_iterations as f64 / r.steps.max(1) as f64,
            collision_fraction: r.collision_fraction,
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
