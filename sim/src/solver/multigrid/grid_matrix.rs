//! A block matrix on a structured `nu x nv` grid, stored as a stencil: for
//! every node, one 3x3 block per coupling offset `(di, dj)`. This is the
//! shape of every level of the multigrid hierarchy: the finest is the
//! cloth's own grid (stretch, shear and bend couple nodes at most two apart
//! along a line and one apart diagonally), and a Galerkin product of a
//! stencil with bilinear transfers is again a stencil.
//!
//! Single precision: the hierarchy only preconditions (MPCG filters its
//! output and measures convergence in f64), and f32 halves the memory
//! traffic of every sweep.

use crate::math::{Mat3, Vec3};
use crate::parallel;
use crate::solver::{BlockCsr, Filter};

/// A 3x3 block in single precision.
pub type Block = nalgebra::Matrix3<f32>;
/// A 3-vector in single precision.
pub type Vec3f = nalgebra::Vector3<f32>;

/// Largest offset along either axis a stencil may hold.
pub const REACH: i32 = 2;
const SIDE: usize = (2 * REACH + 1) as usize;

/// A structured block matrix.
#[derive(Debug, Clone, Default)]
pub struct GridMatrix {
    /// Nodes along `u` (index `i`, fastest).
    pub nu: usize,
    /// Nodes along `v`.
    pub nv: usize,
    /// Coupling offsets `(di, dj)`, sorted by `(dj, di)`; `(0, 0)` is one.
    offsets: Vec<(i32, i32)>,
    /// Position of each offset in `offsets`, by `(dj + 2) * 5 + di + 2`.
    slot: [Option<u8>; SIDE * SIDE],
    /// `values[node * offsets.len() + k]`: the block coupling `node` to
    /// `node + offsets[k]` (zero where that neighbour does not exist).
    values: Vec<Block>,
    /// For each slot of the cloth matrix last given to
    /// [`Self::set_prefiltered`], where its block goes in `values`
    /// ([`NOWHERE`] for an offset the stencil lacks): the pattern is fixed,
    /// so the grid arithmetic is done once.
    from_csr: Vec<u32>,
    /// Per node, whether `from_csr` fills every one of its blocks (so
    /// [`Self::set_prefiltered`] need not zero its row first).
    filled: Vec<bool>,
}

/// A slot with no place in the stencil.
const NOWHERE: u32 = u32::MAX;

impl GridMatrix {
    /// A zero matrix on an `nu x nv` grid with couplings at `offsets`
    /// (each within [`REACH`]; the diagonal is added if missing).
    pub fn new(nu: usize, nv: usize, offsets: impl IntoIterator<Item = (i32, i32)>) -> Self {
        let mut offsets: Vec<(i32, i32)> = offsets.into_iter().chain([(0, 0)]).collect();
        offsets.sort_by_key(|&(di, dj)| (dj, di));
        offsets.dedup();
        let mut slot = [None; SIDE * SIDE];
        for (k, &(di, dj)) in offsets.iter().enumerate() {
            assert!(
                di.abs() <= REACH && dj.abs() <= REACH,
                "offset beyond reach"
            );
            slot[key(di, dj)] = Some(k as u8);
        }
        Self {
            values: vec![Block::zeros(); nu * nv * offsets.len()],
            nu,
            nv,
            offsets,
            slot,
            from_csr: Vec::new(),
            filled: Vec::new(),
        }
    }

    /// The coupling offsets of the cloth matrix `a` on an `nu x nv` grid.
    pub fn offsets_of(a: &BlockCsr, nu: usize) -> Vec<(i32, i32)> {
        let mut seen = [false; SIDE * SIDE];
        for p in 0..a.rows() {
            for (q, _) in a.row(p) {
                let (di, dj) = offset(p, q, nu);
                seen[key(di, dj)] = true;
            }
        }
        let mut out = Vec::new();
        for dj in -REACH..=REACH {
            for di in -REACH..=REACH {
                if seen[key(di, dj)] {
                    out.push((di, dj));
                }
            }
        }
        out
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nu * self.nv
    }

    /// `true` for an empty grid.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The coupling offsets.
    pub fn offsets(&self) -> &[(i32, i32)] {
        &self.offsets
    }

    /// The index of offset `(di, dj)`, if the stencil has it.
    #[inline]
    pub fn offset_index(&self, di: i32, dj: i32) -> Option<usize> {
        if di.abs() > REACH || dj.abs() > REACH {
            return None;
        }
        self.slot[key(di, dj)].map(usize::from)
    }

