//! Stretch springs, method.md §1 eq. [1]: `E = 1/2 k (l - L)^2` between each
//! particle and its grid neighbours.
//!
//! Resolution independence: a spring along `u` of rest length `L = du`
//! stands for a strip of cloth of width `w` (`dv` inside, `dv/2` on the
//! border). A membrane of tensile stiffness `Y` (N/m, force per width per
//! unit strain) gives that strip the axial stiffness `k = Y w / L`; on a
//! square grid `k = Y` whatever the resolution.
//!
//! PSD treatment (Choi & Ko 2002): the exact Hessian of the spring is
//! `k [û ûᵀ + (1 - L/l)(I - û ûᵀ)]`, indefinite when the spring is shorter
//! than its rest length. In [`JacobianMode::Solver`] the transverse factor
//! is clamped to `max(0, 1 - L/l)`, which drops only the buckling term.

use super::force::{Force, Sink};
use super::grid::Grid;
use crate::math::{Mat3, Real, Vec3, outer};
use crate::spec::JacobianMode;

/// One spring between particles `a` and `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spring {
    /// First particle.
    pub a: usize,
    /// Second particle.
    pub b: usize,
    /// Rest length `L`.
    pub rest: Real,
    /// Axial stiffness `k`, N/m.
    pub k: Real,
}

/// The stretch energy: all grid springs.
#[derive(Debug, Clone, Default)]
pub struct Stretch {
    /// The springs, warp springs first, then weft.
    pub springs: Vec<Spring>,
}

impl Stretch {
    /// Springs between grid neighbours with membrane stiffness `stiffness`.
    pub fn on_grid(grid: &Grid, stiffness: Real) -> Self {
        let (nu, nv, du, dv) = (grid.nu, grid.nv, grid.du, grid.dv);
        let mut springs = Vec::with_capacity(2 * nu * nv);
        for j in 0..nv {
            let width = Grid::edge_share(j, nv) * dv;
            for i in 0..nu - 1 {
                springs.push(Spring {
                    a: grid.index(i, j),
                    b: grid.index(i + 1, j),
                    rest: du,
                    k: stiffness * width / du,
                });
            }
        }
        for j in 0..nv - 1 {
            for i in 0..nu {
                let width = Grid::edge_share(i, nu) * du;
                springs.push(Spring {
                    a: grid.index(i, j),
                    b: grid.index(i, j + 1),
                    rest: dv,
                    k: stiffness * width / dv,
                });
            }
        }
        Self { springs }
    }

    /// Largest `l / L` over all springs: the cloth's worst stretch ratio.
    pub fn max_ratio(&self, x: &[Vec3]) -> Real {
        self.springs
            .iter()
            .map(|s| (x[s.a] - x[s.b]).norm() / s.rest)
            .fold(0.0, Real::max)
    }
}

impl Force for Stretch {
    fn name(&self) -> &'static str {
        "stretch"
    }

    fn energy(&self, x: &[Vec3]) -> Option<Real> {
        Some(
            self.springs
                .iter()
                .map(|s| {
                    let e = (x[s.a] - x[s.b]).norm() - s.rest;
                    0.5 * s.k * e * e
                })
                .sum(),
        )
    }

    fn for_each_element(&self, visit: &mut dyn FnMut(&[usize])) {
        for s in &self.springs {
            visit(&[s.a, s.b]);
        }
    }

    fn element_count(&self) -> usize {
        self.springs.len()
    }

    fn add_element<S: Sink>(
        &self,
        e: usize,
        x: &[Vec3],
        _v: &[Vec3],
        mode: JacobianMode,
        sink: &mut S,
    ) {
        if let Some(p) = self.pair(e, x, mode) {
            let s = &self.springs[e];
            sink.add_pair(e, [s.a, s.b], p.g, Some(&p.h), None);
        }
    }
}

/// One spring evaluated at a configuration: its direction, `g = ∂E/∂d`
/// and the Hessian block `∂²E/∂d²`.
#[derive(Debug, Clone, Copy)]
pub struct SpringPair {
    /// `û`, from `b` to `a`.
    pub u: Vec3,
    /// `k (l - L) û`.
    pub g: Vec3,
    /// `k [û ûᵀ + t (I - û ûᵀ)]`, `t = 1 - L/l` (clamped at 0 for the
    /// solver).
    pub h: Mat3,
}

impl Stretch {
    /// Spring `e` at `x` in `mode`; `None` when its ends coincide (no
    /// direction, no force).
    #[inline]
    pub fn pair(&self, e: usize, x: &[Vec3], mode: JacobianMode) -> Option<SpringPair> {
        let s = &self.springs[e];
        let d = x[s.a] - x[s.b];
        let l = d.norm();
        if l <= Real::EPSILON * s.rest {
            return None;
        }
        let u = d / l;
        let uu = outer(&u, &u);
        let mut transverse = 1.0 - s.rest / l;
        if mode == JacobianMode::Solver {
            transverse = transverse.max(0.0);
        }
        Some(SpringPair {
            u,
            g: u * (s.k * (l - s.rest)),
            h: (uu + (Mat3::identity() - uu) * transverse) * s.k,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::fdcheck;

    #[test]
    fn stretch_force_and_jacobian_match_finite_differences() {
        fdcheck::check_on_random_grids(|g| Stretch::on_grid(g, 2.0e4));
    }

    #[test]
    fn solver_jacobian_is_negative_semidefinite_under_compression() {
        let s = Stretch {
            springs: vec![Spring {
                a: 0,
                b: 1,
                rest: 1.0,
                k: 3.0,
            }],
        };
        let x = [Vec3::zeros(), Vec3::new(0.5, 0.2, 0.0)]; // compressed
        let d = fdcheck::evaluate(&s, &x, &[Vec3::zeros(); 2], JacobianMode::Solver);
        let k = d.dfdx[0][0];
        let eig = k.symmetric_eigenvalues();
        assert!(eig.iter().all(|e| *e <= 1e-12), "{eig:?}");
        let exact = fdcheck::evaluate(&s, &x, &[Vec3::zeros(); 2], JacobianMode::Exact).dfdx[0][0];
        assert!(
            exact.symmetric_eigenvalues().iter().any(|e| *e > 0.1),
            "exact is indefinite"
        );
    }
}
