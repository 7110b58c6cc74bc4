//! Admission by cost: a valid scene's memory, disk and wall time,
//! predicted before it is queued, against the per-job [`Budgets`]
//! (`--job-memory-budget`, `--job-disk-budget`, `--job-time-budget`).
//!
//! The model, with `N` cloth particles, `T` obstacle mesh triangles, `F`
//! stored frames (frame 0 included) and `S` solver steps:
//!
//! ```text
//! memory  = MEMORY_BASE + MEMORY_PER_PARTICLE N
//!         + MEMORY_PER_TRIANGLE (T + DISPLAY_TRIANGLES per primitive)
//! disk    = DISK_OVERHEAD (hello + checkpoint + F frame)
//!   hello      = HELLO_PER_CLOTH_TRIANGLE 2 (nu-1)(nv-1)
//!              + HELLO_PER_OBSTACLE_TRIANGLE (T + DISPLAY_TRIANGLES per primitive)
//!   checkpoint = CHECKPOINT_PER_PARTICLE N
//!   frame      = 12 N + FRAME_STATS + (obstacles? CONTACT_PER_PARTICLE N)
//! seconds = SECONDS_PER_STEP_AT_REFERENCE (N / REFERENCE_PARTICLES)^TIME_EXPONENT S
//! ```
//!
//! Where the constants come from (release build, this repository's
//! 2-core x86_64 VM, 2026-11-23; README "Admission by cost" has the
//! numbers): memory is the peak RSS of `drapery run` on
//! `sphere-drape-30` scaled to 50², 100² and 150² (13.8, 37.2 and 77.1
//! MiB: 3.1-3.2 kB per particle, linear; the solver allocates its world and
//! workspace once, sized by `N` and `T`, and nothing grows per step but
//! the contact list, itself at most `N`), plus what the service encodes
//! per frame (the checkpoint's JSON: `drapery serve` running a 1000x250
//! cloth peaked at 876 MiB, 3.7 kB per particle), and of a 10x10 cloth over meshes of
//! 20,000 and 180,000 triangles (20.1 and 127.7 MiB: 670 B per triangle
//! with the spec's own text); the disk terms are the byte counts of the
//! rows `drapery serve` stored for the 50² drape over 1 s (hello 351 kB,
//! checkpoint 215 B per particle, statistics 1.9 kB per frame on average,
//! 2.9 kB at most with 511 particles in contact); the time is `drapery run`
//! on one thread (a worker's share when every worker is busy) of the
//! drape over 0.6 s, through its contact with the sphere (recalibrated
//! 2026-11-28: 50², 100², 150² took 0.0084, 0.058 and 0.19 s per step,
//! where the constant of 2026-11-23, 0.18 s at 100², was three times what
//! the solver now takes). Time per step grows like `N^1.5` (CG iterations
//! ~ √N, each ~ N; measured N^1.41 from 50² to 150²), so one constant,
//! the seconds per step of a 100² cloth, sets the scale: recalibrate
//! [`SECONDS_PER_STEP_AT_REFERENCE`] when the solver gets faster (`drapery
//! bench scale` prints seconds per step). Above 150² the exponent keeps
//! the estimate high: a flat 1000x250 cloth takes 1.08 s a step against
//! 7.5 s estimated.
//!
//! The estimate only admits; what holds a job in fact is elsewhere: the
//! worker counts the bytes it stores per job and fails the job with
//! `limit_exceeded` past the disk budget, `--max-wall-seconds` stops it in
//! time, and memory, which the solver allocates up front from `N` and
//! `T`, is bounded by refusing the counts the memory budget cannot hold.

use drapery_sim::spec::{Scene, TimeStepping};

