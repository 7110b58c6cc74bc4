//! Command-line arguments (DESIGN.md "Command line").

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// Cloth simulation: run a job spec, validate one, or serve jobs.
#[derive(Debug, Parser)]
#[command(name = "drapery", version, about)]
pub struct Cli {
    /// Log as JSON lines instead of text.
    #[arg(long, global = true, env = "DRAPERY_LOG_JSON")]
    pub log_json: bool,
    /// Solver threads (default: every core). Results are bit for bit the
    /// same whatever the number; the service's workers share this pool.
    #[arg(long, global = true, env = "DRAPERY_THREADS", value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub threads: Option<u16>,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run one job spec and write its frames and statistics.
    Run(RunArgs),
    /// Check a job spec and print every error.
    Validate(ValidateArgs),
    /// Run the simulation service (HTTP API, WebSocket streams, workers).
    Serve(ServeArgs),
    /// Print the service's OpenAPI document, or write it and the job
    /// schema into a directory (`api/`).
    Openapi(OpenapiArgs),
    /// Benchmark studies (issue: run time against error, stress, scaling).
    #[command(subcommand)]
    Bench(BenchCommand),
    /// Probe a running server's `/healthz` (exit 0 when healthy): the
    /// container's health check, which has no curl.
    Health(HealthArgs),
}

/// `drapery health`.
#[derive(Debug, Args)]
pub struct HealthArgs {
    /// The server's address.
    #[arg(long, env = "DRAPERY_HEALTH_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: std::net::SocketAddr,
}

/// `drapery openapi`.
#[derive(Debug, Args)]
pub struct OpenapiArgs {
    /// Write `openapi.yaml` and `job.schema.json` into this directory
    /// instead of printing the document.
    #[arg(long)]
    pub write: Option<PathBuf>,
}

/// `drapery run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The job spec (JSON).
    pub spec: PathBuf,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Frame format.
    #[arg(long, value_enum, default_value_t = Format::Obj)]
    pub format: Format,
    /// Never draw a progress bar, even on a terminal.
    #[arg(long)]
    pub quiet: bool,
}

/// Output formats of `drapery run`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// `frames/frame_NNNNN.obj`, one OBJ per frame.
    Obj,
    /// `cloth.pc2` point cache plus `cloth.obj` with the topology.
    Pc2,
    /// `cloth.glb`: binary glTF, frames as morph targets with an animation.
    Glb,
}

/// `drapery validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// The job spec (JSON).
    pub spec: PathBuf,
}

