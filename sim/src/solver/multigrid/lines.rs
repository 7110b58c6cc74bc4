//! Line relaxation: block Gauss–Seidel where a block is a whole grid line.
//!
//! Cloth is strongly anisotropic: stretch along a thread is 10²–10⁶ times
//! stiffer than shear and bending across it, and a warp spring couples
//! particles only along its own line. Point smoothers (Jacobi, Gauss–Seidel)
//! cannot reduce errors that are smooth along a stiff line and rough across
//! it; solving each line exactly can, so alternating warp and weft line
//! relaxation is the smoother that survives the anisotropy (the classic
//! remedy for anisotropic operators, with full coarsening).
//!
//! Each line's block (its nodes, coupled at distance one and two along the
//! line) is factored as a block-pentadiagonal `L Lᵀ` with 3x3 blocks, the
//! inverses of the diagonal factors stored so a solve is only 3x3 products.
//! Lines of one family are relaxed in three colours (line index mod 3):
//! couplings reach two lines across, so the lines of one colour are
//! independent of each other, and a forward sweep (colours 0, 1, 2)
//! followed later by the backward one (2, 1, 0) makes a symmetric
//! smoother.

use super::grid_matrix::{Block, GridMatrix, Vec3f};

/// The lines' direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Lines of fixed `j` along `u` (warp).
    U,
    /// Lines of fixed `i` along `v` (weft).
    V,
}

/// One family of lines with its factors.
#[derive(Debug, Clone)]
pub struct LineFamily {
    direction: Direction,
    /// The stencil's couplings to other lines: `(k, di, dj)`.
    off_line: Vec<(usize, i32, i32)>,
    /// Per node: inverse of the diagonal Cholesky factor, and the factors
    /// coupling it to the previous and the one before on its line.
    inv_diag: Vec<Block>,
    prev1: Vec<Block>,
    prev2: Vec<Block>,
}

/// Scratch of a sweep: one buffer per line, so the lines of a colour can
/// be solved at once.
#[derive(Debug, Clone, Default)]
pub struct LineScratch {
    lines: Vec<Vec3f>,
}

impl LineFamily {
    /// Factors for the lines of `direction` on `a`'s grid.
    pub fn new(direction: Direction, a: &GridMatrix) -> Self {
        let n = a.len();
        let off_line = a
            .offsets()
            .iter()
            .enumerate()
            .filter(|&(_, &(di, dj))| match direction {
                Direction::U => dj != 0,
                Direction::V => di != 0,
            })
            .map(|(k, &(di, dj))| (k, di, dj))
            .collect();
        let mut f = Self {
            direction,
            off_line,
            inv_diag: vec![Block::zeros(); n],
            prev1: vec![Block::zeros(); n],
            prev2: vec![Block::zeros(); n],
        };
        f.factor(a);
        f
    }

    fn step(&self) -> (i32, i32) {
        match self.direction {
            Direction::U => (1, 0),
            Direction::V => (0, 1),
        }
    }

    /// Number of lines and their length on `a`'s grid.
    fn shape(&self, a: &GridMatrix) -> (usize, usize) {
        match self.direction {
            Direction::U => (a.nv, a.nu),
            Direction::V => (a.nu, a.nv),
        }
    }

    /// Node `t` of line `l`.
    #[inline]
    fn node(&self, a: &GridMatrix, l: usize, t: usize) -> usize {
        match self.direction {
            Direction::U => t + l * a.nu,
            Direction::V => l + t * a.nu,
        }
    }

    /// Factors every line of `a`. A pivot that is not positive (the line
    /// block is not SPD to single precision) is replaced by the diagonal's
    /// magnitude, which keeps the smoother SPD at some cost in accuracy.
    pub fn factor(&mut self, a: &GridMatrix) {
        let (sx, sy) = self.step();
        let k1 = a.offset_index(-sx, -sy);
        let k2 = a.offset_index(-2 * sx, -2 * sy);
        let k0 = a.offset_index(0, 0);
        let (lines, len) = self.shape(a);
        for l in 0..lines {
            for t in 0..len {
                let p = self.node(a, l, t);
                let row = a.row(p);
                let get = |k: Option<usize>| k.map_or(Block::zeros(), |k| row[k]);
                let mut l2 = Block::zeros();
                let mut l1 = Block::zeros();
                let mut d = get(k0);
                if t >= 2 {
                    let p2 = self.node(a, l, t - 2);
                    l2 = get(k2) * self.inv_diag[p2].transpose();
                    d -= l2 * l2.transpose();
                }
                if t >= 1 {
                    let p1 = self.node(a, l, t - 1);
                    let mut m = get(k1);
                    if t >= 2 {
                        m -= l2 * self.prev1[p1].transpose();
                    }
                    l1 = m * self.inv_diag[p1].transpose();
                    d -= l1 * l1.transpose();
                }
                self.prev1[p] = l1;
                self.prev2[p] = l2;
                self.inv_diag[p] = inverse_cholesky(&d, &get(k0));
            }
        }
    }

    /// One relaxation of every line, colours in order (`forward`) or
    /// reversed: each line's nodes become the exact solution of its block
    /// given the others' current values. The lines of a colour are solved
    /// in parallel (each into its own buffer), then written back.
    pub fn sweep(
        &self,
        a: &GridMatrix,
        b: &[Vec3f],
        x: &mut [Vec3f],
        forward: bool,
        scratch: &mut LineScratch,
    ) {
        let (lines, len) = self.shape(a);
        scratch.lines.resize(lines * len, Vec3f::zeros());
        for c in 0..3 {
            let colour = if forward { c } else { 2 - c };
            let xr: &[Vec3f] = x;
            crate::parallel::for_rows(&mut scratch.lines, len, |l, out| {
                if l % 3 == colour {
                    self.solve_line(a, l, b, xr, out);
                }
            });
            for l in (colour..lines).step_by(3) {
                for t in 0..len {
                    x[self.node(a, l, t)] = scratch.lines[l * len + t];
                }
            }
        }
    }

