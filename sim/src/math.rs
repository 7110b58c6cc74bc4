//! Scalar and vector types, named once for the whole core.
//!
//! `Real = f64`: cloth stiffness spans ~10 orders of magnitude (stretch vs.
//! bend), and the free-fall and oscillator tests compare against closed forms
//! to round-off, which single precision cannot reach.

/// The scalar type of every computation in the core.
pub type Real = f64;
/// A point or vector in 3-space.
pub type Vec3 = nalgebra::Vector3<Real>;
/// A 3x3 block: one particle-pair entry of a Jacobian or system matrix.
pub type Mat3 = nalgebra::Matrix3<Real>;

/// Outer product `a bᵀ`.
#[inline]
pub fn outer(a: &Vec3, b: &Vec3) -> Mat3 {
    a * b.transpose()
}

/// `true` when every component is finite.
#[inline]
pub fn is_finite(v: &Vec3) -> bool {
    v.iter().all(|c| c.is_finite())
}
