//! The error collector of validation and its checks of single values.

use crate::math::Vec3;
use crate::spec::error::SpecError;

/// Largest coordinate magnitude accepted anywhere, in metres.
pub(super) const MAX_COORD: f64 = 1.0e6;
/// Largest cloth side in metres.
pub(super) const MAX_CLOTH_SIDE: f64 = 1.0e3;
/// Adaptive stepping subdivides a frame at most `2^ADAPTIVE_MAX_LEVEL` times.
pub(super) const ADAPTIVE_MAX_LEVEL: u32 = 12;

/// Collects errors; each check reports and returns whether the value passed.
#[derive(Default)]
pub(super) struct Check {
    pub(super) errors: Vec<SpecError>,
}

impl Check {
    pub(super) fn fail(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.errors.push(SpecError {
            path: path.into(),
            message: message.into(),
        });
    }

    pub(super) fn finite(&mut self, path: &str, x: f64) -> bool {
        if x.is_finite() {
            true
        } else {
            self.fail(path, "must be a finite number");
            false
        }
    }

    /// `lo < x <= hi` (or `lo <= x` when `allow_zero` and `lo == 0`).
    pub(super) fn range(&mut self, path: &str, x: f64, positive: bool, hi: f64) -> bool {
        if !self.finite(path, x) {
            return false;
        }
        if positive && x <= 0.0 {
            self.fail(path, "must be > 0");
            false
        } else if !positive && x < 0.0 {
            self.fail(path, "must be >= 0");
            false
        } else if x > hi {
            self.fail(path, format!("must be <= {hi}"));
            false
        } else {
            true
        }
    }

    pub(super) fn point(&mut self, path: &str, p: [f64; 3]) -> Option<Vec3> {
        let mut ok = true;
        for (k, c) in p.iter().enumerate() {
            let at = format!("{path}[{k}]");
            if self.finite(&at, *c) && c.abs() > MAX_COORD {
                self.fail(at, format!("must be within ±{MAX_COORD} m"));
                ok = false;
            } else if !c.is_finite() {
                ok = false;
            }
        }
        ok.then(|| Vec3::new(p[0], p[1], p[2]))
    }

    pub(super) fn direction(&mut self, path: &str, d: [f64; 3]) -> Option<Vec3> {
        let v = self.point(path, d)?;
        let n = v.norm();
        if n < 1e-12 {
            self.fail(path, "must be a non-zero vector");
            None
        } else {
            Some(v / n)
        }
    }
}
