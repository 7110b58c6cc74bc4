//! A query's boxes in single precision, rounded outward: for the filter
//! that takes a plan's pairs for one motion (`super::plan`), and for the
//! refitted hierarchy and the pair tests of its descent
//! (`super::topology`).
//!
//! PERF: the filter tests ~6,400 planned pairs a query on sphere-drape-30
//! (~1,400 vertex–triangle, ~5,000 edge–edge; ~700 kept), two or three
//! queries a step. With double-precision boxes a test took ~66
//! instructions; a box of four `f32` lanes is one register, and a test is
//! two packed comparisons.
//!
//! Each box holds the double-precision one (`lo` rounded down, `hi` up),
//! so every pair whose double-precision boxes overlap is kept. The few
//! more it may keep are separated by more than the pad, so they act on
//! nothing: the response and the couplings act only on pairs within the
//! pad, and the frames do not change.

use crate::collision::Aabb;
use crate::math::{Real, Vec3};
use crate::parallel;

/// `[lo, hi]` in four lanes (the fourth is zero in both, so it never
/// separates two boxes).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
pub struct Box32 {
    lo: [f32; 4],
    hi: [f32; 4],
}

impl Box32 {
    /// The empty box.
    pub const EMPTY: Self = Self {
        lo: [f32::INFINITY, f32::INFINITY, f32::INFINITY, 0.0],
        hi: [f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY, 0.0],
    };

    /// The box of the segment from `a` to `b` grown by `r` on every side,
    /// rounded outward.
    #[inline]
    pub fn of_segment(a: &Vec3, b: &Vec3, r: Real) -> Self {
        let lo = a.inf(b).add_scalar(-r);
        let hi = a.sup(b).add_scalar(r);
        Self {
            lo: [down(lo.x), down(lo.y), down(lo.z), 0.0],
            hi: [up(hi.x), up(hi.y), up(hi.z), 0.0],
        }
    }

    /// The same box in double precision (exactly).
    pub fn to_aabb(self) -> Aabb {
        let v = |a: [f32; 4]| Vec3::new(a[0].into(), a[1].into(), a[2].into());
        Aabb {
            lo: v(self.lo),
            hi: v(self.hi),
        }
    }

    /// The smallest box holding both.
    #[inline(always)]
    pub fn union(&self, o: &Self) -> Self {
        let mut out = *self;
        for k in 0..4 {
            out.lo[k] = if o.lo[k] < out.lo[k] {
                o.lo[k]
            } else {
                out.lo[k]
            };
            out.hi[k] = if o.hi[k] > out.hi[k] {
                o.hi[k]
            } else {
                out.hi[k]
            };
        }
        out
    }

    /// Whether the boxes share a point: all eight comparisons, joined
    /// without a branch (which axis fails follows no pattern a branch
    /// predictor learns).
    #[inline(always)]
    pub fn overlaps(&self, o: &Self) -> bool {
        let mut all = true;
        for k in 0..4 {
            all &= (self.lo[k] <= o.hi[k]) & (o.lo[k] <= self.hi[k]);
        }
        all
    }
}

/// A margin wider than the rounding of `v` to `f32` (half an `f32` ulp,
/// `|v| 2⁻²⁴`, or the spacing of subnormals near zero): moved by it and
/// then rounded to nearest, a bound stays on its side. PERF: no
/// `next_down` per component (136 instructions a vertex box with it).
#[inline(always)]
fn margin(v: Real) -> Real {
    v.abs() * (1.0 / (1u64 << 22) as Real) + 1e-30
}

/// An `f32` at most `v`.
#[inline(always)]
fn down(v: Real) -> f32 {
    (v - margin(v)) as f32
}

/// An `f32` at least `v`.
#[inline(always)]
fn up(v: Real) -> f32 {
    (v + margin(v)) as f32
}

/// One query's boxes: each vertex's over its motion, grown by half the
/// pad, and each edge's and triangle's, the union of its vertices'.
#[derive(Debug, Clone, Default)]
pub struct QueryBoxes {
    /// Per vertex.
    pub vertices: Vec<Box32>,
    /// Per edge.
    pub edges: Vec<Box32>,
    /// Per triangle ([`QueryBoxes::fit_triangles`]).
    pub triangles: Vec<Box32>,
}

impl QueryBoxes {
    /// The boxes of the motion from `x0` to `x1` with pad `pad`, for a
    /// mesh with edges `edges`.
    pub fn fit(&mut self, x0: &[Vec3], x1: &[Vec3], pad: Real, edges: &[[u32; 2]]) {
        self.fit_each(x0, x1, |_| 0.5 * pad, edges);
    }