    /// The blocks of node `p`, one per offset.
    #[inline]
    pub fn row(&self, p: usize) -> &[Block] {
        let k = self.offsets.len();
        &self.values[p * k..(p + 1) * k]
    }

    /// The blocks of node `p`, to write.
    #[inline]
    pub fn row_mut(&mut self, p: usize) -> &mut [Block] {
        let k = self.offsets.len();
        &mut self.values[p * k..(p + 1) * k]
    }

    /// The neighbour of node `(i, j)` at offset `k`, if it is on the grid.
    #[inline]
    pub fn neighbour(&self, i: usize, j: usize, k: usize) -> Option<usize> {
        let (di, dj) = self.offsets[k];
        let (ii, jj) = (i as i32 + di, j as i32 + dj);
        (ii >= 0 && jj >= 0 && (ii as usize) < self.nu && (jj as usize) < self.nv)
            .then(|| ii as usize + jj as usize * self.nu)
    }

    /// Every block, node by node.
    pub fn values(&self) -> &[Block] {
        &self.values
    }

    /// Every block, node by node, to write.
    pub fn values_mut(&mut self) -> &mut [Block] {
        &mut self.values
    }

    /// Sets every block to zero.
    pub fn clear(&mut self) {
        self.values.fill(Block::zeros());
    }

    /// Rewrites this matrix (built by [`Self::new`] with
    /// [`Self::offsets_of`]`(a)`) as the prefiltered operator of
    /// Tamstorf, Jones & McCormick (2015): `S A S + (I - S) d`, with `d` a
    /// third of the diagonal block's trace. On the free directions it is
    /// the filtered system MPCG solves; the blocked directions decouple,
    /// held invertible at the matrix's own scale.
    pub fn set_prefiltered(&mut self, a: &BlockCsr, filter: &[Filter]) {
        let k = self.offsets.len();
        if self.from_csr.len() != a.nnz() {
            self.from_csr = self.places_of(a);
            // A row's columns are distinct, and so are their offsets: a
            // row is filled when `k` of its slots have a place.
            self.filled = (0..a.rows())
                .map(|p| {
                    a.row_slots(p)
                        .filter(|&s| self.from_csr[s] != NOWHERE)
                        .count()
                        == k
                })
                .collect();
        }
        // Row `p` owns `values[p k .. (p + 1) k]`: rows on the team.
        let (from_csr, filled) = (&self.from_csr, &self.filled);
        parallel::for_rows(&mut self.values, k, parallel::ROWS_MIN * k, |p, row| {
            if !filled[p] {
                row.fill(Block::zeros());
            }
            // PERF: `S_p A_pq S_q` with the identity factors of free
            // particles left out (one product, or none, instead of two),
            // and `S_p` made once a row.
            let sp = (filter[p] != Filter::Free).then(|| filter[p].matrix());
            for s in a.row_slots(p) {
                let at = from_csr[s];
                if at == NOWHERE {
                    continue;
                }
                let (q, block) = (a.column(s), &a.values[s]);
                let sq = (filter[q] != Filter::Free).then(|| filter[q].matrix());
                let m: Mat3 = match (&sp, &sq) {
                    (None, None) => *block,
                    (None, Some(sq)) => block * sq,
                    (Some(sp), None) => sp * block,
                    (Some(sp), Some(sq)) => {
                        let mut m = sp * block * sq;
                        if p == q {
                            let scale = (block.trace().abs() / 3.0).max(f64::MIN_POSITIVE);
                            m += (Mat3::identity() - sp) * scale;
                        }
                        m
                    }
                };
                row[at as usize - p * k] = m.cast::<f32>();
            }
        });
    }

    /// Where each slot of `a` goes in `values` ([`NOWHERE`] if its offset
    /// is not in the stencil).
    fn places_of(&self, a: &BlockCsr) -> Vec<u32> {
        let k = self.offsets.len();
        (0..a.rows())
            .flat_map(|p| {
                a.row_slots(p).map(move |s| {
                    let (di, dj) = offset(p, a.column(s), self.nu);
                    self.offset_index(di, dj)
                        .map_or(NOWHERE, |o| (p * k + o) as u32)
                })
            })
            .collect()
    }

