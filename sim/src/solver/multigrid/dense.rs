//! The coarsest level's direct solve: a dense Cholesky factorisation (in
//! double precision: the coarsest grid has at most a few dozen nodes).

use super::grid_matrix::{GridMatrix, Vec3f};

/// `A = L Lᵀ` of a small structured matrix.
#[derive(Debug, Clone)]
pub struct DenseCholesky {
    factor: nalgebra::DMatrix<f64>,
}

impl DenseCholesky {
    /// Factors `a`. A matrix that is not SPD to working precision gets its
    /// diagonal raised until it is (a preconditioner must stay SPD).
    pub fn new(a: &GridMatrix) -> Self {
        let n = 3 * a.len();
        let mut m = nalgebra::DMatrix::<f64>::zeros(n, n);
        for j in 0..a.nv {
            for i in 0..a.nu {
                let p = i + j * a.nu;
                for (k, block) in a.row(p).iter().enumerate() {
                    if let Some(q) = a.neighbour(i, j, k) {
                        let b = block.cast::<f64>();
                        m.view_mut((3 * p, 3 * q), (3, 3)).copy_from(&b);
                    }
                }
            }
        }
        // Symmetrise the single-precision round-off.
        let m = (&m + m.transpose()) * 0.5;
        let scale = (0..n)
            .map(|k| m[(k, k)].abs())
            .fold(0.0, f64::max)
            .max(1e-300);
        let mut shift = 0.0;
        loop {
            let shifted = &m + nalgebra::DMatrix::<f64>::identity(n, n) * shift;
            if let Some(c) = shifted.cholesky() {
                return Self { factor: c.unpack() };
            }
            shift = if shift == 0.0 {
                1e-10 * scale
            } else {
                shift * 10.0
            };
        }
    }

    /// `x = A⁻¹ b`.
    pub fn solve(&self, b: &[Vec3f], x: &mut [Vec3f]) {
        let n = self.factor.nrows();
        let mut v = nalgebra::DVector::<f64>::from_iterator(
            n,
            b.iter().flat_map(|p| p.iter().map(|c| f64::from(*c))),
        );
        self.factor.solve_lower_triangular_mut(&mut v);
        self.factor.tr_solve_lower_triangular_mut(&mut v);
        for (k, out) in x.iter_mut().enumerate() {
            *out = Vec3f::new(v[3 * k] as f32, v[3 * k + 1] as f32, v[3 * k + 2] as f32);
        }
    }
}
