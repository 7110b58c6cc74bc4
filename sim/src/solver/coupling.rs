//! Couplings: stiff one-sided springs between a few particles and a fixed
//! point of an obstacle, inside the solve (the issue's "stiff damped
//! contact terms added to `A`").
//!
//! A cloth edge across an obstacle's edge, or a cloth triangle over its
//! corner, is held by no particle: the particles' filters `S` cannot
//! carry its load. A coupling carries it through the springs' own
//! system: with `d(x) = n · Σ c_k x_k` the distance of the cloth's closest
//! point from the feature along `n` (the feature's part folded into
//! `target`), its energy is
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

use super::bsr::BlockCsr;
use crate::math::{Real, Vec3, outer};

/// One coupling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    /// The cloth particles (unused slots have weight 0).
    pub particles: [u32; 3],
    /// Their weights `c_k` in the closest point.
    pub weights: [Real; 3],
    /// Unit direction from the feature to the cloth.
    pub normal: Vec3,
    /// The least `d` the spring allows, metres.
    pub target: Real,
    /// Stiffness `s`, N/m.
    pub stiffness: Real,
}

/// Adds `couplings` to `A` and `b` linearised at `x`, with `w` the
/// displacement `K` multiplies in `b` and `h` the scheme's `h'`.
pub(super) fn add(
    couplings: &[Coupling],
    x: &[Vec3],
    w: &[Vec3],
    h: Real,
    a: &mut BlockCsr,
    b: &mut [Vec3],
) {
    for c in couplings {
        let n = c.normal;
        let live = |k: usize| c.weights[k] != 0.0;
        let point = |v: &[Vec3]| -> Vec3 {
            (0..3)
                .filter(|&k| live(k))
                .map(|k| v[c.particles[k] as usize] * c.weights[k])
                .sum()
        };
        let short = c.target - n.dot(&point(x));
        if short <= 0.0 {
            continue;
        }
        let along_w = n.dot(&point(w));
        let nn = outer(&n, &n) * (c.stiffness * h * h);
        // A block missing from the pattern (no force couples those
        // particles) would leave `A` indefinite if dropped alone; such a
        // coupling is lumped onto the diagonal instead, which bounds the
        // rank-one term from above (Gershgorin).
        let all_in = (0..3).all(|k| {
            !live(k)
                || (0..3).all(|l| {
                    !live(l)
                        || a.slot(c.particles[k] as usize, c.particles[l] as usize)
                            .is_some()
                })
        });
        let total: Real = c.weights.iter().map(|w| w.abs()).sum();
        for k in (0..3).filter(|&k| live(k)) {
            let p = c.particles[k] as usize;
            let ck = c.weights[k];
            b[p] += n * (h * c.stiffness * ck * (short - along_w));
            if all_in {
                for l in (0..3).filter(|&l| live(l)) {
                    if let Some(s) = a.slot(p, c.particles[l] as usize) {
                        a.values[s] += nn * (ck * c.weights[l]);
                    }
                }
            } else {
                let d = a.diag_slot(p);
                a.values[d] += nn * (ck.abs() * total);
            }
        }
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
            particles: [0, 0, 0],
            weights: [1.0, 0.0, 0.0],
            normal: Vec3::z(),
            target: 0.001,
            stiffness: 100.0,
        };
        let h = 0.01;
        add(&[c], &[Vec3::zeros()], &[Vec3::zeros()], h, &mut a, &mut b);
        let dv = a.values[0].try_inverse().expect("SPD") * b[0];
        let moved = dv * h;
        let want = 0.001 / (1.0 + m / (100.0 * h * h));
        assert!((moved.z - want).abs() < 1e-15 && moved.xy().norm() == 0.0);
        // Farther than the target: nothing.
        let mut b2 = vec![Vec3::zeros()];
        add(&[c], &[Vec3::z()], &[Vec3::zeros()], h, &mut a, &mut b2);
        assert_eq!(b2[0], Vec3::zeros());
    }
}
