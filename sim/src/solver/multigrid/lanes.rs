//! 3x3 blocks and 3-vectors of several independent lines side by side,
//! one per SIMD lane, for the line smoother's substitutions.
//!
//! A block product on its own is too small to vectorise (nalgebra's
//! generic 3x3 product became shuffles and scalar sums, and a sweep spent
//! ~140 cycles per node); [`LANES`] lines solved together turn each
//! multiply-add into one packed instruction on the baseline x86-64 (SSE)
//! and NEON alike. The sums run in the order nalgebra's product used
//! (`(m₀ v₀ + m₁ v₁) + m₂ v₂`), so each lane's result is bit for bit the
//! scalar one.

use super::grid_matrix::{Block, Vec3f};

/// Lines solved together.
pub const LANES: usize = 4;

/// One number per lane.
pub type Lanes = [f32; LANES];

/// A 3-vector per lane: component `r` of lane `l` at `[r][l]`.
pub type VecLanes = [Lanes; 3];

/// A 3x3 block per lane, row-major: entry `(r, c)` of lane `l` at
/// `[3 r + c][l]`.
pub type BlockLanes = [Lanes; 9];

/// Zero in every lane.
pub const ZERO_VEC: VecLanes = [[0.0; LANES]; 3];

/// The zero block in every lane.
pub const ZERO_BLOCK: BlockLanes = [[0.0; LANES]; 9];

/// Puts `m` in lane `lane` of `out`.
#[inline]
pub fn set_block(out: &mut BlockLanes, lane: usize, m: &Block) {
    for r in 0..3 {
        for c in 0..3 {
            out[3 * r + c][lane] = m[(r, c)];
        }
    }
}

/// Puts `v` in lane `lane` of `out`.
#[inline(always)]
pub fn set_vec(out: &mut VecLanes, lane: usize, v: &Vec3f) {
    out[0][lane] = v.x;
    out[1][lane] = v.y;
    out[2][lane] = v.z;
}

/// Lane `lane` of `v`.
#[inline(always)]
pub fn get_vec(v: &VecLanes, lane: usize) -> Vec3f {
    Vec3f::new(v[0][lane], v[1][lane], v[2][lane])
}

/// `acc -= m v`, lane by lane.
#[inline(always)]
pub fn sub_mul(acc: &mut VecLanes, m: &BlockLanes, v: &VecLanes) {
    sub_assign(acc, &mul(m, v));
}

/// `acc -= mᵀ v`, lane by lane.
#[inline(always)]
pub fn sub_mul_t(acc: &mut VecLanes, m: &BlockLanes, v: &VecLanes) {
    sub_assign(acc, &mul_t(m, v));
}

#[inline(always)]
fn sub_assign(acc: &mut VecLanes, v: &VecLanes) {
    for (a, v) in acc.iter_mut().zip(v) {
        for (a, v) in a.iter_mut().zip(v) {
            *a -= v;
        }
    }
}

/// `m v`, lane by lane.
#[inline(always)]
pub fn mul(m: &BlockLanes, v: &VecLanes) -> VecLanes {
    let mut out = ZERO_VEC;
    for r in 0..3 {
        for l in 0..LANES {
            out[r][l] =
                m[3 * r][l] * v[0][l] + m[3 * r + 1][l] * v[1][l] + m[3 * r + 2][l] * v[2][l];
        }
    }
    out
}

/// `mᵀ v`, lane by lane.
#[inline(always)]
pub fn mul_t(m: &BlockLanes, v: &VecLanes) -> VecLanes {
    let mut out = ZERO_VEC;
    for r in 0..3 {
        for l in 0..LANES {
            out[r][l] = m[r][l] * v[0][l] + m[3 + r][l] * v[1][l] + m[6 + r][l] * v[2][l];
        }
    }
    out
}

/// `a bᵀ`, lane by lane, each entry summed in nalgebra's order.
#[inline(always)]
pub fn mul_bt(a: &BlockLanes, b: &BlockLanes) -> BlockLanes {
    let mut out = ZERO_BLOCK;
    for r in 0..3 {
        for c in 0..3 {
            for l in 0..LANES {
                out[3 * r + c][l] = a[3 * r][l] * b[3 * c][l]
                    + a[3 * r + 1][l] * b[3 * c + 1][l]
                    + a[3 * r + 2][l] * b[3 * c + 2][l];
            }
        }
    }
    out
}

/// `acc -= a bᵀ`, lane by lane.
#[inline(always)]
pub fn sub_mul_bt(acc: &mut BlockLanes, a: &BlockLanes, b: &BlockLanes) {
    let p = mul_bt(a, b);
    for (acc, p) in acc.iter_mut().zip(&p) {
        for (acc, p) in acc.iter_mut().zip(p) {
            *acc -= p;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every lane's products are the scalar products, bit for bit.
    #[test]
    fn lanes_multiply_like_blocks() {
        let blocks: Vec<Block> = (0..LANES)
            .map(|l| Block::from_fn(|r, c| ((l * 9 + r * 3 + c) as f32 * 0.37).sin()))
            .collect();
        let vecs: Vec<Vec3f> = (0..LANES)
            .map(|l| Vec3f::from_fn(|r, _| ((l * 3 + r) as f32 * 1.3).cos()))
            .collect();
        let (mut m, mut v) = (ZERO_BLOCK, ZERO_VEC);
        for l in 0..LANES {
            set_block(&mut m, l, &blocks[l]);
            set_vec(&mut v, l, &vecs[l]);
        }
        let (prod, prod_t) = (mul(&m, &v), mul_t(&m, &v));
        let (mut acc, mut acc_t) = (v, v);
        sub_mul(&mut acc, &m, &v);
        sub_mul_t(&mut acc_t, &m, &v);
        let other: Vec<Block> = blocks.iter().map(|b| b.map(|v| v * 1.7 - 0.2)).collect();
        let mut n = ZERO_BLOCK;
        for (l, o) in other.iter().enumerate() {
            set_block(&mut n, l, o);
        }
        let prod_bt = mul_bt(&m, &n);
        let mut acc_bt = n;
        sub_mul_bt(&mut acc_bt, &m, &n);
        for l in 0..LANES {
            let (b, x) = (&blocks[l], &vecs[l]);
            let lane = |m: &BlockLanes| Block::from_fn(|r, c| m[3 * r + c][l]);
            assert_eq!(lane(&prod_bt), b * other[l].transpose());
            assert_eq!(lane(&acc_bt), other[l] - b * other[l].transpose());
            assert_eq!(get_vec(&prod, l), b * x);
            assert_eq!(get_vec(&prod_t, l), b.transpose() * x);
            assert_eq!(get_vec(&acc, l), x - b * x);
            assert_eq!(get_vec(&acc_t, l), x - b.transpose() * x);
        }
    }
}
