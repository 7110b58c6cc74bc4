//! One simulation run for the studies: its statistics, optionally every
//! frame's positions, and how it ended.

use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, RunStats, SimError, Simulation};
use drapery_sim::spec::{Limits, Scene, Spec};

/// What one run produced.
#[derive(Debug)]
pub struct Outcome {
    /// Statistics of the frames that were finished, `wall_seconds` for the
    /// whole run; `finite: false` if a step produced NaN or infinity.
    pub stats: RunStats,
    /// Positions of every frame (frame 0 first), when asked for.
    pub frames: Vec<Vec<Vec3>>,
    /// Why the run stopped early, if it did.
    pub error: Option<SimError>,
}

/// Peak resident memory of this process so far (`VmHWM`), MiB; `None`
/// where `/proc` does not say.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

/// Reads and parses a spec file (errors name the file and the field);
/// validation comes per run, with each run's settings.
pub fn read_spec(path: &std::path::Path) -> anyhow::Result<Spec> {
    let text = crate::commands::files::read_spec(path)?;
    crate::specfile::parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Validates `spec` under the default limits, naming it in the error.
pub fn scene(spec: &Spec, what: &str) -> anyhow::Result<Scene> {
    spec.validate(&Limits::default())
        .map_err(|e| anyhow::anyhow!("{what}: {e}"))
}

/// Runs `scene` to the end (or its first error), keeping each frame's
/// positions if `capture`.
pub fn simulate(scene: &Scene, capture: bool) -> anyhow::Result<Outcome> {
    let mut sim = Simulation::new(scene)?;
    let mut frames = Vec::new();
    let (stats, result) = sim.run_recorded(&Control::default(), |s, _| {
        if capture {
            frames.push(s.state().x.clone());
        }
        Ok::<(), String>(())
    });
    Ok(Outcome {
        stats,
        frames,
        error: result.err(),
    })
}

/// The median of `values` (the mean of the middle two for an even count).
pub fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => values[n / 2],
        _ => 0.5 * (values[n / 2 - 1] + values[n / 2]),
    }
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&mut []).is_nan());
    }
}
