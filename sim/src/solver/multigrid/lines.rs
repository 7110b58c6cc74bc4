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
use crate::parallel;

/// The lines' direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Lines of fixed `j` along `u` (warp).
    U,
    /// Lines of fixed `i` along `v` (weft).
    V,
}

/// One family of lines with its factors. Everything a sweep reads is
/// stored in line order (node `t` of line `l` at `l * len + t`), so a
/// line's data is contiguous whichever way it runs through the grid.
#[derive(Debug, Clone)]
pub struct LineFamily {
    direction: Direction,
    lines: usize,
    len: usize,
    /// Grid index of each node, in line order.
    nodes: Vec<u32>,
    /// Per node (in line order), its couplings to other lines: `width`
    /// blocks and the grid indices they multiply; a missing neighbour has
    /// a zero block and the node's own index, so the gather has no branch.
    width: usize,
    off_blocks: Vec<Block>,
    off_index: Vec<u32>,
    /// Where each of `off_blocks` is read from in the grid matrix's
    /// values ([`MISSING`] for a neighbour off the grid): fixed by the
    /// grid, so a refactorisation is a gather.
    off_source: Vec<u32>,
    /// Per node (in line order), its Cholesky factors.
    factors: Vec<NodeFactor>,
}

/// A node's part of its line's block-banded Cholesky factor: the inverse
/// of its diagonal factor and the factors coupling it to the previous
/// node and the one before, with their transposes for the backward
/// substitution.
#[derive(Debug, Clone, Copy)]
struct NodeFactor {
    inv: Block,
    prev1: Block,
    prev2: Block,
    inv_t: Block,
    prev1_t: Block,
    prev2_t: Block,
}

impl Default for NodeFactor {
    fn default() -> Self {
        let z = Block::zeros();
        Self {
            inv: z,
            prev1: z,
            prev2: z,
            inv_t: z,
            prev1_t: z,
            prev2_t: z,
        }
    }
}

/// An off-line neighbour outside the grid.
const MISSING: u32 = u32::MAX;

/// Scratch of a sweep: one buffer per line, so the lines of a colour can
/// be solved at once.
#[derive(Debug, Clone, Default)]
pub struct LineScratch {
    lines: Vec<Vec3f>,
}

impl LineFamily {
    /// Factors for the lines of `direction` on `a`'s grid.
    pub fn new(direction: Direction, a: &GridMatrix) -> Self {
        let (lines, len) = match direction {
            Direction::U => (a.nv, a.nu),
            Direction::V => (a.nu, a.nv),
        };
        let n = a.len();
        let nodes: Vec<u32> = (0..lines)
            .flat_map(|l| {
                (0..len).map(move |t| match direction {
                    Direction::U => (t + l * a.nu) as u32,
                    Direction::V => (l + t * a.nu) as u32,
                })
            })
            .collect();
        let off: Vec<usize> = a
            .offsets()
            .iter()
            .enumerate()
            .filter(|&(_, &(di, dj))| !on_line(direction, di, dj))
            .map(|(k, _)| k)
            .collect();
        let width = off.len();
        let stride = a.offsets().len();
        let (mut off_index, mut off_source) = (Vec::with_capacity(n * width), Vec::new());
        for &p in &nodes {
            let p = p as usize;
            let (i, j) = (p % a.nu, p / a.nu);
            for &slot in &off {
                match a.neighbour(i, j, slot) {
                    Some(q) => {
                        off_index.push(q as u32);
                        off_source.push((p * stride + slot) as u32);
                    }
                    None => {
                        off_index.push(p as u32);
                        off_source.push(MISSING);
                    }
                }
            }
        }
        let mut f = Self {
            direction,
            lines,
            len,
            nodes,
            width,
            off_blocks: vec![Block::zeros(); n * width],
            off_index,
            off_source,
            factors: vec![NodeFactor::default(); n],
        };
        f.factor(a);
        f
    }

