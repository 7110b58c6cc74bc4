//! Preconditioners for the modified PCG (method.md §2).
//!
//! The trait is the seam for better preconditioners (the linear solve is
//! where the time goes): `update` sees the assembled matrix once per step,
//! `apply` runs once per CG iteration (and may use scratch of its own).
//! The MPCG filters the output, so a preconditioner need not know about
//! constraints.

use super::bsr::BlockCsr;
use super::constraints::{Filter, filter_and_dot};
use crate::math::{Mat3, Real, Vec3};

/// `out ≈ A⁻¹ r` for a symmetric positive definite `A`.
pub trait Preconditioner: Send + std::fmt::Debug {
    /// A short name for reports.
    fn name(&self) -> &'static str;
    /// Rebuilds from the newly assembled matrix and this step's filters.
    fn update(&mut self, a: &BlockCsr, filter: &[Filter]);
    /// Applies the (symmetric positive definite) approximate inverse of the
    /// filtered matrix to `r`; `a` and `filter` are the ones of `update`.
    fn apply(&mut self, a: &BlockCsr, filter: &[Filter], r: &[Vec3], out: &mut [Vec3]);
    /// [`Self::apply`], then `out = S out`, returning `rᵀ out`: what each
    /// CG iteration asks. PERF: a preconditioner that ends in a pass over
    /// `out` folds the filter and the product into it (one pass less an
    /// iteration), bit for bit this default's result.
    fn apply_filtered(
        &mut self,
        a: &BlockCsr,
        filter: &[Filter],
        r: &[Vec3],
        out: &mut [Vec3],
    ) -> Real {
        self.apply(a, filter, r, out);
        filter_and_dot(filter, out, r)
    }
}

/// Inverse of the scalar diagonal of `A` (the paper's choice).
#[derive(Debug, Default)]
pub struct Jacobi {
    inv: Vec<Vec3>,
}

impl Preconditioner for Jacobi {
    fn name(&self) -> &'static str {
        "jacobi"
    }

    fn update(&mut self, a: &BlockCsr, _filter: &[Filter]) {
        self.inv.clear();
        self.inv.extend((0..a.rows()).map(|i| {
            let d = a.diag_block(i).diagonal();
            d.map(|x| if x > 0.0 { 1.0 / x } else { 1.0 })
        }));
    }

    fn apply(&mut self, _a: &BlockCsr, _filter: &[Filter], r: &[Vec3], out: &mut [Vec3]) {
        for ((o, r), d) in out.iter_mut().zip(r).zip(&self.inv) {
            *o = r.component_mul(d);
        }
    }
}

/// Inverse of each particle's 3x3 diagonal block: exact for the stiff
/// spring directions meeting at one particle, at the same cost per
/// iteration as Jacobi.
#[derive(Debug, Default)]
pub struct BlockJacobi {
    inv: Vec<Mat3>,
}

impl Preconditioner for BlockJacobi {
    fn name(&self) -> &'static str {
        "block_jacobi"
    }

    fn update(&mut self, a: &BlockCsr, filter: &[Filter]) {
        self.inv.clear();
        self.inv.extend((0..a.rows()).map(|i| {
            // Invert S A_ii S + (I - S) d: exact on the free directions.
            let s = filter[i].matrix();
            let raw = a.diag_block(i);
            let d = s * raw * s + (Mat3::identity() - s) * (raw.trace().abs() / 3.0);
            let d = &d;
            // NOTE: A's diagonal blocks are SPD (mass plus PSD terms); the
            // scalar fallback only guards against a singular block.
            d.try_inverse().unwrap_or_else(|| {
                Mat3::from_diagonal(&d.diagonal().map(|x| if x > 0.0 { 1.0 / x } else { 1.0 }))
            })
        }));
    }

    fn apply(&mut self, _a: &BlockCsr, _filter: &[Filter], r: &[Vec3], out: &mut [Vec3]) {
        for ((o, r), m) in out.iter_mut().zip(r).zip(&self.inv) {
            *o = m * r;
        }
    }
}
