//! A symmetric block-sparse (3x3 blocks) matrix in compressed-row form.
//!
//! The pattern (which particle pairs interact) depends only on topology, so
//! it is built once; each step only rewrites `values` (STYLE.md 6). Both
//! triangles are stored: the product is then one pass over rows with no
//! scattered writes, which is also what a parallel product needs.

use crate::math::{Mat3, Vec3};

/// Block compressed-row matrix with sorted columns in each row.
#[derive(Debug, Clone, Default)]
pub struct BlockCsr {
    row_ptr: Vec<usize>,
    col: Vec<u32>,
    diag: Vec<usize>,
    /// One 3x3 block per stored entry, in row order.
    pub values: Vec<Mat3>,
}

impl BlockCsr {
    /// A matrix of `n` block rows whose pattern holds the diagonal and every
    /// pair `(i, j)` and `(j, i)` from `pairs`.
    pub fn with_pattern(n: usize, pairs: impl IntoIterator<Item = (usize, usize)>) -> Self {
        let mut rows: Vec<Vec<u32>> = (0..n).map(|i| vec![i as u32]).collect();
        for (i, j) in pairs {
            rows[i].push(j as u32);
            rows[j].push(i as u32);
        }
        let mut row_ptr = Vec::with_capacity(n + 1);
        let mut col = Vec::new();
        let mut diag = Vec::with_capacity(n);
        row_ptr.push(0);
        for (i, r) in rows.iter_mut().enumerate() {
            r.sort_unstable();
            r.dedup();
            let start = col.len();
            let d = r.binary_search(&(i as u32)).unwrap_or(0);
            diag.push(start + d);
            col.extend_from_slice(r);
            row_ptr.push(col.len());
        }
        let nnz = col.len();
        Self {
            row_ptr,
            col,
            diag,
            values: vec![Mat3::zeros(); nnz],
        }
    }

    /// Number of block rows.
    pub fn rows(&self) -> usize {
        self.diag.len()
    }

    /// Number of stored blocks.
    pub fn nnz(&self) -> usize {
        self.col.len()
    }

    /// Position of block `(i, j)` in `values`, if it is in the pattern.
    pub fn slot(&self, i: usize, j: usize) -> Option<usize> {
        let r = &self.col[self.row_ptr[i]..self.row_ptr[i + 1]];
        r.binary_search(&(j as u32))
            .ok()
            .map(|k| self.row_ptr[i] + k)
    }

    /// Position of the diagonal block of row `i`.
    #[inline]
    pub fn diag_slot(&self, i: usize) -> usize {
        self.diag[i]
    }

    /// The diagonal block of row `i`.
    #[inline]
    pub fn diag_block(&self, i: usize) -> &Mat3 {
        &self.values[self.diag[i]]
    }

    /// The positions in `values` of rows `rows`' blocks.
    pub fn slots_of_rows(&self, rows: std::ops::Range<usize>) -> std::ops::Range<usize> {
        self.row_ptr[rows.start]..self.row_ptr[rows.end]
    }

    /// Sets every stored block to zero, keeping the pattern.
    pub fn clear_values(&mut self) {
        self.values.fill(Mat3::zeros());
    }

    /// `y = A x`, rows in parallel chunks (each row's sum in column
    /// order, so the result does not depend on the thread count).
    pub fn mul(&self, x: &[Vec3], y: &mut [Vec3]) {
        crate::parallel::for_chunks_min(y, crate::parallel::ROWS_MIN, |start, chunk| {
            for (k, yi) in chunk.iter_mut().enumerate() {
                let slots = self.row_slots(start + k);
                let mut acc = Vec3::zeros();
                // PERF: the row's blocks and columns zipped, so only the
                // read of `x` is bounds-checked.
                for (m, &j) in self.values[slots.clone()].iter().zip(&self.col[slots]) {
                    acc += m * x[j as usize];
                }
                *yi = acc;
            }
        });
    }

    /// The slots (positions in `values`) of row `i`'s entries.
    #[inline]
    pub fn row_slots(&self, i: usize) -> std::ops::Range<usize> {
        self.row_ptr[i]..self.row_ptr[i + 1]
    }

    /// The column of slot `s`.
    #[inline]
    pub fn column(&self, s: usize) -> usize {
        self.col[s] as usize
    }

    /// The entries of row `i` as `(column, block)`.
    pub fn row(&self, i: usize) -> impl Iterator<Item = (usize, &Mat3)> {
        self.row_slots(i)
            .map(move |s| (self.column(s), &self.values[s]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pattern_is_symmetric_with_diagonal_and_product_matches_dense() {
        let mut a = BlockCsr::with_pattern(4, [(0, 2), (1, 3), (2, 0)]);
        assert_eq!(a.nnz(), 4 + 4);
        for i in 0..4 {
            assert_eq!(a.slot(i, i), Some(a.diag_slot(i)));
        }
        assert!(a.slot(0, 1).is_none());
        let s02 = a.slot(0, 2).expect("in pattern");
        let s20 = a.slot(2, 0).expect("in pattern");
        let m = Mat3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0);
        a.values[s02] = m;
        a.values[s20] = m.transpose();
        for i in 0..4 {
            let d = a.diag_slot(i);
            a.values[d] = Mat3::identity() * (i as f64 + 1.0);
        }
        let x: Vec<Vec3> = (0..4).map(|i| Vec3::new(i as f64, 1.0, -1.0)).collect();
        let mut y = vec![Vec3::zeros(); 4];
        a.mul(&x, &mut y);
        assert_eq!(y[0], x[0] + m * x[2]);
        assert_eq!(y[2], x[2] * 3.0 + m.transpose() * x[0]);
        assert_eq!(y[1], x[1] * 2.0);
    }
}