/// Resident memory of a job beyond what `N` and `T` explain, bytes.
pub const MEMORY_BASE: f64 = 8.0e6;
/// Resident memory per cloth particle, bytes: 3.2 kB measured for the
/// solver alone; the service running a 1000x250 cloth peaked at 3.7 kB
/// per particle (876 MiB: the solver, the hello and the checkpoint's JSON
/// it encodes).
pub const MEMORY_PER_PARTICLE: f64 = 3700.0;
/// Resident memory per obstacle mesh triangle (mesh, normals, BVH, the
/// spec's text), bytes.
pub const MEMORY_PER_TRIANGLE: f64 = 700.0;
/// SQLite pages and indexes over the bytes stored.
pub const DISK_OVERHEAD: f64 = 1.1;
/// The hello's JSON per cloth triangle (three indices), bytes.
pub const HELLO_PER_CLOTH_TRIANGLE: f64 = 24.0;
/// The hello's JSON per obstacle triangle (indices and its share of the
/// vertices), bytes.
pub const HELLO_PER_OBSTACLE_TRIANGLE: f64 = 50.0;
/// A checkpoint's JSON per particle (position, velocity, warm start,
/// contacts; 215 B measured), bytes.
pub const CHECKPOINT_PER_PARTICLE: f64 = 250.0;
/// A frame's statistics without the contact list, bytes.
pub const FRAME_STATS: f64 = 1000.0;
/// A frame's contact list per particle, all in contact (`123456,`), bytes.
pub const CONTACT_PER_PARTICLE: f64 = 8.0;
/// Seconds per solver step of a cloth of [`REFERENCE_PARTICLES`] (the
/// 100² sphere drape through its contact on one thread: 8.79 s / 152
/// steps, 0.058 s). The one number to recalibrate when the solver gets
/// faster.
pub const SECONDS_PER_STEP_AT_REFERENCE: f64 = 0.06;
/// The cloth size the time constant is measured at (100²).
pub const REFERENCE_PARTICLES: f64 = 10_000.0;
/// Growth of time per step with particles.
pub const TIME_EXPONENT: f64 = 1.5;
/// Steps per frame assumed for adaptive stepping (its level varies).
pub const ADAPTIVE_STEPS_PER_FRAME: f64 = 8.0;
/// Triangles of a primitive's display mesh in the hello, at most (a box
/// is drawn with up to 3,072; a test holds every kind to this). In memory
/// too: the hello is built whole, through a JSON tree, when the job starts.
pub const DISPLAY_TRIANGLES: f64 = 4096.0;

/// What a job may use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Budgets {
    pub memory_bytes: u64,
    pub disk_bytes: u64,
    /// Estimated wall seconds.
    pub seconds: f64,
}

/// What a scene is predicted to use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub particles: u64,
    pub triangles: u64,
    pub frames: u64,
    pub steps: u64,
    pub memory_bytes: f64,
    pub disk_bytes: f64,
    pub seconds: f64,
}

/// One budget a scene's estimate is beyond.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("estimated {what} {estimate} exceeds the per-job budget of {budget} ({flag})")]
pub struct OverBudget {
    pub what: &'static str,
    pub flag: &'static str,
    pub estimate: String,
    pub budget: String,
}

/// The estimate of `scene`, whose obstacle meshes have `triangles`
/// triangles in all.
pub fn estimate(scene: &Scene, triangles: u64) -> Estimate {
    let (nu, nv) = (scene.cloth.nu as f64, scene.cloth.nv as f64);
    let n = nu * nv;
    let t = triangles as f64;
    let frames = scene.frames as f64 + 1.0;
    let per_frame = match scene.solver.stepping {
        TimeStepping::Fixed { substeps } => substeps as f64,
        TimeStepping::Adaptive { .. } => ADAPTIVE_STEPS_PER_FRAME,
    };
    let steps = scene.frames as f64 * per_frame;
    let primitives = scene.obstacles.iter().filter(|o| o.mesh.is_none()).count() as f64;
    let hello = HELLO_PER_CLOTH_TRIANGLE * 2.0 * (nu - 1.0) * (nv - 1.0)
        + HELLO_PER_OBSTACLE_TRIANGLE * (t + primitives * DISPLAY_TRIANGLES);
    let contacts = if scene.obstacles.is_empty() {
        0.0
    } else {
        CONTACT_PER_PARTICLE * n
    };
    let frame = 12.0 * n + FRAME_STATS + contacts;
    Estimate {
        particles: n as u64,
        triangles,
        frames: frames as u64,
        steps: steps as u64,
        memory_bytes: MEMORY_BASE
            + MEMORY_PER_PARTICLE * n
            + MEMORY_PER_TRIANGLE * (t + primitives * DISPLAY_TRIANGLES),
        disk_bytes: DISK_OVERHEAD * (hello + CHECKPOINT_PER_PARTICLE * n + frames * frame),
        seconds: SECONDS_PER_STEP_AT_REFERENCE
            * (n / REFERENCE_PARTICLES).powf(TIME_EXPONENT)
            * steps,
    }
}

