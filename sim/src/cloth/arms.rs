//! The arms of the angle elements, each measured once per assembly.
//!
//! A bending hinge and a shear corner both start from their arms' lengths
//! and unit vectors (`AngleGeom`), and on a grid every arm is a grid edge
//! shared by up to six elements: two hinges (one centred at each end) and
//! four shear corners (two quads, a corner at each end). Measured per
//! element, each edge's square root and three divisions were taken six
//! times. [`ArmTable`] measures each distinct arm once; an element reads
//! its two by [`ArmRef`].
//!
//! The arm from `b` to `a` is the table's edge `(lo, hi)` read forwards
//! (`x_hi - x_lo`) or negated. Negation is exact in floating point
//! (`x - y = -(y - x)`, `|-d| = |d|`, `(-d) / r = -(d / r)`), so an
//! element's geometry is bit for bit the one it would measure itself.

use super::angle::{AngleElement, Arm};
use crate::math::{Real, Vec3};

/// One arm of one element: an edge of the table, read forwards or
/// backwards.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArmRef(u32);

impl ArmRef {
    fn new(edge: usize, backwards: bool) -> Self {
        Self(((edge as u32) << 1) | u32::from(backwards))
    }

    fn edge(self) -> usize {
        (self.0 >> 1) as usize
    }

    fn backwards(self) -> bool {
        self.0 & 1 == 1
    }
}

/// The distinct arms of a set of angle elements, and their current
/// lengths and directions.
#[derive(Debug, Clone, Default)]
pub struct ArmTable {
    /// Each edge's particles `(lo, hi)`, `lo < hi`.
    ends: Vec<[u32; 2]>,
    /// Each edge's `|x_hi - x_lo|` and `(x_hi - x_lo) / |x_hi - x_lo|`.
    measured: Vec<Arm>,
}

impl ArmTable {
    /// The table of every arm of `forces`' elements, and for each force,
    /// each element's two arms (`b -> a`, `b -> c` for `[a, b, c]`).
    pub fn new<const N: usize>(forces: [&[AngleElement]; N]) -> (Self, [Vec<[ArmRef; 2]>; N]) {
        let ends_of = |from: usize, to: usize| [from.min(to) as u32, from.max(to) as u32];
        // PERF: edges in the order of their particles, not of the elements
        // that first named them (a weft hinge's arms, numbered line by line,
        // lay a grid row apart): the assembly, which adds the elements row
        // by row, then reads the table in order.
        let mut ends: Vec<[u32; 2]> = forces
            .iter()
            .flat_map(|elements| elements.iter())
            .flat_map(|el| {
                let [a, b, c] = el.idx;
                [ends_of(b, a), ends_of(b, c)]
            })
            .collect();
        ends.sort_unstable();
        ends.dedup();
        // Forwards is `x_hi - x_lo`: the arm `x_to - x_from` when `to` is
        // the higher index.
        let arm = |from: usize, to: usize| {
            let edge = ends.binary_search(&ends_of(from, to)).unwrap_or_default();
            ArmRef::new(edge, to < from)
        };
        let refs = forces.map(|elements| {
            elements
                .iter()
                .map(|el| {
                    let [a, b, c] = el.idx;
                    [arm(b, a), arm(b, c)]
                })
                .collect()
        });
        let measured = vec![None; ends.len()];
        (Self { ends, measured }, refs)
    }

    /// Measures every arm at positions `x`, the arm `e = x_hi - x_lo`
    /// exactly as `AngleGeom::new` measures its own.
    pub fn measure(&mut self, x: &[Vec3]) {
        let ends = &self.ends;
        crate::parallel::for_chunks(&mut self.measured, |start, out| {
            for (k, m) in out.iter_mut().enumerate() {
                let [lo, hi] = ends[start + k];
                let e = x[hi as usize] - x[lo as usize];
                let r = e.norm();
                *m = (r > Real::MIN_POSITIVE.sqrt()).then(|| (r, e / r));
            }
        });
    }

    /// The arm `r`: its length and unit vector as last measured.
    #[inline]
    pub fn get(&self, r: ArmRef) -> Arm {
        self.measured[r.edge()].map(|(len, u)| (len, if r.backwards() { -u } else { u }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::{AngleGeom, Bend, Shear, fdcheck};

    /// Every bend and shear element of a crumpled grid, its geometry from
    /// the table against the one it measures itself: bit for bit, arms
    /// read forwards and backwards, and a collapsed arm is no angle.
    #[test]
    fn an_elements_arms_from_the_table_are_the_ones_it_measures() {
        let (grid, mut x, _) = fdcheck::random_configuration(7, 5, 0.4, 3);
        let bend = Bend::on_grid(&grid, 1e-3, 0.0, &[]);
        let shear = Shear::on_grid(&grid, 50.0, 0.0);
        // One arm collapsed: particle 8 onto its neighbour 9.
        x[8] = x[9];
        let (mut table, refs) = ArmTable::new([&bend.elements, &shear.elements]);
        // Each grid edge once: (nu - 1) nv + nu (nv - 1).
        assert_eq!(table.ends.len(), 6 * 5 + 7 * 4);
        table.measure(&x);
        let (mut backwards, mut collapsed) = (0, 0);
        for (elements, refs) in [(&bend.elements, &refs[0]), (&shear.elements, &refs[1])] {
            assert_eq!(elements.len(), refs.len());
            for (el, &[r1, r2]) in elements.iter().zip(refs) {
                let [a, b, c] = el.idx;
                let own = AngleGeom::new(&x[a], &x[b], &x[c]);
                let read = AngleGeom::from_arms(table.get(r1), table.get(r2));
                backwards += usize::from(r1.backwards()) + usize::from(r2.backwards());
                let Some(own) = own else {
                    assert!(read.is_none(), "{:?}", el.idx);
                    collapsed += 1;
                    continue;
                };
                let read = read.expect("measured");
                assert_eq!(
                    (own.r1, own.r2, own.u, own.w),
                    (read.r1, read.r2, read.u, read.w)
                );
                assert_eq!(
                    (own.f, own.g1, own.g2, own.sin),
                    (read.f, read.g1, read.g2, read.sin)
                );
            }
        }
        assert!(backwards > 0 && collapsed > 0, "{backwards} {collapsed}");
    }
}
