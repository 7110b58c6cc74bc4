//! Grid transfers between multigrid levels: the natural 2:1 coarsening of
//! a structured grid with bilinear interpolation `P`, restriction `Pᵀ`,
//! and the Galerkin coarse operator `Pᵀ A P`.
//!
//! Along one axis a grid of `n > 4` nodes keeps every other node, and its
//! last one: coarse node `c` sits at fine node `min(2c, n - 1)`. A fine
//! node between two coarse ones is their linear blend. An axis of at most
//! four nodes is not coarsened (a strip coarsens along its length only).
//! In 2-D, `P` is the tensor product of the two axes' interpolations.
//!
//! Below the finest level the transfer is filtered (Tamstorf, Jones &
//! McCormick 2015): `P̄ = S P`, so a coarse correction never moves a fine
//! particle along a blocked direction, and the coarse operator
//! `P̄ᵀ Ā P̄ = Pᵀ S A S P` is not stiffened by the placeholder `(I - S) d`
//! of the blocked directions. A filter is `None` for a free particle.

use super::grid_matrix::{Block, GridMatrix, REACH, Vec3f};
use crate::parallel;

/// Interpolation along one axis.
#[derive(Debug, Clone)]
pub struct Axis {
    /// Fine nodes.
    pub fine: usize,
    /// Coarse nodes.
    pub coarse: usize,
    /// The (at most two) coarse parents of each fine node, with weights;
    /// an unused second parent has weight 0.
    pub parents: Vec<[(u32, f32); 2]>,
    /// The fine nodes each coarse node interpolates to, with weights (the
    /// transpose of `parents`, for gathers).
    pub children: Vec<Vec<(u32, f32)>>,
}

impl Axis {
    /// The coarsening of an axis of `n` nodes.
    pub fn new(n: usize) -> Self {
        if n <= 4 {
            return Self::with_parents(
                n,
                n,
                (0..n).map(|i| [(i as u32, 1.0), (i as u32, 0.0)]).collect(),
            );
        }
        let m = n / 2 + 1;
        let pos = |c: usize| (2 * c).min(n - 1);
        let parents = (0..n)
            .map(|i| {
                if i % 2 == 0 || i == n - 1 {
                    let c = if i == n - 1 { m - 1 } else { i / 2 };
                    [(c as u32, 1.0), (c as u32, 0.0)]
                } else {
                    let (a, b) = ((i - 1) / 2, i.div_ceil(2));
                    let (pa, pb) = (pos(a) as f32, pos(b) as f32);
                    let t = (i as f32 - pa) / (pb - pa);
                    [(a as u32, 1.0 - t), (b as u32, t)]
                }
            })
            .collect();
        Self::with_parents(n, m, parents)
    }

    fn with_parents(fine: usize, coarse: usize, parents: Vec<[(u32, f32); 2]>) -> Self {
        let mut children = vec![Vec::new(); coarse];
        for (i, ps) in parents.iter().enumerate() {
            for &(c, w) in ps {
                if w != 0.0 {
                    children[c as usize].push((i as u32, w));
                }
            }
        }
        Self {
            fine,
            coarse,
            parents,
            children,
        }
    }

    /// The fine nodes coarse node `c` interpolates to, with weights.
    #[inline]
    fn kids(&self, c: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        self.children[c].iter().map(|&(i, w)| (i as usize, w))
    }

    /// `true` when this axis does not coarsen.
    pub fn is_identity(&self) -> bool {
        self.coarse == self.fine
    }

    /// The parents of fine node `i` with non-zero weight.
    #[inline]
    fn of(&self, i: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        self.parents[i]
            .iter()
            .filter(|(_, w)| *w != 0.0)
            .map(|&(c, w)| (c as usize, w))
    }
}

/// The transfer between a level and the next coarser one.
#[derive(Debug, Clone)]
pub struct Transfer {
    /// Along `u`.
    pub u: Axis,
    /// Along `v`.
    pub v: Axis,
}

impl Transfer {
    /// The transfer from an `nu x nv` grid, or `None` when neither axis
    /// coarsens (the grid is the coarsest).
    pub fn new(nu: usize, nv: usize) -> Option<Self> {
        let (u, v) = (Axis::new(nu), Axis::new(nv));
        (!(u.is_identity() && v.is_identity())).then_some(Self { u, v })
    }

