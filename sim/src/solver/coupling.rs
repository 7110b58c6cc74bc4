//! Couplings: stiff one-sided springs between a few particles and a fixed
//! point of an obstacle, or between two features of the cloth, inside the
//! solve (the issue's "stiff damped contact terms added to `A`").
//!
//! A cloth edge across an obstacle's edge, or a cloth triangle over its
//! corner, is held by no particle, and two layers of cloth pressed
//! together couple four particles: the particles' filters `S` cannot
//! carry either. A coupling carries it through the springs' own system:
//! with `d(x) = n · Σ c_k x_k` the distance of the pair's closest points
//! along `n` (an obstacle's part folded into `target`), its energy is
//!
//! ```text
//! E = 1/2 s (target - d)²   while d < target,
//! f_k = s (target - d) c_k n,   K_kl = ∂f_k/∂x_l = -s c_k c_l n nᵀ,
//! ```
//!
//! added to eq. [20] like any force: `A_kl += h'² s c_k c_l n nᵀ` and
//! `b_k += h' (f_k + Σ_l K_kl w_l)`. `K` is a negative rank-one matrix, so
//! `A` stays symmetric positive definite. A coupling whose cloth is
//! farther than `target` where the system is linearised adds nothing.
//!
//! Two layers' particles are far apart on the grid, so most of their
//! blocks lie outside `A`'s pattern: those are kept aside ([`Remote`]) and
//! the solver multiplies by them after `A` ([`mul_add`]); `A`, from which
//! the preconditioner is built, keeps the diagonal blocks.
//!
//! The preconditioner then sees such a coupling only through those
//! diagonal blocks, `D = s h'² diag(c_k² n nᵀ)`, and along the pair's
//! relative motion `g = Σ c_k e_k ⊗ n` (the direction the spring resists)
//! it holds `gᵀ D g = s h'² Σ c_k⁴` of the coupling's `gᵀ (s h'² g gᵀ) g =
//! s h'² (Σ c_k²)²`. With the masses' `m Σ c_k²` beside it, that motion is
//! an eigenvalue of the preconditioned system near
//!
//! ```text
//! β = (Σ c_k²)² / Σ c_k⁴      (1 to 4: the weights' participation number)
//! ```
//!
//! above the others: one more CG iteration for each coupling of a step.
//! So the preconditioner is built with a lone coupling's diagonal blocks
//! times `β` ([`Boost`]; `A` itself is unchanged), which matches its
//! stiffness along `g` exactly (two particles with weights `±1`, `β = 2`:
//! the relative motion becomes an eigenvector of eigenvalue 1); couplings
//! that share a particle are left as they are (`mark_shared`). On
//! sphere-drape-30 that took CG from 4,764 to 4,206 iterations, on
//! rotating-sphere from 12,500 to 11,896 (docs/benchmarks.md 1v).

use super::bsr::BlockCsr;
use crate::math::{Mat3, Real, Vec3, outer};

/// One coupling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    /// The cloth particles (unused slots have weight 0).
    pub particles: [u32; 4],
    /// Their weights `c_k` in the closest point.
    pub weights: [Real; 4],
    /// Unit direction from the feature to the cloth.
    pub normal: Vec3,
    /// The least `d` the spring allows, metres.
    pub target: Real,
    /// Stiffness `s`, N/m.
    pub stiffness: Real,
}

impl Coupling {
    /// The slots in use (an unused slot has weight 0).
    pub(super) fn live(&self) -> impl Iterator<Item = usize> + '_ {
        (0..4).filter(|&k| self.weights[k] != 0.0)
    }

    /// `Σ c_k v_k`: the pair's closest point of `v` (`d = n · point(x)`).
    pub(super) fn point(&self, v: &[Vec3]) -> Vec3 {
        self.live()
            .map(|k| v[self.particles[k] as usize] * self.weights[k])
            .sum()
    }
}

/// A block `A_kl = coef n nᵀ` of a coupling between particles that no
/// force couples, outside `A`'s pattern: applied matrix-free after `A`'s
/// own product ([`mul_add`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Remote {
    row: u32,
    col: u32,
    coef: Real,
    normal: Vec3,
}

/// What the preconditioner adds to one of `A`'s blocks (module doc):
/// `(β - 1)` times a remote coupling's diagonal block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Boost {
    /// The block's slot in `A`.
    slot: usize,
    /// The addition.
    block: Mat3,
    /// The block's particle and coupling, and whether another boosted
    /// coupling holds the particle too.
    particle: u32,
    coupling: u32,
    shared: bool,
}

