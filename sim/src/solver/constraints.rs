//! Per-particle constraints of the modified PCG (method.md §2, eqs. [15]-[20]).
//!
//! - `S_i` ([`Filter`]): the projection onto the directions particle `i` may
//!   move in freely: free, blocked along one or two directions, or fixed.
//! - `z_i`: the velocity change the constrained directions must take.
//! - `y_i`: a position correction applied this step through eq. [20], so
//!   neighbours feel it through the springs in the same solve.
//!
//! - an impulse added to `b`: friction forces that are not constraints.
//! - couplings: springs holding a few particles off an obstacle's sharp
//!   feature (`super::coupling`), added to `A` and `b`.
//!
//! Pins and obstacle contacts fill the same arrays.

use super::coupling::Coupling;
use crate::math::{Mat3, Real, Vec3};

/// `v = S v`, returning `uᵀ v` (after the filter) in one pass: bit for
/// bit the filter's pass and then `parallel::dot(u, v)`.
pub fn filter_and_dot(s: &[Filter], v: &mut [Vec3], u: &[Vec3]) -> Real {
    crate::parallel::update_sum(v, |start, chunk| {
        chunk
            .iter_mut()
            .zip(s[start..].iter().zip(&u[start..]))
            .map(|(x, (s, u))| {
                *x = s.apply(x);
                u.dot(x)
            })
            .sum()
    })
}

/// The filter `S_i`: which directions of particle `i` the solve may change.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Filter {
    /// `S = I`.
    #[default]
    Free,
    /// `S = I - n nᵀ`: blocked along the unit normal `n`.
    Plane(Vec3),
    /// `S = d dᵀ`: blocked along two directions, free only along unit `d`.
    Line(Vec3),
    /// `S = 0`.
    Fixed,
}

impl Filter {
    /// A filter blocking the given (not necessarily orthonormal) directions.
    /// Dependent or zero directions are dropped; three independent ones fix
    /// the particle.
    pub fn blocking(dirs: &[Vec3]) -> Filter {
        let mut basis: Vec<Vec3> = Vec::with_capacity(3);
        for d in dirs {
            let mut r = *d;
            for b in &basis {
                r -= b * b.dot(&r);
            }
            let n = r.norm();
            if n > 1e-9 * d.norm().max(Real::MIN_POSITIVE) && n > 0.0 {
                basis.push(r / n);
            }
        }
        match basis.as_slice() {
            [] => Filter::Free,
            [n] => Filter::Plane(*n),
            [p, q] => Filter::Line(p.cross(q).normalize()),
            _ => Filter::Fixed,
        }
    }

    /// `S v`.
    #[inline]
    pub fn apply(&self, v: &Vec3) -> Vec3 {
        match self {
            Filter::Free => *v,
            Filter::Plane(n) => v - n * n.dot(v),
            Filter::Line(d) => d * d.dot(v),
            Filter::Fixed => Vec3::zeros(),
        }
    }

    /// `S` as a matrix.
    pub fn matrix(&self) -> Mat3 {
        match self {
            Filter::Free => Mat3::identity(),
            Filter::Plane(n) => Mat3::identity() - n * n.transpose(),
            Filter::Line(d) => d * d.transpose(),
            Filter::Fixed => Mat3::zeros(),
        }
    }

    /// Number of blocked directions (0 to 3).
    pub fn blocked(&self) -> usize {
        match self {
            Filter::Free => 0,
            Filter::Plane(_) => 1,
            Filter::Line(_) => 2,
            Filter::Fixed => 3,
        }
    }
}

/// `S`, `z` and `y` for every particle.
#[derive(Debug, Clone, Default)]
pub struct Constraints {
    /// Filters `S_i`.
    pub filter: Vec<Filter>,
    /// Targets `z_i` for the constrained directions of `dv`.
    pub z: Vec<Vec3>,
    /// Position corrections `y_i` (eq. [20]).
    pub y: Vec<Vec3>,
    /// Impulses added to `b` this step (kinetic friction).
    pub impulse: Vec<Vec3>,
    /// Springs to obstacles' sharp features (`super::coupling`).
    pub couplings: Vec<Coupling>,
}

impl Constraints {
    /// All `n` particles free, `z = y = 0`.
    pub fn free(n: usize) -> Self {
        Self {
            filter: vec![Filter::Free; n],
            z: vec![Vec3::zeros(); n],
            y: vec![Vec3::zeros(); n],
            impulse: vec![Vec3::zeros(); n],
            couplings: Vec::new(),
        }
    }

    /// Frees every particle and clears `z` and `y`, keeping the storage.
    pub fn clear(&mut self) {
        self.filter.fill(Filter::Free);
        self.z.fill(Vec3::zeros());
        self.y.fill(Vec3::zeros());
        self.impulse.fill(Vec3::zeros());
        self.couplings.clear();
    }

    /// Fixes particle `i`: its `dv` becomes `dv`, its position moves by `y`
    /// beyond `h (v0 + dv)`.
    pub fn fix(&mut self, i: usize, dv: Vec3, y: Vec3) {
        self.filter[i] = Filter::Fixed;
        self.z[i] = dv;
        self.y[i] = y;
    }

    /// `true` when no particle is constrained and no correction is pending.
    pub fn is_free(&self) -> bool {
        self.filter.iter().all(|f| *f == Filter::Free)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filters_project_onto_free_directions() {
        let v = Vec3::new(1.0, 2.0, 3.0);
        let n = Vec3::new(0.0, 0.0, 2.0);
        assert_eq!(Filter::blocking(&[]).apply(&v), v);
        assert_eq!(Filter::blocking(&[n]).apply(&v), Vec3::new(1.0, 2.0, 0.0));
        let line = Filter::blocking(&[n, Vec3::new(1.0, 0.0, 1.0)]);
        assert_eq!(line.blocked(), 2);
        assert!((line.apply(&v) - Vec3::new(0.0, 2.0, 0.0)).norm() < 1e-15);
        let fixed = Filter::blocking(&[Vec3::x(), Vec3::y(), Vec3::z()]);
        assert_eq!(fixed, Filter::Fixed);
        // Dependent directions do not over-constrain.
        assert_eq!(Filter::blocking(&[n, n * 3.0]).blocked(), 1);
        // S is a projection: S S v = S v.
        for f in [Filter::blocking(&[n]), line] {
            let s = f.apply(&v);
            assert!((f.apply(&s) - s).norm() < 1e-14);
        }
    }
}