/// `drapery serve`: every flag can also be set through the environment
/// variable named beside it (a container's usual configuration).
#[derive(Debug, Clone, Args)]
pub struct ServeArgs {
    /// Address to listen on; port 0 picks a free port (printed at start).
    #[arg(long, env = "DRAPERY_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: std::net::SocketAddr,
    /// Solver worker threads; default: the machine's cores. 0 makes an
    /// API-only node, which needs a shared --store.
    #[arg(long, env = "DRAPERY_WORKERS")]
    pub workers: Option<usize>,
    /// Directory of the job database (created if missing), when --store
    /// is not given.
    #[arg(long, env = "DRAPERY_DATA", default_value = "drapery-data")]
    pub data: PathBuf,
    /// A PostgreSQL job store, `postgres://USER[:PASSWORD]@HOST[:PORT]/DB`,
    /// which several nodes may share; default: SQLite under --data, for
    /// one machine.
    #[arg(long, env = "DRAPERY_STORE")]
    pub store: Option<String>,
    /// Most connections this node opens to the PostgreSQL store.
    #[arg(long, env = "DRAPERY_STORE_CONNECTIONS", default_value_t = 16)]
    pub store_connections: usize,
    /// This node's name, unique among the nodes sharing a store: the job
    /// status's `node`, the metrics' `node` label; default: the host name.
    #[arg(long, env = "DRAPERY_NODE")]
    pub node: Option<String>,
    /// Seconds a node's lease on a running job lasts without renewal (it
    /// renews every second): a job whose node died is taken over by
    /// another node about this long after its last renewal.
    #[arg(long, env = "DRAPERY_LEASE_SECONDS", default_value_t = 20.0)]
    pub lease_seconds: f64,
    /// Jobs that may wait for a worker; beyond it, submissions get 429.
    #[arg(long, env = "DRAPERY_QUEUE_CAPACITY", default_value_t = 64)]
    pub queue_capacity: usize,
    /// Largest cloth of a job, in particles.
    #[arg(long, env = "DRAPERY_MAX_PARTICLES", default_value_t = 250_000)]
    pub max_particles: usize,
    /// Largest total obstacle triangle count of a job.
    #[arg(long, env = "DRAPERY_MAX_TRIANGLES", default_value_t = 2_000_000)]
    pub max_triangles: usize,
    /// Longest simulated duration of a job, seconds.
    #[arg(long, env = "DRAPERY_MAX_DURATION", default_value_t = 600.0)]
    pub max_duration: f64,
    /// Most output frames of a job.
    #[arg(long, env = "DRAPERY_MAX_FRAMES", default_value_t = 20_000)]
    pub max_frames: usize,
    /// Longest wall time a job may run before it is failed, seconds.
    #[arg(long, env = "DRAPERY_MAX_WALL_SECONDS", default_value_t = 3600.0)]
    pub max_wall_seconds: f64,
    /// Largest request body, bytes.
    #[arg(long, env = "DRAPERY_MAX_BODY_BYTES", default_value_t = 32 << 20)]
    pub max_body_bytes: usize,
    /// API keys as `NAME:SECRET` (or a bare secret); with any set, every
    /// `/v1` call needs `Authorization: Bearer SECRET` and sees only its own
    /// jobs. Comma-separated in the environment.
    #[arg(long = "api-key", env = "DRAPERY_API_KEYS", value_delimiter = ',')]
    pub api_keys: Vec<String>,
    /// Origins allowed by CORS (`*` for any); none: no CORS headers.
    #[arg(
        long = "cors-origin",
        env = "DRAPERY_CORS_ORIGINS",
        value_delimiter = ','
    )]
    pub cors_origins: Vec<String>,
    /// Wall seconds between checkpoints of a running job.
    #[arg(long, env = "DRAPERY_CHECKPOINT_SECONDS", default_value_t = 2.0)]
    pub checkpoint_seconds: f64,
    /// On SIGTERM/SIGINT, how long running jobs get to reach a frame and
    /// checkpoint, and open connections to finish their requests, before
    /// the server exits anyway, seconds.
    #[arg(long, env = "DRAPERY_SHUTDOWN_GRACE", default_value_t = 20.0)]
    pub shutdown_grace: f64,
    /// Most open client connections; more wait in the listen backlog.
    #[arg(long, env = "DRAPERY_MAX_CONNECTIONS", default_value_t = 512)]
    pub max_connections: usize,
    /// Seconds a request's head (request line and headers) may take from
    /// its first byte; the connection is closed after.
    #[arg(long, env = "DRAPERY_HEADER_TIMEOUT", default_value_t = 10.0)]
    pub header_timeout: f64,
    /// Seconds a request's body may take to arrive whole; `408` after.
    #[arg(long, env = "DRAPERY_BODY_TIMEOUT", default_value_t = 60.0)]
    pub body_timeout: f64,
    /// Seconds a kept-alive connection may stay silent between requests
    /// before it is closed.
    #[arg(long, env = "DRAPERY_IDLE_TIMEOUT", default_value_t = 60.0)]
    pub idle_timeout: f64,
    /// Result downloads built at once: each is held in memory whole until
    /// it is sent, so this bounds their memory; more wait up to 10 s for
    /// their turn, then get 429 with `Retry-After`.
    #[arg(long, env = "DRAPERY_MAX_DOWNLOADS", default_value_t = 2)]
    pub max_downloads: usize,
    /// Per-job memory budget (`2GiB`, `512MiB`, bytes): a spec whose
    /// estimated solver memory is larger gets `422 over_budget`.
    #[arg(long, env = "DRAPERY_JOB_MEMORY_BUDGET", default_value = "2GiB", value_parser = parse_bytes)]
    pub job_memory_budget: u64,
    /// Per-job disk budget: a spec whose estimated stored frames,
    /// checkpoint and hello are larger gets `422 over_budget`, and a job
    /// that stores more fails with `limit_exceeded`.
    #[arg(long, env = "DRAPERY_JOB_DISK_BUDGET", default_value = "2GiB", value_parser = parse_bytes)]
    pub job_disk_budget: u64,
    /// Per-job estimated wall-time budget, seconds: a spec estimated to run
    /// longer gets `422 over_budget`. Generous on purpose (three times the
    /// default --max-wall-seconds): the estimate is rough, and
    /// --max-wall-seconds stays the hard bound.
    #[arg(long, env = "DRAPERY_JOB_TIME_BUDGET", default_value_t = 10_800.0)]
    pub job_time_budget: f64,
    /// Delete ended jobs (their frames and checkpoints too) older than an
    /// age (`30d`, `12h`) or beyond a count of the newest (`1000`); both
    /// may be given (`30d,1000`). Default: keep every job.
    #[arg(long, env = "DRAPERY_RETENTION", value_delimiter = ',', value_parser = parse_retention)]
    pub retention: Vec<Retention>,
}

