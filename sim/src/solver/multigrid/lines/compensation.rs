//! What a line sweep that leaves a coupling out puts back on the
//! diagonal, so that the smoother stays SPD (`Ã ≥ A`, module doc of
//! `lines`).
//!
//! Leaving out the block `C = A_pq` between nodes `p` and `q` and adding
//! `X` to both diagonals changes `A` by `[[X, -C], [-Cᵀ, X]]`.
//!
//! - **Loose**: `X = |C|_F I`, as `2 uᵀ C v ≤ |C|_F (|u|² + |v|²)`. One
//!   norm, but it resists every motion of the two nodes, their common
//!   translation too, which a bending hinge's end coupling does not.
//! - **Tight**: with `C = S + W` (symmetric and skew parts, `W v = w × v`)
//!   and `X = S + μ I` the change's quadratic form at `(a, b)` is
//!
//!   ```text
//!   aᵀ X a + bᵀ X b - 2 aᵀ C b = (a - b)ᵀ S (a - b) + μ (|a|² + |b|²) - 2 aᵀ W b
//!   ```
//!
//!   never negative when `μ ≥ |w| + 2 max(0, -λ_min(S))`:
//!   `2 |aᵀ W b| ≤ |w| (|a|² + |b|²)`, and for a negative `λ_min`,
//!   `(a - b)ᵀ S (a - b) ≥ λ_min |a - b|² ≥ 2 λ_min (|a|² + |b|²)`. A
//!   hinge's end coupling `c P` (`P` the projector across its line) is
//!   put back as itself, and the change vanishes on `a = b`.

use super::super::grid_matrix::{Block, GridMatrix, Vec3f};
use crate::parallel;

/// Every node's sum of the tight `X` of its couplings at offsets
/// `dropped`, into `sum`. `X(Bᵀ) = X(B)` and `A` is symmetric, so a pair's
/// `X` is computed once, at the node it reaches forward from (into
/// `pairs`, one vector per forward offset), and read by both.
pub fn tight_sums(
    a: &GridMatrix,
    dropped: &[usize],
    pairs: &mut Vec<Vec<Block>>,
    sum: &mut Vec<Block>,
) {
    let n = a.len();
    // PERF: no list is gathered: this runs at every factorisation.
    let forward = || dropped.iter().copied().filter(|&k| a.offsets()[k] > (0, 0));
    pairs.resize(forward().count(), Vec::new());
    for (pair, k) in pairs.iter_mut().zip(forward()) {
        pair.resize(n, Block::zeros());
        parallel::for_chunks_min(pair, parallel::ROWS_MIN, |start, out| {
            for (q, x) in out.iter_mut().enumerate() {
                *x = tight(&a.row(start + q)[k]);
            }
        });
    }
    sum.resize(n, Block::zeros());
    let nu = a.nu;
    parallel::for_chunks_min(sum, parallel::ROWS_MIN, |start, out| {
        for (q, x) in out.iter_mut().enumerate() {
            let p = start + q;
            let (i, j) = (p % nu, p / nu);
            *x = Block::zeros();
            for (pair, k) in pairs.iter().zip(forward()) {
                *x += pair[p];
                let (di, dj) = a.offsets()[k];
                let (bi, bj) = (i as i32 - di, j as i32 - dj);
                if bi >= 0 && bj >= 0 && (bi as usize) < nu && (bj as usize) < a.nv {
                    *x += pair[bi as usize + bj as usize * nu];
                }
            }
        }
    });
}

/// The loose `X` (module doc), as the multiple of `I`.
pub fn loose(c: &Block) -> f32 {
    c.norm()
}

