//! The block-banded Cholesky factor `A = L Lᵀ` of a line's block (each
//! node coupled to the next two along the line), for a pack of lines side
//! by side in SIMD lanes (`lanes`): every product of the recurrence is
//! one packed instruction per entry, and each lane's numbers are those of
//! the same recurrence on 3x3 blocks alone.
//!
//! ```text
//! L_t,t-2 = A_t,t-2 L_t-2,t-2⁻ᵀ
//! L_t,t-1 = (A_t,t-1 - L_t,t-2 L_t-1,t-2ᵀ) L_t-1,t-1⁻ᵀ
//! L_tt L_ttᵀ = A_tt + E_t - L_t,t-2 L_t,t-2ᵀ - L_t,t-1 L_t,t-1ᵀ
//! ```
//!
//! with `E_t` the block that makes up for couplings the smoother leaves
//! out (`lines`).

use super::lanes::{BlockLanes, LANES, ZERO_BLOCK, mul_bt, sub_mul_bt};

/// A node's part of its line's block-banded Cholesky factor, one lane per
/// line of the pack: the inverse of its diagonal factor and the factors
/// coupling it to the previous node and the one before. The backward
/// substitution multiplies by their transposes, so none are stored twice.
#[derive(Debug, Clone, Copy)]
pub struct NodeFactor {
    /// `L_tt⁻¹`.
    pub inv: BlockLanes,
    /// `L_t,t-1`.
    pub prev1: BlockLanes,
    /// `L_t,t-2`.
    pub prev2: BlockLanes,
}

/// Zero factors, before the first factorisation.
pub const ZERO_FACTOR: NodeFactor = NodeFactor {
    inv: ZERO_BLOCK,
    prev1: ZERO_BLOCK,
    prev2: ZERO_BLOCK,
};

/// A node's blocks of its line, one lane per line: its diagonal block
/// (also the scale of a failed pivot's fallback), the block added to
/// that diagonal, and its couplings to the previous node and the one
/// before (`A_t,t-1`, `A_t,t-2`; not read at the line's start).
#[derive(Debug, Clone, Copy)]
pub struct NodeBlocks {
    /// `A_tt`.
    pub diag: BlockLanes,
    /// `E_t`.
    pub shift: BlockLanes,
    /// `A_t,t-1`.
    pub prev1: BlockLanes,
    /// `A_t,t-2`.
    pub prev2: BlockLanes,
}

/// Factors a pack of lines whose node `t` has blocks `node(t)`, into
/// `factors` (one per node).
pub fn factor(factors: &mut [NodeFactor], node: impl Fn(usize) -> NodeBlocks) {
    // The last two nodes' factors: (inverse, prev1) at t - 1 and the
    // inverse at t - 2.
    let (mut inv1, mut prev1, mut inv2) = (ZERO_BLOCK, ZERO_BLOCK, ZERO_BLOCK);
    for (t, f) in factors.iter_mut().enumerate() {
        let a = node(t);
        let mut d = a.diag;
        for (d, s) in d.iter_mut().zip(&a.shift) {
            for (d, s) in d.iter_mut().zip(s) {
                *d += s;
            }
        }
        let mut l2 = ZERO_BLOCK;
        let mut l1 = ZERO_BLOCK;
        if t >= 2 {
            l2 = mul_bt(&a.prev2, &inv2);
            sub_mul_bt(&mut d, &l2, &l2);
        }
        if t >= 1 {
            let mut m = a.prev1;
            if t >= 2 {
                sub_mul_bt(&mut m, &l2, &prev1);
            }
            l1 = mul_bt(&m, &inv1);
            sub_mul_bt(&mut d, &l1, &l1);
        }
        let inv = inverse_cholesky(&d, &a.diag);
        *f = NodeFactor {
            inv,
            prev1: l1,
            prev2: l2,
        };
        (inv2, inv1, prev1) = (inv1, inv, l1);
    }
}

/// `L⁻¹` for the lower Cholesky factor `L` of `d`, lane by lane; a
/// non-positive pivot falls back to the magnitude of `original`'s
/// diagonal entry.
fn inverse_cholesky(d: &BlockLanes, original: &BlockLanes) -> BlockLanes {
    let at = |r: usize, c: usize| 3 * r + c;
    let mut l = ZERO_BLOCK;
    for c in 0..3 {
        for lane in 0..LANES {
            let mut s = d[at(c, c)][lane];
            for k in 0..c {
                s -= l[at(c, k)][lane] * l[at(c, k)][lane];
            }
            let o = original[at(c, c)][lane].abs();
            let pivot = if s > 1e-6 * o && s.is_finite() {
                s
            } else {
                o.max(f32::MIN_POSITIVE)
            };
            l[at(c, c)][lane] = pivot.sqrt();
        }
        for r in c + 1..3 {
            for lane in 0..LANES {
                let mut s = d[at(r, c)][lane];
                for k in 0..c {
                    s -= l[at(r, k)][lane] * l[at(c, k)][lane];
                }
                l[at(r, c)][lane] = s / l[at(c, c)][lane];
            }
        }
    }
    // Invert the lower triangle.
    let mut inv = ZERO_BLOCK;
    for c in 0..3 {
        for lane in 0..LANES {
            inv[at(c, c)][lane] = 1.0 / l[at(c, c)][lane];
        }
        for r in c + 1..3 {
            for lane in 0..LANES {
                let mut s = 0.0;
                for k in c..r {
                    s -= l[at(r, k)][lane] * inv[at(k, c)][lane];
                }
                inv[at(r, c)][lane] = s / l[at(r, r)][lane];
            }
        }
    }
    inv
}

#[cfg(test)]
mod tests {
    use super::super::grid_matrix::Block;
    use super::super::lanes::set_block;
    use super::*;

    /// In every lane, `(L⁻¹)ᵀ L⁻¹ = D⁻¹`, so `D (L⁻¹)ᵀ L⁻¹ = I`; a lane
    /// with a non-positive pivot still gets a finite factor.
    #[test]
    fn inverse_cholesky_inverts_the_factor() {
        let base = Block::new(4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0);
        let (mut d, mut original) = (ZERO_BLOCK, ZERO_BLOCK);
        for lane in 0..LANES {
            let m = base * (1.0 + lane as f32) + Block::identity() * (0.1 * lane as f32);
            set_block(&mut d, lane, &m);
            set_block(&mut original, lane, &m);
        }
        let mut singular = base;
        singular[(1, 1)] = -1.0;
        set_block(&mut d, LANES - 1, &singular);
        let inv = inverse_cholesky(&d, &original);
        let lane_of = |m: &BlockLanes, l: usize| Block::from_fn(|r, c| m[3 * r + c][l]);
        for lane in 0..LANES - 1 {
            let (d, inv) = (lane_of(&d, lane), lane_of(&inv, lane));
            let id = d * inv.transpose() * inv;
            assert!((id - Block::identity()).amax() < 1e-5, "lane {lane}: {id}");
        }
        assert!(lane_of(&inv, LANES - 1).iter().all(|v| v.is_finite()));
    }
}