/// A rule for deleting ended jobs (`--retention`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Retention {
    /// Ended longer ago than this.
    Age(std::time::Duration),
    /// Beyond this many of the most recently ended.
    Count(usize),
}

/// `--retention`: a count of jobs (`1000`) or an age (`30d`, `12h`, `90s`).
fn parse_retention(s: &str) -> Result<Retention, String> {
    let s = s.trim();
    if let Ok(n) = s.parse::<usize>() {
        return Ok(Retention::Count(n));
    }
    humantime::parse_duration(s)
        .map(Retention::Age)
        .map_err(|e| format!("{s}: neither a count of jobs nor an age like 30d or 12h ({e})"))
}

/// A size in bytes: a whole number, or a number with a unit (`KB`, `MB`,
/// `GB`, `TB` are powers of 1000; `KiB`, `MiB`, `GiB`, `TiB` of 1024).
pub fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !(c.is_ascii_digit() || c == '.'))
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let number: f64 = number
        .parse()
        .map_err(|_| format!("{s}: expected a size such as 2GiB, 512MB or 1000000"))?;
    let scale: f64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "kb" => 1e3,
        "mb" => 1e6,
        "gb" => 1e9,
        "tb" => 1e12,
        "kib" => 1024.0,
        "mib" => 1024.0 * 1024.0,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        "tib" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        other => return Err(format!("{s}: unknown unit {other:?}")),
    };
    let bytes = number * scale;
    if bytes.is_finite() && bytes >= 0.0 && bytes < u64::MAX as f64 {
        Ok(bytes.round() as u64)
    } else {
        Err(format!("{s}: out of range"))
    }
}

/// `drapery bench ...`.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Work against precision: error against a reference solution for a
    /// sweep of time steps and a sweep of CG tolerances, with the Pareto
    /// front and the observed order of accuracy.
    Precision(PrecisionArgs),
    /// The stability stress suite: cases built to break the solver, each
    /// checked for finite numbers, bounded stretch, no penetration and
    /// bounded CG iterations; exits 1 if any fails.
    Stress(StressArgs),
    /// Cost against cloth size: a sphere drape at growing grids, with the
    /// fitted growth exponent of time per step.
    Scale(ScaleArgs),
}

/// `drapery bench scale`.
#[derive(Debug, Args)]
pub struct ScaleArgs {
    /// Output directory for `scale.csv` and `scale.svg`.
    #[arg(long)]
    pub out: PathBuf,
    /// Grid sizes `n` (the cloth is `n` x `n`), ascending.
    #[arg(long, value_delimiter = ',', default_value = "30,60,100,200,300")]
    pub sizes: Vec<u32>,
    /// Simulated seconds per size (the drape meets the sphere at ~0.2 s).
    #[arg(long, default_value_t = 0.5)]
    pub duration: f64,
    /// Scene to scale (its grid is replaced); default: the sphere drape.
    #[arg(long)]
    pub spec: Option<PathBuf>,
    /// Preconditioners to compare, each at every size and thread count.
    #[arg(long, value_delimiter = ',', default_value = "lines,multigrid")]
    pub preconditioners: Vec<drapery_sim::spec::PreconditionerKind>,
    /// Thread counts to compare (each run in a pool of that size).
    #[arg(long, value_delimiter = ',', default_value = "1,2", value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub threads: Vec<u16>,
}

