//! `drapery run SPEC --out DIR`: simulate one job and write its frames and
//! `stats.json` (DESIGN.md "Command line").
//!
//! Frames are written as they are produced, so memory does not grow with
//! the run's length; `stats.json` is written even when the run fails, with
//! `finite: false` and the error, so a failed run still explains itself.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use drapery_sim::export::{Pc2Writer, write_glb, write_obj};
use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, Progress};
use drapery_sim::spec::{Limits, Scene, SpecError, SpecErrors};
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::{Format, RunArgs};
use crate::specfile::{self, SpecLoadError};

/// A `.glb` is held in memory until the run ends and then written whole,
/// so one that glTF's 4 GiB cannot hold is refused before the run, at the
/// field that sets the frame count.
fn glb_fits(scene: &Scene) -> Result<(), SpecLoadError> {
    let particles = (scene.cloth.nu * scene.cloth.nv) as f64;
    let frames = scene.frames + 1;
    // Each frame a morph target (12 B a particle) and its sparse weight
    // key; the base mesh's positions and triangles ~24 B a particle.
    let bytes = frames as f64 * (12.0 * particles + 64.0) + 24.0 * particles;
    if bytes <= f64::from(u32::MAX) {
        return Ok(());
    }
    Err(SpecLoadError::Invalid(SpecErrors(vec![SpecError {
        path: "fps".into(),
        message: format!(
            "{frames} frames of {particles} particles make a {:.1} GiB .glb, over glTF's 4 GiB: fewer frames, or --format pc2 or obj",
            bytes / f64::from(1u32 << 30)
        ),
    }])))
}

/// Runs the job; exit 2 for an invalid spec, 1 for a failed run.
pub fn run(args: &RunArgs) -> anyhow::Result<ExitCode> {
    let text = super::files::read_spec(&args.spec)?;
    let loaded = specfile::load_scene(&text, &Limits::default()).and_then(|scene| {
        if args.format == Format::Glb {
            glb_fits(&scene)?;
        }
        specfile::build(&scene)
    });
    let mut sim = match loaded {
        Ok(s) => s,
        Err(e) => {
            for err in e.errors() {
                eprintln!("{err}");
            }
            return Ok(ExitCode::from(2));
        }
    };
    let frames = sim.scene().frames;
    fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let triangles = sim.grid().triangles();

    let bar = progress_bar(args.quiet, frames as u64);
    let on_progress = |p: Progress| bar.set_position(p.frame as u64);
    let control = Control {
        cancel: None,
        progress: Some(&on_progress),
    };

    let mut sink = FrameSink::open(
        args.format,
        &args.out,
        &sim.grid().rest,
        frames + 1,
        &triangles,
    )?;
    let start = Instant::now();
    let mut rec = sim.recorder();
    // PERF: frames are formatted and written on a thread of their own
    // while the solver goes on (an OBJ frame is ~5 % of a 30² run's
    // instructions): the files are the same, the solver waits only when
    // it is `FRAMES_IN_FLIGHT` frames ahead of the disk. On a write error
    // the run stops at the next frame, so `stats.json` may count up to
    // that many frames past the last file written; its `error` names the
    // file.
    let outcome = std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<(usize, f64, Vec<Vec3>)>(FRAMES_IN_FLIGHT);
        let writer = scope.spawn(move || -> anyhow::Result<()> {
            for (frame, time, x) in rx {
                sink.write(frame, time, &x)?;
            }
            sink.finish()
        });
        let simulated = sim.run(&control, &mut rec, |s, stats| {
            tx.send((stats.frame, stats.time, s.state().x.clone()))
                .map_err(|_| "the frame writer stopped")
        });
        drop(tx);
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("the frame writer panicked")));
        // The writer's own error says why it stopped; the solver's only
        // that it did.
        written.and(simulated.map_err(anyhow::Error::from))
    });
    bar.finish_and_clear();

    let stats = rec.finish(start.elapsed().as_secs_f64());
    let mut json = serde_json::to_value(&stats)?;
    if let Err(e) = &outcome {
        json["error"] = serde_json::Value::String(format!("{e:#}"));
    }
    let stats_path = args.out.join("stats.json");
    fs::write(&stats_path, serde_json::to_vec_pretty(&json)?)
        .with_context(|| format!("writing {}", stats_path.display()))?;

    match outcome {
        Ok(()) => {
            eprintln!(
                "{}: {} frames, {} steps, {} CG iterations in {:.3} s; max stretch {:.4}; wrote {}",
                stats.name,
                stats.frames,
                stats.steps,
                stats.cg_iterations_total,
                stats.wall_seconds,
                stats.max_stretch,
                args.out.display()
            );
            if stats.error_missed_steps > 0 {
                eprintln!(
                    "warning: {} adaptive steps at the finest size allowed still estimated more error than their share of solver.error; see error_missed_steps in stats.json",
                    stats.error_missed_steps
                );
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            Ok(ExitCode::FAILURE)
        }
    }
}