    /// Coarse nodes.
    pub fn coarse_len(&self) -> usize {
        self.u.coarse * self.v.coarse
    }

    /// `coarse = P̄ᵀ fine`, each coarse node gathering its fine children.
    pub fn restrict(&self, fine: &[Vec3f], filter: &[Option<Block>], coarse: &mut [Vec3f]) {
        let (mu, nu) = (self.u.coarse, self.u.fine);
        parallel::for_chunks(coarse, |start, chunk| {
            for (k, out) in chunk.iter_mut().enumerate() {
                let (c, d) = ((start + k) % mu, (start + k) / mu);
                let mut acc = Vec3f::zeros();
                for (j, wj) in self.v.kids(d) {
                    for (i, wi) in self.u.kids(c) {
                        let p = i + j * nu;
                        acc += filtered(filter, p, fine[p]) * (wi * wj);
                    }
                }
                *out = acc;
            }
        });
    }

    /// `fine += P̄ coarse`, each fine node gathering its coarse parents.
    pub fn prolong_add(&self, coarse: &[Vec3f], filter: &[Option<Block>], fine: &mut [Vec3f]) {
        let (mu, nu) = (self.u.coarse, self.u.fine);
        parallel::for_chunks(fine, |start, chunk| {
            for (k, out) in chunk.iter_mut().enumerate() {
                let p = start + k;
                let (i, j) = (p % nu, p / nu);
                let mut acc = Vec3f::zeros();
                for (d, wd) in self.v.of(j) {
                    for (c, wc) in self.u.of(i) {
                        acc += coarse[c + d * mu] * (wc * wd);
                    }
                }
                *out += filtered(filter, p, acc);
            }
        });
    }

    /// An empty coarse operator with the stencil `Pᵀ A P` has.
    pub fn coarse_matrix(&self, a: &GridMatrix) -> GridMatrix {
        let side = (2 * REACH + 1) as usize;
        let mut seen = vec![false; side * side];
        for row in 0..self.coarse_len() {
            self.for_each_term(a, row, |(dc, dd), _, _, _, _| {
                seen[((dd + REACH) * side as i32 + dc + REACH) as usize] = true;
            });
        }
        let mut offsets = Vec::new();
        for dd in -REACH..=REACH {
            for dc in -REACH..=REACH {
                if seen[((dd + REACH) * side as i32 + dc + REACH) as usize] {
                    offsets.push((dc, dd));
                }
            }
        }
        GridMatrix::new(self.u.coarse, self.v.coarse, offsets)
    }

    /// Writes the Galerkin product `P̄ᵀ a P̄` into `coarse` (made by
    /// [`Self::coarse_matrix`] from a matrix of `a`'s stencil), each
    /// coarse row gathering its own terms.
    pub fn galerkin(&self, a: &GridMatrix, filter: &[Option<Block>], coarse: &mut GridMatrix) {
        let width = coarse.offsets().len();
        let index: Vec<Option<usize>> = (0..(2 * REACH + 1) * (2 * REACH + 1))
            .map(|key| {
                let (dc, dd) = (key % (2 * REACH + 1) - REACH, key / (2 * REACH + 1) - REACH);
                coarse.offset_index(dc, dd)
            })
            .collect();
        parallel::for_rows(coarse.values_mut(), width, parallel::HEAVY_MIN, |r, row| {
            row.fill(Block::zeros());
            self.for_each_term(a, r, |(dc, dd), w, p, q, block| {
                let key = ((dd + REACH) * (2 * REACH + 1) + dc + REACH) as usize;
                let k = index[key].unwrap_or_else(|| unreachable!("the stencil has room"));
                let b = match (
                    filter.get(p).copied().flatten(),
                    filter.get(q).copied().flatten(),
                ) {
                    (None, None) => *block,
                    (sp, sq) => {
                        sp.unwrap_or(Block::identity()) * block * sq.unwrap_or(Block::identity())
                    }
                };
                row[k] += b * w;
            });
        });
    }

