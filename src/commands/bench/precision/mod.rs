//! `drapery bench precision`: a work-precision study of one scene, the way
//! ODE suites measure integrators: how much wall time buys how much
//! accuracy.
//!
//! - The **reference** is the same scene at a much smaller step (default:
//!   the smallest swept step / 8) and a tight CG tolerance (1e-10), or one
//!   saved by an earlier study (`--reference DIR`).
//! - The **sweeps** ([`row::Sweep`]): the step halved from `--dt-max`
//!   at the tight tolerance (the time discretisation's error, plus what
//!   contact events add), and the CG tolerance at a fixed step (against
//!   the tight run at that step, the solver's error alone:
//!   `solver_error_rms`; against the reference, the total); the time-step
//!   sweep runs once per integrator (`--integrators`, Euler and BDF2), a
//!   front each;
//! - the **adaptive** sweep: `dt: "adaptive"` at each `--errors` value
//!   per integrator, its cost and its calibration (the error asked per
//!   frame, what the run's estimate reported, what it achieved).
//!
//! The reference is always BDF2 (the more accurate at any step).
//!
//! Errors are position differences over the frames both runs have (frame 0
//! excluded: it is the same initial state), RMS over particles and frames
//! and the maximum, divided by the cloth's diagonal so scenes compare. All
//! runs write frames at the same rate, so their frames coincide: the
//! scene's fps, lowered to `1 / dt_max` if that is longer, since a step
//! cannot be longer than a frame.
//!
//! `reference` makes or reads the reference, `sweeps` runs, `row` is what
//! a run leaves, `analysis` concludes, `output` writes.

mod analysis;
mod output;
mod reference;
mod row;
mod sweeps;

use std::process::ExitCode;

use anyhow::Context;
use drapery_sim::math::Vec3;
use drapery_sim::spec::{IntegratorKind, Spec, StoppingRule, TimeStep};

use super::runner;
use crate::cli::PrecisionArgs;
use analysis::{mark_pareto, position_error};
use reference::Reference;
use row::{Row, Sweep};
use sweeps::{adaptive, measure, step_of, with};