/// Adds `couplings` to `A` and `b` linearised at `x`, with `w` the
/// displacement `K` multiplies in `b` and `h` the scheme's `h'`. Blocks
/// inside `A`'s pattern (always the diagonal ones) are added to it; the
/// others are appended to `remote`, and the preconditioner's share of
/// their couplings' diagonal blocks to `boost` (module doc). (Lumping
/// the remote blocks onto the diagonal instead keeps `A` definite but
/// resists the pair's shared motion: two layers of cloth falling together
/// would be held back by the stiffness meant for their approach.)
pub(super) fn add(
    couplings: &[Coupling],
    x: &[Vec3],
    w: &[Vec3],
    h: Real,
    a: &mut BlockCsr,
    b: &mut [Vec3],
    (remote, boost): (&mut Vec<Remote>, &mut Vec<Boost>),
) {
    let first = boost.len();
    for (id, c) in couplings.iter().enumerate() {
        let n = c.normal;
        let short = c.target - n.dot(&c.point(x));
        if short <= 0.0 {
            continue;
        }
        let along_w = n.dot(&c.point(w));
        let scale = c.stiffness * h * h;
        let nn = outer(&n, &n) * scale;
        // Either every block goes into `A`, or only the diagonal ones: a
        // rank-one term with some blocks dropped is indefinite, and `A`
        // is what the preconditioner is built from.
        let all_in = c.live().all(|k| {
            c.live().all(|l| {
                a.slot(c.particles[k] as usize, c.particles[l] as usize)
                    .is_some()
            })
        });
        let (s2, s4) = c
            .weights
            .iter()
            .fold((0.0, 0.0), |(s2, s4), w| (s2 + w * w, s4 + w * w * w * w));
        let extra = s2 * s2 / s4 - 1.0;
        for k in c.live() {
            let p = c.particles[k] as usize;
            let ck = c.weights[k];
            b[p] += n * (h * c.stiffness * ck * (short - along_w));
            for l in c.live() {
                let q = c.particles[l] as usize;
                let cl = c.weights[l];
                match a.slot(p, q).filter(|_| all_in || p == q) {
                    Some(s) => {
                        a.values[s] += nn * (ck * cl);
                        if !all_in && extra > 0.0 {
                            boost.push(Boost {
                                slot: s,
                                block: nn * (ck * cl * extra),
                                particle: p as u32,
                                coupling: id as u32,
                                shared: false,
                            });
                        }
                    }
                    None => remote.push(Remote {
                        row: p as u32,
                        col: q as u32,
                        coef: scale * ck * cl,
                        normal: n,
                    }),
                }
            }
        }
    }
    mark_shared(&mut boost[first..]);
    // Entries before `first` were kept by an earlier call: none is shared.
    boost.retain(|b| !b.shared);
}

/// Marks as shared every entry of a coupling one of whose particles
/// another coupling of `boost` holds too, leaving the entries ordered by
/// coupling, then particle.
///
/// Why only lone couplings are boosted: `β` is the stiffness of one
/// coupling along its own motion. Where layers lie on each other over a
/// patch, couplings share particles, and each particle's diagonal
/// already sums several of them; boosted, it held the patch's layers
/// moving together (which no coupling resists) so stiffly that CG's
/// error rule, reading the smallest Ritz value, stopped before that
/// motion was solved: the stress suite's fast fold stretched 18 %
/// (1.8 % unboosted, and with lone couplings boosted).
fn mark_shared(boost: &mut [Boost]) {
    boost.sort_unstable_by_key(|b| (b.particle, b.coupling));
    for k in 1..boost.len() {
        if boost[k].particle == boost[k - 1].particle && boost[k].coupling != boost[k - 1].coupling
        {
            boost[k].shared = true;
            boost[k - 1].shared = true;
        }
    }
    boost.sort_unstable_by_key(|b| (b.coupling, b.particle));
    let mut start = 0;
    while start < boost.len() {
        let c = boost[start].coupling;
        let end = start
            + boost[start..]
                .iter()
                .take_while(|b| b.coupling == c)
                .count();
        let shared = boost[start..end].iter().any(|b| b.shared);
        for b in &mut boost[start..end] {
            b.shared = shared;
        }
        start = end;
    }
}

/// Runs `update` on `a` with each `boost` added to its block, then puts
/// the blocks back as they were, bit for bit: the preconditioner sees the
/// boosted diagonal, the operator does not.
pub fn boosted(
    a: &mut BlockCsr,
    boost: &[Boost],
    saved: &mut Vec<Mat3>,
    update: impl FnOnce(&BlockCsr),
) {
    saved.clear();
    for b in boost {
        saved.push(a.values[b.slot]);
        a.values[b.slot] += b.block;
    }
    update(a);
    // In reverse, so a slot boosted twice ends at its first value.
    for (b, v) in boost.iter().zip(saved.iter()).rev() {
        a.values[b.slot] = *v;
    }
}