/// `drapery bench precision`.
#[derive(Debug, Args)]
pub struct PrecisionArgs {
    /// The scene (JSON); its `solver.dt` and `solver.tolerance` are swept.
    pub spec: PathBuf,
    /// Output directory for `precision.csv`, `precision.svg` and the
    /// reference (`reference.bin`).
    #[arg(long)]
    pub out: PathBuf,
    /// Reuse the reference written by an earlier study of the same scene
    /// (its `reference.bin`) instead of computing it.
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Runs per point; the median wall time is reported.
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Largest step of the time-step sweep, seconds (`1/30` or `0.0333`).
    #[arg(long, default_value = "1/30", value_parser = parse_seconds)]
    pub dt_max: f64,
    /// Halvings of the step after `--dt-max` (6: 1/30 ... 1/1920).
    #[arg(long, default_value_t = 6)]
    pub halvings: u32,
    /// Step of the reference; default: the smallest swept step / 8.
    #[arg(long, value_parser = parse_seconds)]
    pub reference_dt: Option<f64>,
    /// CG tolerance of the reference and of the time-step sweep.
    #[arg(long, default_value_t = 1e-10)]
    pub tight_tolerance: f64,
    /// CG tolerances of the tolerance sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1e-2,1e-3,1e-4,1e-5,1e-6,1e-7,1e-8"
    )]
    pub tolerances: Vec<f64>,
    /// Step of the tolerance sweep; default: the scene's `solver.dt`.
    #[arg(long, value_parser = parse_seconds)]
    pub tolerance_dt: Option<f64>,
    /// Integrators of the time-step and adaptive sweeps, each a front of
    /// its own (the reference is BDF2; the tolerance sweep uses the
    /// scene's integrator).
    #[arg(long, value_delimiter = ',', default_value = "euler,bdf2")]
    pub integrators: Vec<drapery_sim::spec::IntegratorKind>,
    /// Position errors per frame (metres) of the adaptive sweep, each run
    /// with `dt: "adaptive"` and that `solver.error`; `--errors` with no
    /// value skips the sweep.
    #[arg(
        long,
        value_delimiter = ',',
        num_args = 0..,
        default_value = "1e-2,3e-3,1e-3,3e-4,1e-4"
    )]
    pub errors: Vec<f64>,
    /// Simulated seconds; default: the scene's `duration`.
    #[arg(long)]
    pub duration: Option<f64>,
}

/// `drapery bench stress`.
#[derive(Debug, Args)]
pub struct StressArgs {
    /// Output directory for `stress.csv`.
    #[arg(long)]
    pub out: PathBuf,
    /// Cloth resolution of the cases (`n` x `n` particles).
    #[arg(long, default_value_t = 30)]
    pub size: u32,
    /// Run only the cases whose name contains one of these.
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Run every case with this integrator (default: each case's own,
    /// backward Euler).
    #[arg(long)]
    pub integrator: Option<drapery_sim::spec::IntegratorKind>,
}

/// A duration in seconds, as a decimal (`0.004`) or a fraction (`1/240`).
fn parse_seconds(s: &str) -> Result<f64, String> {
    let v = match s.split_once('/') {
        Some((a, b)) => {
            let a: f64 = a.trim().parse().map_err(|e| format!("{a}: {e}"))?;
            let b: f64 = b.trim().parse().map_err(|e| format!("{b}: {e}"))?;
            a / b
        }
        None => s.trim().parse().map_err(|e| format!("{s}: {e}"))?,
    };
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{s}: must be a positive number of seconds"))
    }
}

#[cfg(test)]
mod tests {
    use super::{Retention, parse_bytes, parse_retention, parse_seconds};

    #[test]
    fn sizes_parse_with_decimal_and_binary_units() {
        assert_eq!(parse_bytes("1000"), Ok(1000));
        assert_eq!(parse_bytes("2GiB"), Ok(2 << 30));
        assert_eq!(parse_bytes("1.5 MB"), Ok(1_500_000));
        assert_eq!(parse_bytes("512mib"), Ok(512 << 20));
        assert!(parse_bytes("lots").is_err());
        assert!(parse_bytes("3 parsecs").is_err());
    }

    #[test]
    fn retention_is_a_count_or_an_age() {
        assert_eq!(parse_retention("1000"), Ok(Retention::Count(1000)));
        assert_eq!(
            parse_retention("12h"),
            Ok(Retention::Age(std::time::Duration::from_secs(12 * 3600)))
        );
        assert!(parse_retention("soon").is_err());
    }

    #[test]
    fn seconds_parse_as_decimals_or_fractions() {
        assert_eq!(parse_seconds("1/240"), Ok(1.0 / 240.0));
        assert_eq!(parse_seconds("0.004"), Ok(0.004));
        assert!(parse_seconds("1/0").is_err());
        assert!(parse_seconds("-1").is_err());
        assert!(parse_seconds("x/3").is_err());
    }
}
