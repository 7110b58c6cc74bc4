//! The sink of the assembly (`assemble`): element blocks written into
//! one band of `A` and `b` through the slots precomputed for each
//! element, with the structured fast paths of pairs and arms.

use std::ops::Range;

use crate::cloth::{Sink, arm_blocks};
use crate::math::{Mat3, Real, Vec3};

/// Writes element blocks into one band of `A` and `b` through precomputed
/// slots; blocks of rows outside the band are left to its neighbour.
pub(super) struct AssemblySink<'a> {
    /// The band's blocks of `A`.
    pub(super) values: &'a mut [Mat3],
    /// The band's rows of `b`.
    pub(super) b: &'a mut [Vec3],
    /// The band's rows.
    pub(super) rows: Range<usize>,
    /// Slot of `values[0]`.
    pub(super) base: usize,
    /// The displacement `K` multiplies in `b`, per particle.
    pub(super) w: &'a [Vec3],
    /// `h'`.
    pub(super) h: Real,
    /// The slot table of the force being added (`N x N` per element).
    pub(super) slots: &'a [u32],
}

impl AssemblySink<'_> {
    /// The displacements `K` multiplies along a three-particle element's
    /// arms: `(w_a - w_b, w_c - w_b)`.
    #[inline]
    fn arm_displacements(&self, idx: [usize; 3]) -> [Vec3; 2] {
        let w = |k: usize| self.w[idx[k]];
        [w(0) - w(1), w(2) - w(1)]
    }
}

impl Sink for AssemblySink<'_> {
    #[inline]
    fn add<const N: usize>(
        &mut self,
        element: usize,
        idx: &[usize; N],
        f: &[Vec3; N],
        dfdx: Option<&[[Mat3; N]; N]>,
        dfdv: Option<&[[Mat3; N]; N]>,
    ) {
        let h = self.h;
        let h2 = h * h;
        let slots = &self.slots[element * N * N..(element + 1) * N * N];
        let w: [Vec3; N] = std::array::from_fn(|q| self.w[idx[q]]);
        for a in 0..N {
            if !self.rows.contains(&idx[a]) {
                continue;
            }
            let mut rhs = f[a];
            let row = &slots[a * N..(a + 1) * N];
            if let Some(k) = dfdx {
                for q in 0..N {
                    let block = &k[a][q];
                    self.values[row[q] as usize - self.base] -= block * h2;
                    rhs += block * w[q];
                }
            }
            if let Some(d) = dfdv {
                for q in 0..N {
                    self.values[row[q] as usize - self.base] -= d[a][q] * h;
                }
            }
            self.b[idx[a] - self.rows.start] += rhs * h;
        }
    }

    /// PERF: the four blocks of a pair are `±k` (and `±c`), so each is
    /// scaled once. The sums are those of [`Sink::add`] term for term, so
    /// `A` and `b` are bit for bit the same.
    #[inline]
    fn add_pair(
        &mut self,
        element: usize,
        idx: [usize; 2],
        g: Vec3,
        k: Option<&Mat3>,
        c: Option<&Mat3>,
    ) {
        let h = self.h;
        let [a, b] = idx;
        let mut m = Mat3::zeros();
        // f_a = -g; K_a w = -k w_a + k w_b, and row b is the negation.
        let mut rhs = -g;
        if let Some(k) = k {
            m += k * (h * h);
            rhs += -k * self.w[a];
            rhs += k * self.w[b];
        }
        if let Some(c) = c {
            m += c * h;
        }
        let rhs = rhs * h;
        let slots = &self.slots[element * 4..element * 4 + 4];
        let base = self.base;
        if self.rows.contains(&a) {
            self.values[slots[0] as usize - base] += m;
            self.values[slots[1] as usize - base] -= m;
            self.b[a - self.rows.start] += rhs;
        }
        if self.rows.contains(&b) {
            self.values[slots[2] as usize - base] -= m;
            self.values[slots[3] as usize - base] += m;
            self.b[b - self.rows.start] -= rhs;
        }
    }

    /// PERF: in arm space. The arm blocks are scaled by `h'²` once (four
    /// products, not nine), and `K w` is `∓ h (w_a - w_b, w_c - w_b)`
    /// per arm (four block products, not nine). The same sums as
    /// [`Sink::add`] regrouped, so `A` and `b` agree with it to round-off.
    #[inline]
    fn add_arms(&mut self, element: usize, idx: [usize; 3], g: [Vec3; 2], h: &[[Mat3; 2]; 2]) {
        let [[h11, h12], [h21, h22]] = *h;
        let [d1, d2] = self.arm_displacements(idx);
        // ∂²E/∂e∂e times the arms' displacements.
        let (r1, r2) = (h11 * d1 + h12 * d2, h21 * d1 + h22 * d2);
        let s = self.h * self.h;
        // The particles' `f + K w` and `h'² K` (A -= h'² K), both mapped
        // from the arms as the generic path maps them.
        let (rhs, blocks) = arm_blocks(
            [g[0] + r1, g[1] + r2],
            &[[h11 * s, h12 * s], [h21 * s, h22 * s]],
        );
        let slots = &self.slots[element * 9..element * 9 + 9];
        for (a, row) in blocks.iter().enumerate() {
            let p = idx[a];
            if !self.rows.contains(&p) {
                continue;
            }
            for (q, block) in row.iter().enumerate() {
                self.values[slots[a * 3 + q] as usize - self.base] -= block;
            }
            self.b[p - self.rows.start] += rhs[a] * self.h;
        }
    }

    /// PERF: a rank-one arm Hessian `s j jᵀ` (shear's Gauss–Newton term)
    /// and damping `c j jᵀ` (its Rayleigh damping). With the particle
    /// gradients `J = (j1, -(j1 + j2), j2)` the blocks `(h'² s + h' c)
    /// J_p J_qᵀ` are nine outer products, and `K w` along the arms is
    /// `s (j · d) j`: no 3x3 product at all. The same `A` and `b` as
    /// [`Sink::add`] to round-off.
    #[inline]
    fn add_arms_rank1(
        &mut self,
        element: usize,
        idx: [usize; 3],
        g: [Vec3; 2],
        s: Real,
        c: Real,
        j: [Vec3; 2],
    ) {
        let [d1, d2] = self.arm_displacements(idx);
        let r = s * (j[0].dot(&d1) + j[1].dot(&d2));
        let (g1, g2) = (g[0] + j[0] * r, g[1] + j[1] * r);
        let rhs = [-g1, g1 + g2, -g2];
        let jp = [j[0], -(j[0] + j[1]), j[1]];
        let scale = s * self.h * self.h + c * self.h;
        let slots = &self.slots[element * 9..element * 9 + 9];
        for (a, &p) in idx.iter().enumerate() {
            if !self.rows.contains(&p) {
                continue;
            }
            let left = jp[a] * scale;
            for (q, right) in jp.iter().enumerate() {
                self.values[slots[a * 3 + q] as usize - self.base] += left * right.transpose();
            }
            self.b[p - self.rows.start] += rhs[a] * self.h;
        }
    }
}