/// The tight `X` (module doc), with `λ_min(S)` taken as zero when every
/// principal minor of `S` is non-negative to single precision's round-off
/// (the common case, a hinge's end coupling), else bounded below by
/// Gershgorin's discs: no eigenvalue, as a factorisation computes one per
/// node and coupling left out. Where that comes to more than the loose
/// `X` (in trace), the loose one.
pub fn tight(c: &Block) -> Block {
    let s = (c + c.transpose()) * 0.5;
    let w = Vec3f::new(
        c[(2, 1)] - c[(1, 2)],
        c[(0, 2)] - c[(2, 0)],
        c[(1, 0)] - c[(0, 1)],
    ) * 0.5;
    let scale = s.diagonal().abs().max();
    let negative = if semidefinite(&s, scale) {
        0.0
    } else {
        (0..3)
            .map(|r| {
                let off: f32 = (0..3).filter(|&k| k != r).map(|k| s[(r, k)].abs()).sum();
                off - s[(r, r)]
            })
            .fold(0.0, f32::max)
    };
    let mu = w.norm() + 2.0 * negative + ROUND_OFF * scale;
    // Either bound holds, pair by pair: where the symmetric part is far
    // from semi-definite (a hinge folded nearly flat, whose Gauss–Newton
    // coupling is mostly its rank-one term), the loose one can be less.
    let loose = loose(c);
    if s.trace() + 3.0 * mu <= 3.0 * loose {
        s + Block::identity() * mu
    } else {
        Block::from_diagonal_element(loose)
    }
}

/// Round-off a principal minor of `S` may fall below zero by, relative to
/// `S`'s largest diagonal entry (to the minor's order), and the margin
/// `μ` keeps for it.
const ROUND_OFF: f32 = 1e-5;

/// Whether the symmetric `s` is positive semi-definite: every principal
/// minor at least `-ROUND_OFF scale^k`, `k` its order.
fn semidefinite(s: &Block, scale: f32) -> bool {
    let d = s.diagonal();
    let minor = |a: usize, b: usize| d[a] * d[b] - s[(a, b)] * s[(a, b)];
    let tol = ROUND_OFF * scale;
    d.min() >= -tol
        && minor(0, 1).min(minor(0, 2)).min(minor(1, 2)) >= -tol * scale
        && s.determinant() >= -tol * scale * scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, Matrix3};

    fn random_block(seed: u32) -> Block {
        Block::from_fn(|r, c| ((seed * 9 + r as u32 * 3 + c as u32) as f32 * 1.618).sin())
    }

    /// The change `[[X, -C], [-Cᵀ, X]]` is positive semi-definite for
    /// either `X` and any block: symmetric, skew, indefinite or not.
    #[test]
    fn the_change_is_positive_semidefinite() {
        let mut blocks: Vec<Block> = (0..200).map(random_block).collect();
        blocks.push(Block::zeros());
        blocks.push(Block::identity() * -3.0);
        blocks.push(random_block(7) - random_block(7).transpose());
        for c in blocks {
            for x in [Block::identity() * loose(&c), tight(&c)] {
                let mut m = DMatrix::<f64>::zeros(6, 6);
                for r in 0..3 {
                    for k in 0..3 {
                        m[(r, k)] = f64::from(x[(r, k)]);
                        m[(3 + r, 3 + k)] = f64::from(x[(r, k)]);
                        m[(r, 3 + k)] = -f64::from(c[(r, k)]);
                        m[(3 + k, r)] = -f64::from(c[(r, k)]);
                    }
                }
                let m = (&m + m.transpose()) * 0.5;
                let min = m.symmetric_eigenvalues().min();
                assert!(min >= -1e-6 * f64::from(c.norm()), "{c}: {min}");
            }
        }
    }

    /// A bending hinge's end coupling `c P` is put back as itself: no
    /// stiffness against moving both nodes together.
    #[test]
    fn a_hinge_coupling_is_put_back_as_itself() {
        let t = nalgebra::Vector3::new(0.3f64, -0.5, 0.8).normalize();
        let p = (Matrix3::identity() - t * t.transpose()) * 2.5e-3;
        let c = p.cast::<f32>();
        let x = tight(&c);
        // Equal but for the margin `ROUND_OFF` on the diagonal.
        assert!(
            (x - c).amax() <= 2.0 * ROUND_OFF * c.amax(),
            "{x} against {c}"
        );
    }

    /// The semi-definite test agrees with the eigenvalues away from the
    /// round-off band.
    #[test]
    fn semidefinite_blocks_are_recognised() {
        for seed in 0..300 {
            let c = random_block(seed);
            let s = (c + c.transpose()) * 0.5;
            for shift in [-2.0f32, -0.5, 0.0, 0.5, 2.0] {
                let m = s + Block::identity() * shift;
                let min = m.cast::<f64>().symmetric_eigenvalues().min();
                let scale = m.diagonal().abs().max();
                if min.abs() > 1e-3 * f64::from(scale) {
                    assert_eq!(semidefinite(&m, scale), min > 0.0, "{m}");
                }
            }
        }
    }
}
