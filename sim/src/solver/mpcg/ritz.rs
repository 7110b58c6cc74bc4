//! The smallest Ritz value of the preconditioned operator, read from the
//! conjugate gradient's own coefficients.
//!
//! CG is the Lanczos process in disguise (Golub & Van Loan, *Matrix
//! Computations*, §11.3.5; Meurant, *The Lanczos and Conjugate Gradient
//! Algorithms*, 2006, §2.1): with step lengths `α_j` and direction weights
//! `β_j = δ_j / δ_{j-1}`, the symmetric tridiagonal
//!
//! ```text
//! T[0][0] = 1/α_0,  T[j][j] = 1/α_j + β_j/α_{j-1},  T[j-1][j] = √β_j / α_{j-1}
//! ```
//!
//! is the preconditioned operator `P⁻¹A` projected on the Krylov space, so
//! its eigenvalues (Ritz values) lie in that operator's spectrum's hull
//! and the smallest one falls toward `λ_min(P⁻¹A)` as iterations go on,
//! from above. It costs a Sturm-sequence bisection on a vector as long as
//! the iteration count.

use crate::math::Real;

/// The tridiagonal of one solve, grown one iteration at a time.
#[derive(Debug, Clone)]
pub struct Lanczos {
    diag: Vec<Real>,
    /// `off[j]` couples rows `j` and `j + 1`.
    off: Vec<Real>,
    last_alpha: Real,
    /// The smallest Ritz value found so far (the next one is at most it,
    /// by interlacing).
    smallest: Real,
}

/// Bisection steps: the interval shrinks to 2⁻⁴⁰ of itself.
const BISECTIONS: usize = 40;

impl Default for Lanczos {
    fn default() -> Self {
        Self {
            diag: Vec::new(),
            off: Vec::new(),
            last_alpha: 0.0,
            smallest: Real::INFINITY,
        }
    }
}

impl Lanczos {
    /// Forgets the last solve.
    pub fn clear(&mut self) {
        self.diag.clear();
        self.off.clear();
        self.smallest = Real::INFINITY;
    }

    /// Records iteration `j`'s step length `alpha` and the weight `beta`
    /// its direction gave the previous one (ignored at `j = 0`).
    pub fn push(&mut self, alpha: Real, beta: Real) {
        if self.diag.is_empty() {
            self.diag.push(1.0 / alpha);
        } else {
            let prev = self.last_alpha;
            self.diag.push(1.0 / alpha + beta / prev);
            self.off.push(beta.sqrt() / prev);
        }
        self.last_alpha = alpha;
    }

    /// An upper bracket of the smallest eigenvalue, in one pass: the last
    /// one found (interlacing) or the smallest diagonal entry.
    pub fn ceiling(&self) -> Real {
        self.diag.iter().copied().fold(self.smallest, Real::min)
    }

    /// A lower bracket of the smallest eigenvalue of the tridiagonal so
    /// far, within 2⁻⁴⁰ of its smallest diagonal entry (0 before any
    /// iteration or with non-finite coefficients).
    pub fn smallest(&mut self) -> Real {
        if self.diag.is_empty() || !self.diag.iter().chain(&self.off).all(|x| x.is_finite()) {
            return 0.0;
        }
        let (mut lo, mut hi) = (0.0, self.ceiling());
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if self.count_below(mid) > 0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        self.smallest = hi;
        lo
    }

    /// How many eigenvalues lie below `x`: the negative pivots of
    /// `T - x I`'s LDLᵀ factorisation (Sylvester's law of inertia).
    fn count_below(&self, x: Real) -> usize {
        let mut count = 0;
        let mut q = 1.0;
        for (j, d) in self.diag.iter().enumerate() {
            let coupling = if j == 0 {
                0.0
            } else {
                self.off[j - 1] * self.off[j - 1] / q
            };
            q = d - x - coupling;
            if q == 0.0 {
                q = -Real::EPSILON * (d.abs() + x.abs()).max(Real::MIN_POSITIVE);
            }
            if q < 0.0 {
                count += 1;
            }
        }
        count
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;
    use rand::{RngExt, SeedableRng, rngs::StdRng};

    #[test]
    fn the_smallest_ritz_value_matches_a_dense_eigensolve() {
        let mut rng = StdRng::seed_from_u64(5);
        for n in 1..30 {
            let mut t = Lanczos::default();
            for _ in 0..n {
                t.push(rng.random_range(0.01..2.0), rng.random_range(0.0..1.5));
            }
            let dense = DMatrix::from_fn(n, n, |i, j| match i.abs_diff(j) {
                0 => t.diag[i],
                1 => t.off[i.min(j)],
                _ => 0.0,
            });
            let exact = dense.symmetric_eigenvalues().min();
            let got = t.smallest();
            let scale = t.diag.iter().copied().fold(0.0, f64::max);
            assert!(
                got <= exact && exact - got <= 1e-10 * scale,
                "n = {n}: {got} against {exact}"
            );
        }
    }
}
