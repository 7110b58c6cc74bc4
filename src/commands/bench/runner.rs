//! The studies' glue: spec files in, one run through the shared runner
//! (`drapery_studies::runner`), medians out.

use drapery_sim::spec::{Limits, Scene, Spec};
use drapery_studies::runner::{self, Outcome, RunOptions};

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

/// Runs `scene` from rest to the end (or its first error), keeping each
/// frame's positions if `capture`.
pub fn simulate(scene: &Scene, capture: bool) -> anyhow::Result<Outcome> {
    let options = RunOptions {
        capture,
        ..RunOptions::default()
    };
    Ok(runner::simulate(scene, options)?)
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