    /// Solves line `l`'s block for `b` minus its couplings to the other
    /// lines at their values in `x`, into `out`.
    fn solve_line(&self, a: &GridMatrix, l: usize, b: &[Vec3f], x: &[Vec3f], out: &mut [Vec3f]) {
        let len = out.len();
        let (nu, nv) = (a.nu as i32, a.nv as i32);
        for t in 0..len {
            let p = self.node(a, l, t);
            let (i, j) = ((p % a.nu) as i32, (p / a.nu) as i32);
            let row = a.row(p);
            let mut acc = b[p];
            // PERF: away from the border every neighbour exists and its
            // index is a fixed shift; only border nodes check.
            let inside = i >= 2 && j >= 2 && i < nu - 2 && j < nv - 2;
            for &(k, di, dj) in &self.off_line {
                let (qi, qj) = (i + di, j + dj);
                if inside || (qi >= 0 && qj >= 0 && qi < nu && qj < nv) {
                    acc -= row[k] * x[(qi + qj * nu) as usize];
                }
            }
            out[t] = acc;
        }
        // L y = rhs.
        for t in 0..len {
            let p = self.node(a, l, t);
            let mut s = out[t];
            if t >= 1 {
                s -= self.prev1[p] * out[t - 1];
            }
            if t >= 2 {
                s -= self.prev2[p] * out[t - 2];
            }
            out[t] = self.inv_diag[p] * s;
        }
        // Lᵀ x = y.
        for t in (0..len).rev() {
            let p = self.node(a, l, t);
            let mut s = out[t];
            if t + 1 < len {
                s -= self.prev1[self.node(a, l, t + 1)].transpose() * out[t + 1];
            }
            if t + 2 < len {
                s -= self.prev2[self.node(a, l, t + 2)].transpose() * out[t + 2];
            }
            out[t] = self.inv_diag[p].transpose() * s;
        }
    }
}

/// `L⁻¹` for the lower Cholesky factor `L` of `d`; a non-positive pivot
/// falls back to the magnitude of `original`'s diagonal entry.
fn inverse_cholesky(d: &Block, original: &Block) -> Block {
    let mut l = Block::zeros();
    for c in 0..3 {
        let mut s = d[(c, c)];
        for k in 0..c {
            s -= l[(c, k)] * l[(c, k)];
        }
        let floor = 1e-6 * original[(c, c)].abs();
        let pivot = if s > floor && s.is_finite() {
            s
        } else {
            original[(c, c)].abs().max(f32::MIN_POSITIVE)
        };
        l[(c, c)] = pivot.sqrt();
        for r in c + 1..3 {
            let mut s = d[(r, c)];
            for k in 0..c {
                s -= l[(r, k)] * l[(c, k)];
            }
            l[(r, c)] = s / l[(c, c)];
        }
    }
    // Invert the lower triangle.
    let mut inv = Block::zeros();
    for c in 0..3 {
        inv[(c, c)] = 1.0 / l[(c, c)];
        for r in c + 1..3 {
            let mut s = 0.0;
            for k in c..r {
                s -= l[(r, k)] * inv[(k, c)];
            }
            inv[(r, c)] = s / l[(r, r)];
        }
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line family on a grid whose only couplings are along its lines is
    /// an exact solver: one sweep solves `A x = b`.
    #[test]
    fn a_sweep_solves_a_matrix_of_independent_lines() {
        for dir in [Direction::U, Direction::V] {
            let (nu, nv) = (7, 5);
            let offsets: Vec<(i32, i32)> = (-2..=2)
                .map(|d| if dir == Direction::U { (d, 0) } else { (0, d) })
                .collect();
            let mut a = GridMatrix::new(nu, nv, offsets);
            let near = Block::new(-1.0, 0.2, 0.0, 0.2, -0.5, 0.1, 0.0, 0.1, -0.3);
            let far = Block::new(0.1, 0.0, 0.05, 0.0, 0.1, 0.0, 0.05, 0.0, 0.1);
            for j in 0..nv {
                for i in 0..nu {
                    let p = i + j * nu;
                    for k in 0..a.offsets().len() {
                        if a.neighbour(i, j, k).is_none() {
                            continue;
                        }
                        let (di, dj) = a.offsets()[k];
                        a.row_mut(p)[k] = match (di + dj).abs() {
                            0 => Block::from_diagonal(&Vec3f::new(6.0, 5.0, 4.0)),
                            1 => near,
                            _ => far,
                        };
                    }
                }
            }
            let family = LineFamily::new(dir, &a);
            let b: Vec<Vec3f> = (0..nu * nv)
                .map(|k| Vec3f::new(1.0, (k as f32).sin(), -0.5))
                .collect();
            let mut x = vec![Vec3f::zeros(); nu * nv];
            family.sweep(&a, &b, &mut x, true, &mut LineScratch::default());
            let mut r = vec![Vec3f::zeros(); nu * nv];
            a.residual(&b, &x, &mut r);
            let worst = r.iter().map(|v| v.amax()).fold(0.0, f32::max);
            assert!(worst < 1e-5, "{dir:?}: residual {worst}");
        }
    }

    #[test]
    fn inverse_cholesky_inverts_the_factor() {
        let d = Block::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0);
        let inv = inverse_cholesky(&d, &d);
        // (L⁻¹)ᵀ L⁻¹ = D⁻¹, so D (L⁻¹)ᵀ L⁻¹ = I.
        let id = d * inv.transpose() * inv;
        assert!((id - Block::identity()).amax() < 1e-5, "{id}");
    }
}