    /// Copies `a`'s couplings between lines and factors every line. A
    /// pivot that is not positive (the line block is not SPD to single
    /// precision) is replaced by the diagonal's magnitude, which keeps the
    /// smoother SPD at some cost in accuracy.
    pub fn factor(&mut self, a: &GridMatrix) {
        let (dir, len) = (self.direction, self.len);
        let (sx, sy) = match dir {
            Direction::U => (1, 0),
            Direction::V => (0, 1),
        };
        let k1 = a.offset_index(-sx, -sy);
        let k2 = a.offset_index(-2 * sx, -2 * sy);
        let k0 = a.offset_index(0, 0);
        // Couplings to other lines, node by node.
        let values = a.values();
        let source = &self.off_source;
        parallel::for_chunks(&mut self.off_blocks, |start, blocks| {
            for (b, &src) in blocks.iter_mut().zip(&source[start..]) {
                *b = if src == MISSING {
                    Block::zeros()
                } else {
                    values[src as usize]
                };
            }
        });
        // Each line's Cholesky factors, lines in parallel.
        let nodes = &self.nodes;
        let get = |p: usize, k: Option<usize>| k.map_or(Block::zeros(), |k| a.row(p)[k]);
        parallel::for_rows(&mut self.factors, len, |l, line| {
            for t in 0..len {
                let p = nodes[l * len + t] as usize;
                let mut l2 = Block::zeros();
                let mut l1 = Block::zeros();
                let mut d = get(p, k0);
                if t >= 2 {
                    l2 = get(p, k2) * line[t - 2].inv_t;
                    d -= l2 * l2.transpose();
                }
                if t >= 1 {
                    let mut m = get(p, k1);
                    if t >= 2 {
                        m -= l2 * line[t - 1].prev1_t;
                    }
                    l1 = m * line[t - 1].inv_t;
                    d -= l1 * l1.transpose();
                }
                let inv = inverse_cholesky(&d, &get(p, k0));
                line[t] = NodeFactor {
                    inv,
                    prev1: l1,
                    prev2: l2,
                    inv_t: inv.transpose(),
                    prev1_t: l1.transpose(),
                    prev2_t: l2.transpose(),
                };
            }
        });
    }

    /// One relaxation of every line, colours in order (`forward`) or
    /// reversed: each line's nodes become the exact solution of its block
    /// given the others' current values. The lines of a colour are solved
    /// in parallel (each into its own buffer), then written back.
    pub fn sweep(&self, b: &[Vec3f], x: &mut [Vec3f], forward: bool, scratch: &mut LineScratch) {
        let (lines, len) = (self.lines, self.len);
        scratch.lines.resize(lines * len, Vec3f::zeros());
        for c in 0..3 {
            let colour = if forward { c } else { 2 - c };
            let xr: &[Vec3f] = x;
            parallel::for_rows(&mut scratch.lines, len, |l, out| {
                if l % 3 == colour {
                    self.solve_line(l, b, xr, out);
                }
            });
            for l in (colour..lines).step_by(3) {
                let at = l * len;
                for t in 0..len {
                    x[self.nodes[at + t] as usize] = scratch.lines[at + t];
                }
            }
        }
    }

    /// Solves line `l`'s block for `b` minus its couplings to the other
    /// lines at their values in `x`, into `out`.
    #[inline]
    fn solve_line(&self, l: usize, b: &[Vec3f], x: &[Vec3f], out: &mut [Vec3f]) {
        let len = self.len;
        let at = l * len;
        let w = self.width;
        // rhs, then L y = rhs in the same pass.
        for t in 0..len {
            let s = at + t;
            let mut acc = b[self.nodes[s] as usize];
            let blocks = &self.off_blocks[s * w..(s + 1) * w];
            let index = &self.off_index[s * w..(s + 1) * w];
            for (m, &q) in blocks.iter().zip(index) {
                acc -= m * x[q as usize];
            }
            let f = &self.factors[s];
            if t >= 1 {
                acc -= f.prev1 * out[t - 1];
            }
            if t >= 2 {
                acc -= f.prev2 * out[t - 2];
            }
            out[t] = f.inv * acc;
        }
        // Lᵀ x = y.
        for t in (0..len).rev() {
            let s = at + t;
            let mut acc = out[t];
            if t + 1 < len {
                acc -= self.factors[s + 1].prev1_t * out[t + 1];
            }
            if t + 2 < len {
                acc -= self.factors[s + 2].prev2_t * out[t + 2];
            }
            out[t] = self.factors[s].inv_t * acc;
        }
    }
}

/// Whether offset `(di, dj)` stays on a line of `direction`.
fn on_line(direction: Direction, di: i32, dj: i32) -> bool {
    match direction {
        Direction::U => dj == 0,
        Direction::V => di == 0,
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
            family.sweep(&b, &mut x, true, &mut LineScratch::default());
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
