//! Preconditioners for the modified PCG (method.md §2).
//!
//! The trait is the seam for better preconditioners (the linear solve is
//! where the time goes): `update` sees the assembled matrix once per step,
//! `apply` runs once per CG iteration. The MPCG filters the output, so a
//! preconditioner need not know about constraints.

use super::bsr::BlockCsr;
use crate::math::{Mat3, Vec3};
use crate::spec::PreconditionerKind;

/// `out ≈ A⁻¹ r` for a symmetric positive definite `A`.
pub trait Preconditioner: Send + std::fmt::Debug {
    /// A short name for reports.
    fn name(&self) -> &'static str;
    /// Rebuilds from the newly assembled matrix.
    fn update(&mut self, a: &BlockCsr);
    /// Applies the (symmetric positive definite) approximate inverse.
    fn apply(&self, r: &[Vec3], out: &mut [Vec3]);
}

/// The preconditioner a spec asks for.
pub fn make_preconditioner(kind: PreconditionerKind) -> Box<dyn Preconditioner> {
    match kind {
        PreconditionerKind::Jacobi => Box::<Jacobi>::default(),
        PreconditionerKind::BlockJacobi => Box::<BlockJacobi>::default(),
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

    fn update(&mut self, a: &BlockCsr) {
        self.inv.clear();
        self.inv.extend((0..a.rows()).map(|i| {
            let d = a.diag_block(i).diagonal();
            d.map(|x| if x > 0.0 { 1.0 / x } else { 1.0 })
        }));
    }

    fn apply(&self, r: &[Vec3], out: &mut [Vec3]) {
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

    fn update(&mut self, a: &BlockCsr) {
        self.inv.clear();
        self.inv.extend((0..a.rows()).map(|i| {
            let d = a.diag_block(i);
            // NOTE: A's diagonal blocks are SPD (mass plus PSD terms); the
            // scalar fallback only guards against a singular block.
            d.try_inverse().unwrap_or_else(|| {
                Mat3::from_diagonal(&d.diagonal().map(|x| if x > 0.0 { 1.0 / x } else { 1.0 }))
            })
        }));
    }

    fn apply(&self, r: &[Vec3], out: &mut [Vec3]) {
        for ((o, r), m) in out.iter_mut().zip(r).zip(&self.inv) {
            *o = m * r;
        }
    }
}