    /// `y = A x`.
    pub fn mul(&self, x: &[Vec3f], y: &mut [Vec3f]) {
        parallel::for_chunks_min(y, parallel::ROWS_MIN, |start, chunk| {
            for (k, out) in chunk.iter_mut().enumerate() {
                let p = start + k;
                *out = self.row_product(p % self.nu, p / self.nu, x);
            }
        });
    }

    /// `r = b - A x`.
    pub fn residual(&self, b: &[Vec3f], x: &[Vec3f], r: &mut [Vec3f]) {
        parallel::for_chunks_min(r, parallel::ROWS_MIN, |start, chunk| {
            for (k, out) in chunk.iter_mut().enumerate() {
                let p = start + k;
                *out = b[p] - self.row_product(p % self.nu, p / self.nu, x);
            }
        });
    }

    /// `(A x)` at node `(i, j)`.
    #[inline]
    pub fn row_product(&self, i: usize, j: usize, x: &[Vec3f]) -> Vec3f {
        let p = i + j * self.nu;
        let row = self.row(p);
        let mut acc = Vec3f::zeros();
        for (k, block) in row.iter().enumerate() {
            if let Some(q) = self.neighbour(i, j, k) {
                acc += block * x[q];
            }
        }
        acc
    }

    /// The block coupling node `p` to node `q`, zero if not stored.
    pub fn block(&self, p: usize, q: usize) -> Block {
        let (di, dj) = offset(p, q, self.nu);
        self.offset_index(di, dj)
            .map_or(Block::zeros(), |k| self.row(p)[k])
    }
}

/// `(di, dj)` from node `p` to node `q` on a grid `nu` wide.
#[inline]
fn offset(p: usize, q: usize, nu: usize) -> (i32, i32) {
    let (pi, pj) = ((p % nu) as i32, (p / nu) as i32);
    let (qi, qj) = ((q % nu) as i32, (q / nu) as i32);
    (qi - pi, qj - pj)
}

#[inline]
fn key(di: i32, dj: i32) -> usize {
    ((dj + REACH) * SIDE as i32 + di + REACH) as usize
}

/// A double-precision vector in single precision.
#[inline]
pub fn to_f32(v: &Vec3) -> Vec3f {
    v.cast::<f32>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::fdcheck::random_configuration;

    /// The structured copy of a real cloth matrix multiplies like the
    /// sparse original (to single precision), and prefiltering keeps the
    /// free part and decouples blocked directions.
    #[test]
    fn structured_copy_matches_the_sparse_matrix() {
        let (grid, x, v) = random_configuration(9, 7, 0.2, 3);
        let y = vec![Vec3::zeros(); grid.len()];
        let (_, sys) = crate::testing::cotton_system(&grid, &x, &v, &y, 1.0 / 60.0);
        let offsets = GridMatrix::offsets_of(&sys.a, grid.nu);
        assert_eq!(offsets.len(), 13, "{offsets:?}");
        let mut g = GridMatrix::new(grid.nu, grid.nv, offsets);
        let free = vec![Filter::Free; grid.len()];
        g.set_prefiltered(&sys.a, &free);
        let xs: Vec<Vec3> = (0..grid.len())
            .map(|k| Vec3::new((k as f64).sin(), (k as f64 * 0.7).cos(), 0.3))
            .collect();
        let mut exact = vec![Vec3::zeros(); grid.len()];
        sys.a.mul(&xs, &mut exact);
        let xf: Vec<Vec3f> = xs.iter().map(to_f32).collect();
        let mut got = vec![Vec3f::zeros(); grid.len()];
        g.mul(&xf, &mut got);
        let scale = exact.iter().map(|e| e.norm()).fold(0.0, f64::max);
        for (e, g) in exact.iter().zip(&got) {
            assert!((e - g.cast::<f64>()).norm() < 1e-5 * scale);
        }

        let mut filters = free;
        filters[5] = Filter::Fixed;
        filters[6] = Filter::Plane(Vec3::z());
        g.set_prefiltered(&sys.a, &filters);
        // The fixed particle couples to nothing off the diagonal.
        for k in 0..g.offsets().len() {
            if g.offsets()[k] != (0, 0) {
                assert_eq!(g.row(5)[k], Block::zeros());
            }
        }
        assert!(g.block(6, 7).row(2).iter().all(|c| *c == 0.0));
        assert!(g.block(7, 6).column(2).iter().all(|c| *c == 0.0));
    }
}