/// Runs the study; writes `precision.csv` and `precision.svg`, the
/// per-frame `precision-frames.csv` and `.svg`, and (unless it was given)
/// `reference.bin`.
pub fn run(args: &PrecisionArgs) -> anyhow::Result<ExitCode> {
    let study = Study::new(args)?;
    let reference = study.reference()?;
    let (mut rows, baseline) = study.time_steps(&reference)?;
    rows.extend(study.tolerances(&reference, &baseline)?);
    rows.extend(study.adaptive(&reference)?);
    mark_pareto(&mut rows);
    output::write(&args.out, &study.name, &rows, reference.frame_dt, args)?;
    output::report(&rows, reference.frame_dt);
    eprintln!(
        "wrote {}/precision.csv, precision.svg, precision-frames.csv and precision-frames.svg",
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// The study's settings, checked.
struct Study<'a> {
    args: &'a PrecisionArgs,
    /// The scene, with the duration and frame rate every run shares.
    base: Spec,
    name: String,
    diagonal: f64,
    /// The time-step sweep's steps, largest first.
    dts: Vec<f64>,
}

impl<'a> Study<'a> {
    fn new(args: &'a PrecisionArgs) -> anyhow::Result<Self> {
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
        anyhow::ensure!(
            args.errors.iter().all(|e| *e > 0.0 && *e <= 1.0),
            "--errors: each in (0, 1] metres"
        );
        anyhow::ensure!(!args.integrators.is_empty(), "--integrators: at least one");
        let mut base = runner::read_spec(&args.spec)?;
        if let Some(d) = args.duration {
            anyhow::ensure!(d > 0.0 && d.is_finite(), "--duration: must be positive");
            base.duration = d;
        }
        // Every run writes frames at this rate, so all share every frame.
        if base.fps * args.dt_max > 1.0 + 1e-9 {
            base.fps = 1.0 / args.dt_max;
        }
        std::fs::create_dir_all(&args.out)
            .with_context(|| format!("creating {}", args.out.display()))?;
        Ok(Self {
            args,
            diagonal: base.cloth.size[0].hypot(base.cloth.size[1]),
            name: base.name.clone().unwrap_or_else(|| "scene".into()),
            dts: (0..=args.halvings)
                .map(|k| args.dt_max / f64::from(1u32 << k))
                .collect(),
            base,
        })
    }

    fn smallest(&self) -> f64 {
        self.dts.last().copied().unwrap_or(self.args.dt_max)
    }

    /// The reference: read from `--reference`, or run and saved.
    fn reference(&self) -> anyhow::Result<Reference> {
        let tight = self.args.tight_tolerance;
        let Some(dir) = &self.args.reference else {
            let dt = self.args.reference_dt.unwrap_or(self.smallest() / 8.0);
            let scene = runner::scene(
                &with(&self.base, IntegratorKind::Bdf2, dt, tight),
                "reference",
            )?;
            eprintln!(
                "reference: dt {:.3e} s, tolerance {tight:e}, {} frames ...",
                step_of(&scene),
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
                tolerance: tight,
                frames: out.frames,
            };
            r.write(&self.args.out.join("reference.bin"))?;
            return Ok(r);
        };
        let r = Reference::read(&dir.join("reference.bin"))?;
        let scene = runner::scene(
            &with(&self.base, IntegratorKind::Bdf2, self.smallest(), tight),
            "reference",
        )?;
        anyhow::ensure!(
            (r.frame_dt - scene.frame_dt()).abs() < 1e-12 * scene.frame_dt(),
            "--reference: frames every {} s, this study needs {} s",
            r.frame_dt,
            scene.frame_dt()
        );
        anyhow::ensure!(
            r.frames.len() > scene.frames && r.frames[0].len() == scene.cloth.nu * scene.cloth.nv,
            "--reference: {} frames of {} particles, this study needs {} of {}",
            r.frames.len(),
            r.frames.first().map_or(0, Vec::len),
            scene.frames + 1,
            scene.cloth.nu * scene.cloth.nv
        );
        eprintln!("reference: {} (dt {:.3e} s)", dir.display(), r.dt);
        Ok(r)
    }

    /// The tolerance sweep's step: `--tolerance-dt`, or the scene's own.
    fn fixed_dt(&self) -> f64 {
        self.args.tolerance_dt.unwrap_or(match self.base.solver.dt {
            TimeStep::Fixed(dt) => dt,
            TimeStep::Adaptive => self.smallest(),
        })
    }

    /// The time-step sweep of each integrator, and the frames of the
    /// scene's integrator's tight run at the tolerance sweep's step (run
    /// apart if the sweep has no such run).
    fn time_steps(&self, reference: &Reference) -> anyhow::Result<(Vec<Row>, Vec<Vec<Vec3>>)> {
        let tight = self.args.tight_tolerance;
        let own = self.base.solver.integrator;
        let fixed = runner::scene(
            &with(&self.base, own, self.fixed_dt(), tight),
            "tolerance sweep",
        )?;
        let h = step_of(&fixed);
        let mut baseline = None;
        let mut rows = Vec::new();
        for &integrator in &self.args.integrators {
            for &dt in &self.dts {
                let spec = with(&self.base, integrator, dt, tight);
                let scene = runner::scene(&spec, "time-step sweep")?;
                let (row, frames) = self.measure(Sweep::TimeStep, &scene, reference)?;
                if integrator == own && (row.dt - h).abs() <= 1e-12 * h {
                    baseline = Some(frames);
                }
                rows.push(row);
            }
        }
        let baseline = match baseline {
            Some(frames) => frames,
            None => measure(Sweep::TimeStep, &fixed, 1, &reference.frames, self.diagonal)?.1,
        };
        Ok((rows, baseline))
    }

    /// The adaptive sweep: each integrator at each requested error.
    fn adaptive(&self, reference: &Reference) -> anyhow::Result<Vec<Row>> {
        let tight = self.args.tight_tolerance;
        let mut rows = Vec::new();
        for &integrator in &self.args.integrators {
            for &error in &self.args.errors {
                let spec = adaptive(&self.base, integrator, error, tight);
                let scene = runner::scene(&spec, "adaptive sweep")?;
                rows.push(self.measure(Sweep::Adaptive, &scene, reference)?.0);
            }
        }
        Ok(rows)
    }

    /// The tolerance sweep at the fixed step, with each run's error
    /// against the tight run at that step (`baseline`).
    fn tolerances(
        &self,
        reference: &Reference,
        baseline: &[Vec<Vec3>],
    ) -> anyhow::Result<Vec<Row>> {
        let own = self.base.solver.integrator;
        let by_residual = self
            .args
            .tolerances
            .iter()
            .map(|&tol| with(&self.base, own, self.fixed_dt(), tol));
        // And the scene's tolerance with the error rule.
        let mut by_error = with(&self.base, own, self.fixed_dt(), self.base.solver.tolerance);
        by_error.solver.stopping = StoppingRule::Error;
        let mut rows = Vec::new();
        for spec in by_residual.chain([by_error]) {
            let scene = runner::scene(&spec, "tolerance sweep")?;
            let (mut row, frames) = self.measure(Sweep::Tolerance, &scene, reference)?;
            // A run that stopped early has no solver error either.
            row.solver_error_rms = row
                .error_rms
                .is_finite()
                .then(|| position_error(&frames, baseline, self.diagonal).rms);
            output::print_row(&row);
            rows.push(row);
        }
        Ok(rows)
    }

    fn measure(
        &self,
        sweep: Sweep,
        scene: &drapery_sim::spec::Scene,
        reference: &Reference,
    ) -> anyhow::Result<(Row, Vec<Vec<Vec3>>)> {
        let (row, frames) = measure(
            sweep,
            scene,
            self.args.repeat,
            &reference.frames,
            self.diagonal,
        )?;
        if sweep != Sweep::Tolerance {
            output::print_row(&row);
        }
        Ok((row, frames))
    }
}
