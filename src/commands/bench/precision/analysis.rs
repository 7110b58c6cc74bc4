//! What a study concludes from its runs: errors against the reference, the
//! Pareto front, the observed order of accuracy.

use drapery_sim::math::Vec3;

use super::row::{Row, Sweep};
use crate::commands::bench::fit::power_law;

/// Position error of a run against another, over the diagonal.
#[derive(Debug, Clone, PartialEq)]
pub struct Errors {
    /// RMS distance over particles and frames.
    pub rms: f64,
    /// Largest distance of any particle in any frame.
    pub max: f64,
    /// RMS distance of each frame.
    pub per_frame: Vec<f64>,
}

/// Distances between matching particles over the frames both runs have,
/// frame 0 excluded (both start from the same state), each divided by
/// `diagonal`.
pub fn position_error(run: &[Vec<Vec3>], reference: &[Vec<Vec3>], diagonal: f64) -> Errors {
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
pub fn mark_pareto(rows: &mut [Row]) {
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

/// The time-step sweep's finished runs.
fn time_steps(rows: &[Row]) -> impl Iterator<Item = &Row> {
    rows.iter()
        .filter(|r| r.sweep == Sweep::TimeStep && r.error_rms.is_finite())
}

/// Observed order `p` in `error ~ dt^p`: the least-squares slope over the
/// time-step sweep, and the slope between each pair of neighbours.
pub fn orders(rows: &[Row]) -> (Option<f64>, Vec<(f64, f64)>) {
    let pts: Vec<(f64, f64)> = time_steps(rows)
        .filter(|r| r.error_rms > 0.0)
        .map(|r| (r.dt, r.error_rms))
        .collect();
    let pairs = pts
        .windows(2)
        .map(|w| (w[1].0, (w[0].1 / w[1].1).ln() / (w[0].0 / w[1].0).ln()))
        .collect();
    (power_law(&pts).map(|(p, _)| p), pairs)
}

/// The observed order at single frames, at eight times spread over the
/// run: `(time, order)`. Where a problem is smooth it stays near one; where
/// runs settle into different states (a symmetric drape choosing its
/// folds) it falls to zero from the time they part.
pub fn orders_over_time(rows: &[Row], frame_dt: f64) -> Vec<(f64, f64)> {
    let sweep: Vec<&Row> = time_steps(rows).collect();
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

/// The exponent of solver error against tolerance, from the tolerance
/// sweep.
pub fn solver_error_exponent(rows: &[Row]) -> Option<f64> {
    let tol: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.stopping == drapery_sim::spec::StoppingRule::Residual)
        .filter_map(|r| Some((r.tolerance, r.solver_error_rms?)))
        .filter(|(_, e)| *e > 0.0)
        .collect();
    power_law(&tol).map(|(p, _)| p)
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) fn row(sweep: Sweep, dt: f64, wall: f64, err: f64) -> Row {
        Row {
            sweep,
            integrator: drapery_sim::spec::IntegratorKind::Euler,
            stopping: drapery_sim::spec::StoppingRule::Residual,
            dt,
            error_target: None,
            error_estimate: 0.0,
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
            row(Sweep::TimeStep, 0.1, 1.0, 1e-2),
            row(Sweep::TimeStep, 0.05, 2.0, 5e-3),
            row(Sweep::Tolerance, 0.1, 1.5, 2e-2), // slower and worse than the first
            row(Sweep::Tolerance, 0.1, 3.0, 1e-3),
            row(Sweep::TimeStep, 0.025, 4.0, f64::NAN), // failed: never on the front
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
                row(Sweep::TimeStep, dt, 1.0, 3.0 * dt)
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
                let mut r = row(Sweep::TimeStep, dt, 1.0, dt);
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
}
