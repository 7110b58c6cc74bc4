//! `drapery bench stress`: the stress suite (`drapery_studies::stress`)
//! at `--size`, one line per case, `stress.csv`, exit 1 if any case fails.

use std::process::ExitCode;

use anyhow::Context;
use drapery_studies::stress::{self, Outcome};

use super::csvfile::write_csv;
use crate::cli::StressArgs;

/// Runs the suite.
pub fn run(args: &StressArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        (4..=1000).contains(&args.size),
        "--size: between 4 and 1000"
    );
    let mut cases: Vec<_> = stress::cases(args.size)
        .into_iter()
        .filter(|c| args.only.is_empty() || args.only.iter().any(|o| c.name.contains(o.as_str())))
        .collect();
    if let Some(integrator) = args.integrator {
        for case in &mut cases {
            case.spec.solver.integrator = integrator;
        }
    }
    anyhow::ensure!(!cases.is_empty(), "--only: no case matches");
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    // Each case's scene, so a failure can be replayed with `drapery run`
    // (a crumpled start is the one thing a spec cannot hold).
    let specs = args.out.join("specs");
    std::fs::create_dir_all(&specs)?;
    for case in &cases {
        let file = specs.join(format!("{}.json", slug(&case.name)));
        std::fs::write(&file, serde_json::to_string_pretty(&case.spec)?)
            .with_context(|| format!("writing {}", file.display()))?;
    }
    let mut outcomes = Vec::new();
    for case in &cases {
        let o = stress::run(case);
        eprintln!(
            "{} {:<28} stretch {:>6.2} %  min distance {:>9}  CG max {:>4}  {:>7.2} s{}",
            if o.pass() { "pass" } else { "FAIL" },
            o.case,
            100.0 * (o.max_stretch - 1.0),
            o.min_signed_distance
                .map_or("-".into(), |d| format!("{:.2} mm", d * 1e3)),
            o.cg_iterations_max,
            o.wall_seconds,
            if o.pass() {
                String::new()
            } else {
                format!(": {}", o.failures.join("; "))
            }
        );
        outcomes.push(o);
    }
    write_csv(
        &args.out.join("stress.csv"),
        outcomes.iter().map(CsvRow::from),
    )?;
    let failed = outcomes.iter().filter(|o| !o.pass()).count();
    eprintln!(
        "{} of {} cases passed; wrote {}/stress.csv",
        outcomes.len() - failed,
        outcomes.len(),
        args.out.display()
    );
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// `tablecloth-pull 0.5 m/s` -> `tablecloth-pull-0.5-m-s`.
fn slug(name: &str) -> String {
    let mut out = String::new();
    for c in name.chars() {
        if c.is_ascii_alphanumeric() || c == '.' {
            out.push(c);
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    out.trim_matches('-').to_owned()
}

/// A line of `stress.csv`.
#[derive(serde::Serialize)]
struct CsvRow<'a> {
    case: &'a str,
    dt: f64,
    finite: bool,
    max_stretch: f64,
    min_signed_distance: Option<f64>,
    self_crossings: Option<usize>,
    obstacle_crossings: usize,
    cg_iterations_max: usize,
    unconverged_solves: usize,
    wall_seconds: f64,
    pass: bool,
    failures: String,
}

impl<'a> From<&'a Outcome> for CsvRow<'a> {
    fn from(o: &'a Outcome) -> Self {
        Self {
            case: &o.case,
            dt: o.dt,
            finite: o.finite,
            max_stretch: o.max_stretch,
            min_signed_distance: o.min_signed_distance,
            self_crossings: o.self_crossings,
            obstacle_crossings: o.obstacle_crossings,
            cg_iterations_max: o.cg_iterations_max,
            unconverged_solves: o.unconverged_solves,
            wall_seconds: o.wall_seconds,
            pass: o.pass(),
            failures: o.failures.join("; "),
        }
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn case_names_become_file_names() {
        assert_eq!(
            super::slug("tablecloth-pull 0.5 m/s"),
            "tablecloth-pull-0.5-m-s"
        );
        assert_eq!(super::slug("hanging dt 1.00e-4"), "hanging-dt-1.00e-4");
    }
}
