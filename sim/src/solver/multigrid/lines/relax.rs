//! One pack's relaxation: the substitutions that solve its lines' blocks
//! against the other lines' current values ([`LineFamily::relax_pack`]).

use super::{LineFamily, MISSING};
use crate::parallel::Disjoint;
use crate::solver::multigrid::grid_matrix::Vec3f;
use crate::solver::multigrid::lanes::{
    LANES, VecLanes, ZERO_VEC, get_vec, mul, mul_t, set_vec, sub_mul, sub_mul_t,
};

impl LineFamily {
    /// Solves the blocks of pack `pack`'s lines for `b` minus their
    /// couplings to the other lines at their values in `x` (taken as zero
    /// unless `coupled`), into `out`, and writes their nodes of `x`. It
    /// reads `x` only on lines of other colours and, for a neighbour off
    /// the grid, at its own nodes (times a zero block), which only this
    /// pack writes, after this.
    #[inline]
    pub fn relax_pack(
        &self,
        pack: usize,
        b: &[Vec3f],
        x: &Disjoint<'_, Vec3f>,
        coupled: bool,
        out: &mut [VecLanes],
    ) {
        let len = self.len;
        let at = pack * len;
        let w = self.width;
        // Every index read below is a node of the grid (`new`).
        assert!(b.len() == self.grid_nodes && x.len() == self.grid_nodes);
        // rhs, then L y = rhs in the same pass.
        for t in 0..len {
            let s = at + t;
            let mut acc = ZERO_VEC;
            for (lane, &p) in self.nodes[s].iter().enumerate() {
                // SAFETY: `p` is below `grid_nodes` (`new`), `b`'s length.
                #[allow(unsafe_code)]
                set_vec(&mut acc, lane, unsafe { b.get_unchecked(p as usize) });
            }
            if coupled {
                let blocks = &self.off_blocks[s * w..(s + 1) * w];
                let index = &self.off_index[s * w..(s + 1) * w];
                for (m, q) in blocks.iter().zip(index) {
                    let mut g = ZERO_VEC;
                    for (lane, &p) in q.iter().enumerate() {
                        // SAFETY: below `grid_nodes` (`new`), `x`'s length
                        // (checked above), and not written by another pack
                        // during this colour (the doc above).
                        #[allow(unsafe_code)]
                        let v = unsafe { x.read_unchecked(p as usize) };
                        set_vec(&mut g, lane, &v);
                    }
                    sub_mul(&mut acc, m, &g);
                }
            }
            let f = &self.factors[s];
            if t >= 1 {
                sub_mul(&mut acc, &f.prev1, &out[t - 1]);
            }
            if t >= 2 {
                sub_mul(&mut acc, &f.prev2, &out[t - 2]);
            }
            out[t] = mul(&f.inv, &acc);
        }
        // Lᵀ x = y.
        for t in (0..len).rev() {
            let s = at + t;
            let mut acc = out[t];
            if t + 1 < len {
                sub_mul_t(&mut acc, &self.factors[s + 1].prev1, &out[t + 1]);
            }
            if t + 2 < len {
                sub_mul_t(&mut acc, &self.factors[s + 2].prev2, &out[t + 2]);
            }
            out[t] = mul_t(&self.factors[s].inv, &acc);
        }
        for lane in 0..LANES {
            if self.pack_lines[pack * LANES + lane] == MISSING {
                continue;
            }
            for (t, v) in out.iter().enumerate() {
                let p = self.nodes[at + t][lane] as usize;
                // SAFETY: `p` is on this pack's own line, untouched by the
                // packs running meanwhile: others of its colour (lines of a
                // colour are `reach + 1` apart, couplings reach `reach`), or
                // in a flow (`multigrid::symmetric`) those not near this one.
                #[allow(unsafe_code)]
                unsafe {
                    x.write(p, get_vec(v, lane));
                }
            }
        }
    }
}