impl Budgets {
    /// Every budget `e` is beyond (none: admitted).
    pub fn check(&self, e: &Estimate) -> Vec<OverBudget> {
        let mut over = Vec::new();
        if e.memory_bytes > self.memory_bytes as f64 {
            over.push(OverBudget {
                what: "memory",
                flag: "--job-memory-budget",
                estimate: bytes(e.memory_bytes),
                budget: bytes(self.memory_bytes as f64),
            });
        }
        if e.disk_bytes > self.disk_bytes as f64 {
            over.push(OverBudget {
                what: "disk",
                flag: "--job-disk-budget",
                estimate: bytes(e.disk_bytes),
                budget: bytes(self.disk_bytes as f64),
            });
        }
        if e.seconds > self.seconds {
            over.push(OverBudget {
                what: "wall time",
                flag: "--job-time-budget",
                estimate: duration(e.seconds),
                budget: duration(self.seconds),
            });
        }
        over
    }
}

/// `1.5 GiB`, `640 MiB`, `12 KiB`.
pub fn bytes(b: f64) -> String {
    const UNITS: [&str; 5] = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b;
    let mut unit = 0;
    while v >= 1024.0 && unit + 1 < UNITS.len() {
        v /= 1024.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{v:.0} B")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

/// `42 s`, `3.5 h`.
fn duration(s: f64) -> String {
    if s < 120.0 {
        format!("{s:.0} s")
    } else if s < 7200.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drapery_sim::spec::Limits;

    fn scene(grid: [u32; 2], duration: f64, fps: f64) -> Scene {
        let text = format!(
            r#"{{"cloth": {{"grid": {grid:?}, "size": [1, 1]}}, "material": "cotton",
                "obstacles": [{{"sphere": {{"center": [0, 0, -1], "radius": 0.5}}}}],
                "duration": {duration}, "fps": {fps}}}"#
        );
        crate::specfile::load(&text, &Limits::default()).expect("valid")
    }

    #[test]
    fn the_issues_job_is_beyond_the_default_budgets_and_a_small_one_is_not() {
        let defaults = Budgets {
            memory_bytes: 2 << 30,
            disk_bytes: 2 << 30,
            seconds: 3.0 * 3600.0,
        };
        let huge = estimate(&scene([1000, 250], 600.0, 33.0), 0);
        assert_eq!(huge.frames, 19_801);
        let over = defaults.check(&huge);
        let what: Vec<&str> = over.iter().map(|o| o.what).collect();
        assert_eq!(what, ["disk", "wall time"], "{over:?}");
        assert!(
            over[0].to_string().contains("--job-disk-budget"),
            "{}",
            over[0]
        );
        let small = estimate(&scene([30, 30], 2.0, 60.0), 0);
        assert!(defaults.check(&small).is_empty(), "{small:?}");
        assert_eq!(small.steps, 120 * 4);
    }

    #[test]
    fn sizes_read_in_binary_units() {
        assert_eq!(bytes(512.0), "512 B");
        assert_eq!(bytes(2.0 * 1024.0 * 1024.0 * 1024.0), "2.0 GiB");
        assert_eq!(duration(30.0), "30 s");
        assert_eq!(duration(36_000.0), "10.0 h");
    }
}