/// `out += R v`: the couplings' blocks outside `A`'s pattern, in their
/// fixed order (so the sum does not depend on the thread count).
pub fn mul_add(remote: &[Remote], v: &[Vec3], out: &mut [Vec3]) {
    for r in remote {
        let n = r.normal;
        out[r.row as usize] += n * (r.coef * n.dot(&v[r.col as usize]));
    }
}

/// The remote blocks filtered, `(k, S_k (coef n nᵀ) S_l)`, with
/// `filter(k, v)` giving `S_k v`: their share of the filtered operator's
/// action on rigid translations, row by row (`mpcg::translation`).
pub fn translation_blocks<'a>(
    remote: &'a [Remote],
    filter: impl Fn(usize, &Vec3) -> Vec3 + 'a,
) -> impl Iterator<Item = (usize, Mat3)> + 'a {
    remote.iter().map(move |r| {
        let row = filter(r.row as usize, &r.normal);
        let col = filter(r.col as usize, &r.normal);
        (r.row as usize, row * col.transpose() * r.coef)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One particle held by a coupling at rest with no other force: the
    /// system `A dv = b` is that of a mass on a spring, and its solution
    /// moves the particle out by `short / (1 + m / (s h²))`.
    #[test]
    fn a_single_coupling_is_a_spring_to_its_target() {
        let mut a = BlockCsr::with_pattern(1, []);
        let m = 0.01;
        a.values[0] = crate::math::Mat3::identity() * m;
        let mut b = vec![Vec3::zeros()];
        let c = Coupling {
            particles: [0; 4],
            weights: [1.0, 0.0, 0.0, 0.0],
            normal: Vec3::z(),
            target: 0.001,
            stiffness: 100.0,
        };
        let h = 0.01;
        let mut remote = Vec::new();
        add(
            &[c],
            &[Vec3::zeros()],
            &[Vec3::zeros()],
            h,
            &mut a,
            &mut b,
            (&mut remote, &mut Vec::new()),
        );
        assert!(remote.is_empty());
        let dv = a.values[0].try_inverse().expect("SPD") * b[0];
        let moved = dv * h;
        let want = 0.001 / (1.0 + m / (100.0 * h * h));
        assert!((moved.z - want).abs() < 1e-15 && moved.xy().norm() == 0.0);
        // Farther than the target: nothing.
        let mut b2 = vec![Vec3::zeros()];
        add(
            &[c],
            &[Vec3::z()],
            &[Vec3::zeros()],
            h,
            &mut a,
            &mut b2,
            (&mut remote, &mut Vec::new()),
        );
        assert_eq!(b2[0], Vec3::zeros());
    }

    /// A vertex over a triangle of particles that no force couples to it
    /// (two layers of cloth): `A + R` is exactly `M + h² s g gᵀ` with
    /// `g = Σ c_k n` on the four particles, whichever blocks the pattern
    /// has, and `b` pushes the vertex out and the triangle in.
    #[test]
    fn blocks_outside_the_pattern_are_applied_exactly() {
        // The triangle's corners 1, 2, 3 are coupled to each other; the
        // vertex 0 to none of them.
        let pairs = [(1, 2), (2, 1), (1, 3), (3, 1), (2, 3), (3, 2)];
        let mut a = BlockCsr::with_pattern(4, pairs);
        let m = 0.01;
        for i in 0..4 {
            let d = a.diag_slot(i);
            a.values[d] = crate::math::Mat3::identity() * m;
        }
        let n = Vec3::new(0.0, 0.6, 0.8);
        let c = Coupling {
            particles: [0, 1, 2, 3],
            weights: [1.0, -0.2, -0.3, -0.5],
            normal: n,
            target: 0.002,
            stiffness: 50.0,
        };
        let h = 0.01;
        let x = [Vec3::zeros(); 4];
        let mut b = vec![Vec3::zeros(); 4];
        let mut remote = Vec::new();
        add(
            &[c],
            &x,
            &[Vec3::zeros(); 4],
            h,
            &mut a,
            &mut b,
            (&mut remote, &mut Vec::new()),
        );
        // Some blocks are missing, so every off-diagonal block is kept
        // aside (`A` with part of a rank-one term would be indefinite),
        // and `A`'s blocks between the corners are untouched.
        assert_eq!(remote.len(), 12);
        let s12 = a.slot(1, 2).expect("in the pattern");
        assert_eq!(a.values[s12], crate::math::Mat3::zeros());
        let v: Vec<Vec3> = (0..4)
            .map(|k| Vec3::new(1.0 + k as Real, -2.0 * k as Real, 0.5))
            .collect();
        let mut got = vec![Vec3::zeros(); 4];
        a.mul(&v, &mut got);
        mul_add(&remote, &v, &mut got);
        let gv: Real = (0..4).map(|k| c.weights[k] * n.dot(&v[k])).sum();
        for k in 0..4 {
            let want = v[k] * m + n * (50.0 * h * h * c.weights[k] * gv);
            assert!((got[k] - want).norm() < 1e-15 * want.norm().max(1.0), "{k}");
            let push = n * (h * 50.0 * c.weights[k] * 0.002);
            assert!((b[k] - push).norm() < 1e-18, "{k}");
        }
    }

    /// `couplings` added to `a` with the cloth at rest at the origin and
    /// `h' = 0.01`: the remote blocks and the boost.
    fn added_at_rest(couplings: &[Coupling], a: &mut BlockCsr) -> (Vec<Remote>, Vec<Boost>) {
        let zeros = vec![Vec3::zeros(); a.rows()];
        let mut b = zeros.clone();
        let (mut remote, mut boost) = (Vec::new(), Vec::new());
        add(
            couplings,
            &zeros,
            &zeros,
            0.01,
            a,
            &mut b,
            (&mut remote, &mut boost),
        );
        (remote, boost)
    }

    /// Four particles of equal mass coupled across the grid (no block
    /// between them in `A`'s pattern), for several weights: the boosted
    /// diagonal blocks hold the coupling's stiffness along the pair's
    /// relative motion `g` exactly (block Jacobi's Rayleigh quotient
    /// `gᵀ A g / gᵀ P g` along it is 1; unboosted it is above 1), and
    /// `A` comes back bit for bit once the preconditioner is built.
    #[test]
    fn the_boost_holds_the_couplings_stiffness_along_its_motion() {
        let m = 0.01;
        let n = Vec3::new(0.0, 0.6, 0.8);
        for weights in [
            [1.0, -1.0, 0.0, 0.0],
            [1.0, -0.2, -0.3, -0.5],
            [0.5, 0.5, -0.5, -0.5],
            [0.9, 0.1, -0.7, -0.3],
        ] {
            let mut a = BlockCsr::with_pattern(4, []);
            for i in 0..4 {
                let d = a.diag_slot(i);
                a.values[d] = Mat3::identity() * m;
            }
            let live = weights.iter().filter(|w| **w != 0.0).count();
            let c = Coupling {
                particles: [0, 1, 2, 3],
                weights,
                normal: n,
                target: 0.002,
                stiffness: 16.0 * m / (0.01 * 0.01),
            };
            let (remote, boost) = added_at_rest(&[c], &mut a);
            assert_eq!(boost.len(), live);
            let g: Vec<Vec3> = (0..4).map(|k| n * weights[k]).collect();
            let mut ag = vec![Vec3::zeros(); 4];
            a.mul(&g, &mut ag);
            mul_add(&remote, &g, &mut ag);
            let gag: Real = g.iter().zip(&ag).map(|(g, a)| g.dot(a)).sum();
            let quotient = |a: &BlockCsr| -> Real {
                let gpg: Real = (0..4).map(|k| g[k].dot(&(a.diag_block(k) * g[k]))).sum();
                gag / gpg
            };
            let before = a.values.clone();
            let plain = quotient(&a);
            let mut boosted_quotient = 0.0;
            let mut saved = Vec::new();
            boosted(&mut a, &boost, &mut saved, |a| {
                boosted_quotient = quotient(a)
            });
            assert!(
                (boosted_quotient - 1.0).abs() < 1e-12,
                "{weights:?}: {boosted_quotient}"
            );
            let beta = {
                let s2: Real = weights.iter().map(|w| w * w).sum();
                let s4: Real = weights.iter().map(|w| w.powi(4)).sum();
                s2 * s2 / s4
            };
            assert!(
                plain > 1.0 + 0.9 * (beta - 1.0) / beta,
                "{weights:?}: {plain}"
            );
            assert!(a.values.iter().zip(&before).all(|(x, y)| x == y));
        }
    }

    /// Two couplings sharing a particle are not boosted; a third, alone,
    /// is, one entry per particle with a weight.
    #[test]
    fn only_lone_couplings_are_boosted() {
        let mut a = BlockCsr::with_pattern(9, []);
        for i in 0..9 {
            let d = a.diag_slot(i);
            a.values[d] = Mat3::identity() * 0.01;
        }
        let coupling = |particles: [u32; 4]| Coupling {
            particles,
            weights: [1.0, -0.5, -0.25, -0.25],
            normal: Vec3::z(),
            target: 0.002,
            stiffness: 100.0,
        };
        let couplings = [
            coupling([0, 1, 2, 3]),
            coupling([4, 5, 6, 7]),
            coupling([8, 3, 2, 1]),
        ];
        let (_, boost) = added_at_rest(&couplings, &mut a);
        let boosted: Vec<u32> = boost.iter().map(|b| b.particle).collect();
        assert_eq!(boosted, [4, 5, 6, 7]);
        assert!(
            boost
                .iter()
                .all(|b| b.slot == a.diag_slot(b.particle as usize))
        );
    }
}