    /// Calls `f(coarse_offset, weight, p, q, a_pq)` for every term of row
    /// `row` of `Pᵀ a P`, in a fixed order.
    fn for_each_term(
        &self,
        a: &GridMatrix,
        row: usize,
        mut f: impl FnMut((i32, i32), f32, usize, usize, &Block),
    ) {
        let mu = self.u.coarse;
        let (c, d) = (row % mu, row / mu);
        for (j, wj) in self.v.kids(d) {
            for (i, wi) in self.u.kids(c) {
                let p = i + j * a.nu;
                for (k, block) in a.row(p).iter().enumerate() {
                    let Some(q) = a.neighbour(i, j, k) else {
                        continue;
                    };
                    let (qi, qj) = (q % a.nu, q / a.nu);
                    for (d2, wd2) in self.v.of(qj) {
                        for (c2, wc2) in self.u.of(qi) {
                            let off = (c2 as i32 - c as i32, d2 as i32 - d as i32);
                            f(off, wi * wj * wc2 * wd2, p, q, block);
                        }
                    }
                }
            }
        }
    }
}

/// `S v` at node `p` (`v` for a free node or no filters).
#[inline]
fn filtered(filter: &[Option<Block>], p: usize, v: Vec3f) -> Vec3f {
    match filter.get(p) {
        Some(Some(s)) => s * v,
        _ => v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_keep_every_other_node_and_the_last_and_interpolate_linearly() {
        for n in [5, 6, 7, 30, 31] {
            let a = Axis::new(n);
            assert_eq!(a.coarse, n / 2 + 1);
            // A linear function on the coarse nodes' fine positions is
            // reproduced exactly at every fine node.
            let pos = |c: usize| (2 * c).min(n - 1) as f32;
            for i in 0..n {
                let v: f32 = a.of(i).map(|(c, w)| w * pos(c)).sum();
                let total: f32 = a.of(i).map(|(_, w)| w).sum();
                assert!((v - i as f32).abs() < 1e-5 && (total - 1.0).abs() < 1e-6);
            }
        }
        assert!(Axis::new(4).is_identity());
        assert!(Transfer::new(4, 3).is_none());
    }

    /// `Pᵀ A P` of a symmetric stencil is symmetric, and restriction is the
    /// transpose of prolongation: `<Pᵀ f, c> = <f, P c>`.
    #[test]
    fn galerkin_product_is_symmetric_and_restriction_is_the_adjoint() {
        let (nu, nv) = (9, 6);
        let offsets: Vec<(i32, i32)> = (-1..=1)
            .flat_map(|dj| (-2..=2).map(move |di| (di, dj)))
            .collect();
        let mut a = GridMatrix::new(nu, nv, offsets);
        // A symmetric matrix: block (p, q) = s(p, q) B with s symmetric.
        let b = Block::new(2.0, 0.3, 0.1, 0.3, 1.0, -0.2, 0.1, -0.2, 3.0);
        for j in 0..nv {
            for i in 0..nu {
                let p = i + j * nu;
                for k in 0..a.offsets().len() {
                    if let Some(q) = a.neighbour(i, j, k) {
                        let s = 1.0 / (1.0 + (p + q) as f32 + (p * q) as f32 * 0.01);
                        a.row_mut(p)[k] = b * s;
                    }
                }
            }
        }
        let t = Transfer::new(nu, nv).expect("coarsens");
        let mut c = t.coarse_matrix(&a);
        t.galerkin(&a, &[], &mut c);
        for p in 0..c.len() {
            for q in 0..c.len() {
                let d = c.block(p, q) - c.block(q, p).transpose();
                assert!(d.amax() < 1e-5, "({p}, {q})");
            }
        }
        let f: Vec<Vec3f> = (0..nu * nv)
            .map(|k| Vec3f::new(k as f32, 1.0, (k % 3) as f32))
            .collect();
        let cv: Vec<Vec3f> = (0..t.coarse_len())
            .map(|k| Vec3f::new(1.0, k as f32 * 0.5, -1.0))
            .collect();
        let mut rf = vec![Vec3f::zeros(); t.coarse_len()];
        t.restrict(&f, &[], &mut rf);
        let mut pc = vec![Vec3f::zeros(); nu * nv];
        t.prolong_add(&cv, &[], &mut pc);
        let lhs: f32 = rf.iter().zip(&cv).map(|(a, b)| a.dot(b)).sum();
        let rhs: f32 = f.iter().zip(&pc).map(|(a, b)| a.dot(b)).sum();
        assert!((lhs - rhs).abs() < 1e-3 * lhs.abs());
    }
}