/// Frames the solver may run ahead of the frame writer.
const FRAMES_IN_FLIGHT: usize = 4;

fn progress_bar(quiet: bool, frames: u64) -> ProgressBar {
    // indicatif draws to stderr and hides itself when that is not a terminal.
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(frames);
    if let Ok(style) = ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} frames (eta {eta})",
    ) {
        bar.set_style(style);
    }
    bar
}

/// Where frames go, by format.
enum FrameSink<'a> {
    Obj {
        dir: &'a Path,
        triangles: &'a [[u32; 3]],
    },
    Pc2(Pc2Writer<BufWriter<File>>),
    /// glTF needs every frame before it can be written: kept as f32.
    Glb {
        out: &'a Path,
        triangles: &'a [[u32; 3]],
        times: Vec<f64>,
        frames: Vec<Vec<[f32; 3]>>,
    },
}

impl<'a> FrameSink<'a> {
    fn open(
        format: Format,
        out: &'a Path,
        rest: &[drapery_sim::math::Vec3],
        frames: usize,
        triangles: &'a [[u32; 3]],
    ) -> anyhow::Result<Self> {
        match format {
            Format::Obj => {
                let dir = out.join("frames");
                fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
                Ok(FrameSink::Obj {
                    dir: out,
                    triangles,
                })
            }
            Format::Pc2 => {
                // The cache holds positions only; the topology goes beside it.
                let mut mesh = BufWriter::new(
                    File::create(out.join("cloth.obj")).context("creating cloth.obj")?,
                );
                write_obj(&mut mesh, rest, triangles)?;
                mesh.flush()?;
                let points = rest.len();
                let file = File::create(out.join("cloth.pc2")).context("creating cloth.pc2")?;
                Ok(FrameSink::Pc2(Pc2Writer::new(
                    BufWriter::new(file),
                    points,
                    frames,
                )?))
            }
            Format::Glb => Ok(FrameSink::Glb {
                out,
                triangles,
                times: Vec::with_capacity(frames),
                frames: Vec::with_capacity(frames),
            }),
        }
    }

    fn write(
        &mut self,
        frame: usize,
        time: f64,
        x: &[drapery_sim::math::Vec3],
    ) -> anyhow::Result<()> {
        match self {
            FrameSink::Obj { dir, triangles } => {
                let path = dir.join("frames").join(format!("frame_{frame:05}.obj"));
                let mut w = BufWriter::new(
                    File::create(&path).with_context(|| format!("creating {}", path.display()))?,
                );
                write_obj(&mut w, x, triangles)?;
                w.flush()?;
                Ok(())
            }
            FrameSink::Pc2(w) => Ok(w.write_frame(x)?),
            FrameSink::Glb { times, frames, .. } => {
                times.push(time);
                frames.push(x.iter().map(|p| p.map(|c| c as f32).into()).collect());
                Ok(())
            }
        }
    }

    fn finish(self) -> anyhow::Result<()> {
        match self {
            FrameSink::Obj { .. } => Ok(()),
            FrameSink::Pc2(w) => {
                w.finish()?;
                Ok(())
            }
            FrameSink::Glb {
                out,
                triangles,
                times,
                frames,
            } => {
                let path = out.join("cloth.glb");
                let mut w = BufWriter::new(
                    File::create(&path).with_context(|| format!("creating {}", path.display()))?,
                );
                write_glb(&mut w, triangles, &times, &frames)?;
                w.flush()?;
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `.glb` glTF cannot hold is refused before the run, naming the
    /// field; one it can is let through.
    #[test]
    fn a_glb_over_four_gib_is_refused_before_the_run() {
        let scene = |n: u32, duration: f64| {
            let text = format!(
                r#"{{"cloth": {{"grid": [{n}, {n}], "size": [1, 1]}}, "material": "cotton",
                    "duration": {duration}, "fps": 10}}"#
            );
            specfile::load_scene(&text, &Limits::default()).expect("valid")
        };
        glb_fits(&scene(30, 2.0)).expect("a small drape");
        glb_fits(&scene(1000, 30.0)).expect("301 frames of 10^6 particles: 3.4 GiB");
        let e = glb_fits(&scene(1000, 40.0))
            .expect_err("401 frames: 4.5 GiB")
            .errors();
        assert_eq!(e[0].path, "fps", "{e:?}");
        assert!(e[0].message.contains("over glTF's 4 GiB"), "{e:?}");
    }
}