    /// [`Self::fit`] with each vertex's box grown by its own `grow(k)`.
    pub fn fit_each(
        &mut self,
        x0: &[Vec3],
        x1: &[Vec3],
        grow: impl Fn(usize) -> Real + Sync,
        edges: &[[u32; 2]],
    ) {
        let min = 4 * parallel::ROWS_MIN;
        self.vertices.resize(x0.len(), Box32::EMPTY);
        parallel::for_chunks_min(&mut self.vertices, min, |start, boxes| {
            for (k, ((b, a), e)) in boxes
                .iter_mut()
                .zip(&x0[start..])
                .zip(&x1[start..])
                .enumerate()
            {
                *b = Box32::of_segment(a, e, grow(start + k));
            }
        });
        self.edges.resize(edges.len(), Box32::EMPTY);
        let vertices = &self.vertices;
        parallel::for_chunks_min(&mut self.edges, min, |start, boxes| {
            for (b, e) in boxes.iter_mut().zip(&edges[start..]) {
                *b = vertices[e[0] as usize].union(&vertices[e[1] as usize]);
            }
        });
    }

    /// The triangles' boxes, from the vertices' of the last [`Self::fit`].
    pub fn fit_triangles(&mut self, triangles: &[[u32; 3]]) {
        self.triangles.resize(triangles.len(), Box32::EMPTY);
        let vertices = &self.vertices;
        parallel::for_chunks_min(
            &mut self.triangles,
            4 * parallel::ROWS_MIN,
            |start, boxes| {
                for (b, t) in boxes.iter_mut().zip(&triangles[start..]) {
                    let [p, q, r] = t.map(|k| &vertices[k as usize]);
                    *b = p.union(q).union(r);
                }
            },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng, rngs::StdRng};

    /// Every pair of double-precision boxes that overlaps overlaps here
    /// too, and boxes apart by more than the rounding stay apart.
    #[test]
    fn holds_the_double_precision_box_and_keeps_every_overlap() {
        let mut rng = StdRng::seed_from_u64(5);
        let mut point = || {
            Vec3::new(
                rng.random_range(-0.6..0.6),
                rng.random_range(-0.6..0.6),
                rng.random_range(-0.6..0.6),
            )
        };
        let mut overlapping = 0;
        for i in 0..20_000 {
            let (a0, a1, b0, b1) = (point(), point() * 0.01, point(), point() * 0.01);
            let (a1, mut b1) = (a0 + a1, b0 + b1);
            let pad = 0.3;
            // Every fourth pair: the first box moved along x until the
            // two (nearly) touch.
            let mut b0 = b0;
            if i % 4 == 0 {
                let shift = Vec3::x() * ((a0.x - a1.x).abs() + pad);
                (b0, b1) = (a0 + shift, a1 + shift);
            }
            let exact = |p: &Vec3, q: &Vec3| Aabb::of_segment(p, q).grown(0.5 * pad);
            let (ea, eb) = (exact(&a0, &a1), exact(&b0, &b1));
            let (fa, fb) = (
                Box32::of_segment(&a0, &a1, 0.5 * pad),
                Box32::of_segment(&b0, &b1, 0.5 * pad),
            );
            for (e, f) in [(&ea, &fa), (&eb, &fb)] {
                for k in 0..3 {
                    assert!(f.lo[k] as Real <= e.lo[k] && e.hi[k] <= f.hi[k] as Real);
                }
                let back = f.to_aabb();
                assert!(back.lo.x == f.lo[0] as Real && back.hi.z == f.hi[2] as Real);
            }
            let gap = (0..3)
                .map(|k| (ea.lo[k] - eb.hi[k]).max(eb.lo[k] - ea.hi[k]))
                .fold(Real::NEG_INFINITY, Real::max);
            if ea.overlaps(&eb) {
                overlapping += 1;
                assert!(fa.overlaps(&fb));
            } else if gap > 1e-5 {
                assert!(!fa.overlaps(&fb), "gap {gap}");
            }
            assert!(fa.union(&fb).overlaps(&fa) && fa.union(&fb).overlaps(&fb));
        }
        // The touching quarter, and more.
        assert!(overlapping > 5_000, "{overlapping}");
        assert!(!Box32::EMPTY.overlaps(&Box32::EMPTY));
    }
}
