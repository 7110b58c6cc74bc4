//! Axis-aligned bounding boxes: the volumes of the hierarchy (method.md §3
//! [11][12]) and of whole-cloth and whole-obstacle culling.

use crate::math::{Real, Vec3};

/// A box `[lo, hi]`; empty when any `lo > hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub lo: Vec3,
    /// Upper corner.
    pub hi: Vec3,
}

/// The empty box, the identity of [`Aabb::union`].
impl Default for Aabb {
    fn default() -> Self {
        Self::empty()
    }
}

impl Aabb {
    /// The empty box (the identity of [`Aabb::union`]).
    pub fn empty() -> Self {
        Self {
            lo: Vec3::repeat(Real::INFINITY),
            hi: Vec3::repeat(Real::NEG_INFINITY),
        }
    }

    /// The box of some points.
    pub fn of_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Self {
        points.into_iter().fold(Self::empty(), |b, p| b.with(p))
    }

    /// The box of a segment.
    #[inline]
    pub fn of_segment(a: &Vec3, b: &Vec3) -> Self {
        Self {
            lo: a.inf(b),
            hi: a.sup(b),
        }
    }

    /// This box grown to contain `p`.
    #[inline]
    pub fn with(&self, p: &Vec3) -> Self {
        Self {
            lo: self.lo.inf(p),
            hi: self.hi.sup(p),
        }
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Self {
        Self {
            lo: self.lo.inf(&o.lo),
            hi: self.hi.sup(&o.hi),
        }
    }

    /// Grown by `r` on every side.
    #[inline]
    pub fn grown(&self, r: Real) -> Self {
        Self {
            lo: self.lo - Vec3::repeat(r),
            hi: self.hi + Vec3::repeat(r),
        }
    }

    /// `true` when the boxes share a point.
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        // PERF: all six comparisons, joined without branches: where
        // candidate pairs are filtered, which axis fails follows no
        // pattern a branch predictor learns (docs/benchmarks.md 1r).
        (self.lo.x <= o.hi.x)
            & (o.lo.x <= self.hi.x)
            & (self.lo.y <= o.hi.y)
            & (o.lo.y <= self.hi.y)
            & (self.lo.z <= o.hi.z)
            & (o.lo.z <= self.hi.z)
    }

    /// `true` when `p` is inside or on the box.
    #[inline]
    pub fn contains(&self, p: &Vec3) -> bool {
        (0..3).all(|k| self.lo[k] <= p[k] && p[k] <= self.hi[k])
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    pub fn distance_squared(&self, p: &Vec3) -> Real {
        (0..3)
            .map(|k| {
                let d = (self.lo[k] - p[k]).max(p[k] - self.hi[k]).max(0.0);
                d * d
            })
            .sum()
    }

    /// Centre.
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.lo + self.hi) / 2.0
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|k| {
            Vec3::new(
                if k & 1 == 0 { self.lo.x } else { self.hi.x },
                if k & 2 == 0 { self.lo.y } else { self.hi.y },
                if k & 4 == 0 { self.lo.z } else { self.hi.z },
            )
        })
    }
}
