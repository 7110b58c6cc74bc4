//! Cholesky factorisation of a small symmetric banded matrix, for the line
//! solves of [`super::AlternatingLines`].

/// `L Lᵀ` of an SPD matrix of half-bandwidth `P`, stored by rows:
/// `band[i][k]` is entry `(i, i - k)`.
#[derive(Debug, Clone, Default)]
pub struct BandedCholesky<const P: usize> {
    band: Vec<[f64; P]>,
    diag: Vec<f64>,
}

impl<const P: usize> BandedCholesky<P> {
    /// Sets the matrix to zero with `n` rows, keeping storage.
    pub fn reset(&mut self, n: usize) {
        self.band.clear();
        self.band.resize(n, [0.0; P]);
        self.diag.clear();
        self.diag.resize(n, 0.0);
    }

    /// Adds `x` to entry `(i, j)`, `j <= i`, `i - j <= P`.
    #[inline]
    pub fn add(&mut self, i: usize, j: usize, x: f64) {
        if i == j {
            self.diag[i] += x;
        } else {
            self.band[i][i - j - 1] += x;
        }
    }

    /// Factorises in place. A non-positive pivot (the matrix is not SPD to
    /// working precision) is replaced by the row's diagonal magnitude, which
    /// keeps the preconditioner SPD at the cost of accuracy in that row.
    pub fn factor(&mut self) {
        let n = self.diag.len();
        for i in 0..n {
            let lo = i.saturating_sub(P);
            for k in lo..i {
                let mut s = self.band[i][i - k - 1];
                for m in i.saturating_sub(P).max(k.saturating_sub(P))..k {
                    s -= self.band[i][i - m - 1] * self.band[k][k - m - 1];
                }
                self.band[i][i - k - 1] = s / self.diag[k];
            }
            let original = self.diag[i];
            let mut d = original;
            for m in lo..i {
                let l = self.band[i][i - m - 1];
                d -= l * l;
            }
            self.diag[i] = if d > 1e-12 * original.abs() && d > 0.0 {
                d.sqrt()
            } else {
                original.abs().max(f64::MIN_POSITIVE).sqrt()
            };
        }
    }

    /// Solves `L Lᵀ x = b` in place.
    pub fn solve(&self, x: &mut [f64]) {
        let n = self.diag.len();
        for i in 0..n {
            let mut s = x[i];
            for m in i.saturating_sub(P)..i {
                s -= self.band[i][i - m - 1] * x[m];
            }
            x[i] = s / self.diag[i];
        }
        for i in (0..n).rev() {
            x[i] /= self.diag[i];
            let xi = x[i];
            for m in i.saturating_sub(P)..i {
                x[m] -= self.band[i][i - m - 1] * xi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_a_banded_spd_system_exactly() {
        // Tridiagonal-plus: A = 4 I - (shift 1) - 0.5 (shift 2), SPD.
        let n = 12;
        let mut c = BandedCholesky::<2>::default();
        c.reset(n);
        let mut dense = vec![vec![0.0; n]; n];
        for i in 0..n {
            c.add(i, i, 4.0);
            dense[i][i] = 4.0;
            if i >= 1 {
                c.add(i, i - 1, -1.0);
                dense[i][i - 1] = -1.0;
                dense[i - 1][i] = -1.0;
            }
            if i >= 2 {
                c.add(i, i - 2, -0.5);
                dense[i][i - 2] = -0.5;
                dense[i - 2][i] = -0.5;
            }
        }
        c.factor();
        let b: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut x = b.clone();
        c.solve(&mut x);
        for i in 0..n {
            let ax: f64 = (0..n).map(|j| dense[i][j] * x[j]).sum();
            assert!((ax - b[i]).abs() < 1e-13, "row {i}: {ax} vs {}", b[i]);
        }
    }
}
