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

use super::bsr::BlockCsr;
use crate::math::{Real, Vec3, outer};

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

/// Adds `couplings` to `A` and `b` linearised at `x`, with `w` the
/// displacement `K` multiplies in `b` and `h` the scheme's `h'`. Blocks
/// inside `A`'s pattern (always the diagonal ones) are added to it; the
/// others are appended to `remote`. (Lumping those onto the diagonal
/// instead keeps `A` definite but resists the pair's shared motion: two
/// layers of cloth falling together would be held back by the stiffness
/// meant for their approach.)
pub(super) fn add(
    couplings: &[Coupling],
    x: &[Vec3],
    w: &[Vec3],
    h: Real,
    a: &mut BlockCsr,
    b: &mut [Vec3],
    remote: &mut Vec<Remote>,
) {
    for c in couplings {
        let n = c.normal;
        let live = |k: &usize| c.weights[*k] != 0.0;
        let point = |v: &[Vec3]| -> Vec3 {
            (0..4)
                .filter(live)
                .map(|k| v[c.particles[k] as usize] * c.weights[k])
                .sum()
        };
        let short = c.target - n.dot(&point(x));
        if short <= 0.0 {
            continue;
        }
        let along_w = n.dot(&point(w));
        let scale = c.stiffness * h * h;
        let nn = outer(&n, &n) * scale;
        // Either every block goes into `A`, or only the diagonal ones: a
        // rank-one term with some blocks dropped is indefinite, and `A`
        // is what the preconditioner is built from.
        let all_in = (0..4).filter(live).all(|k| {
            (0..4).filter(live).all(|l| {
                a.slot(c.particles[k] as usize, c.particles[l] as usize)
                    .is_some()
            })
        });
        for k in (0..4).filter(live) {
            let p = c.particles[k] as usize;
            let ck = c.weights[k];
            b[p] += n * (h * c.stiffness * ck * (short - along_w));
            for l in (0..4).filter(live) {
                let q = c.particles[l] as usize;
                let cl = c.weights[l];
                match a.slot(p, q).filter(|_| all_in || p == q) {
                    Some(s) => a.values[s] += nn * (ck * cl),
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
}

/// `out += R v`: the couplings' blocks outside `A`'s pattern, in their
/// fixed order (so the sum does not depend on the thread count).
pub fn mul_add(remote: &[Remote], v: &[Vec3], out: &mut [Vec3]) {
    for r in remote {
        let n = r.normal;
        out[r.row as usize] += n * (r.coef * n.dot(&v[r.col as usize]));
    }
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
            &mut remote,
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
            &mut remote,
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
            &mut remote,
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
}
