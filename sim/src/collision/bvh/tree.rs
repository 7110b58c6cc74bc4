//! A flat bounding-volume hierarchy of axis-aligned boxes over an obstacle's
//! triangles (method.md §3, [11][12]): built once by median splits along
//! the longest axis, stored as one array of nodes in depth-first order, and
//! queried top-down with an explicit stack.
//!
//! Rigid obstacles are queried in their own frame, so their hierarchy is
//! never updated; [`Bvh::refit`] exists for deforming obstacles, whose
//! leaves move but whose topology stays.

use crate::collision::aabb::Aabb;
use crate::math::{Real, Vec3};
use std::sync::OnceLock;

/// Most primitives in one leaf.
const LEAF_SIZE: usize = 4;

#[derive(Debug, Clone, Copy)]
pub(super) struct Node {
    pub(super) aabb: Aabb,
    /// Leaf: first index into `order`; inner: index of the right child
    /// (the left child is the next node).
    pub(super) start: u32,
    /// Primitives in a leaf; 0 for an inner node.
    pub(super) count: u32,
}

/// The hierarchy over `n` primitive boxes.
#[derive(Debug, Clone)]
pub struct Bvh {
    pub(super) nodes: Vec<Node>,
    pub(super) order: Vec<u32>,
    /// Each primitive's own box, tested before it is handed out.
    pub(super) boxes: Vec<Aabb>,
    /// [`Bvh::refit`]'s node boxes before they are written to the nodes.
    fitted: Vec<Aabb>,
    /// Where a shared fold cuts the tree (`fold`), made at its first.
    pub(super) cut: OnceLock<Cut>,
}

/// Subtrees' `(root, end)` node ranges and the inner nodes above them.
pub(super) type Cut = (Vec<(usize, usize)>, Vec<usize>);

impl Bvh {
    /// Builds the hierarchy over `boxes` (one per primitive).
    pub fn build(boxes: &[Aabb]) -> Self {
        let centers: Vec<Vec3> = boxes.iter().map(Aabb::center).collect();
        Self::build_by(boxes, |part| {
            let cb = Aabb::of_points(part.iter().map(|&i| &centers[i as usize]));
            let axis = (cb.hi - cb.lo).imax();
            let mid = part.len() / 2;
            part.select_nth_unstable_by(mid, |&a, &b| {
                centers[a as usize][axis].total_cmp(&centers[b as usize][axis])
            });
            mid
        })
    }

    /// Builds the hierarchy over `boxes` with `split` choosing each inner
    /// node's children: it reorders a node's primitives and returns how
    /// many go to the left child (at least one, fewer than all).
    pub fn build_by(boxes: &[Aabb], mut split: impl FnMut(&mut [u32]) -> usize) -> Self {
        let mut bvh = Self {
            nodes: Vec::with_capacity(2 * boxes.len() / LEAF_SIZE + 1),
            order: (0..boxes.len() as u32).collect(),
            boxes: boxes.to_vec(),
            fitted: Vec::new(),
            cut: OnceLock::new(),
        };
        if !boxes.is_empty() {
            bvh.split(&mut split, 0, boxes.len());
        }
        bvh
    }

    fn split(&mut self, part: &mut impl FnMut(&mut [u32]) -> usize, lo: usize, hi: usize) -> usize {
        let boxes = &self.boxes;
        let aabb = self.order[lo..hi]
            .iter()
            .fold(Aabb::empty(), |b, &i| b.union(&boxes[i as usize]));
        let me = self.nodes.len();
        self.nodes.push(Node {
            aabb,
            start: lo as u32,
            count: (hi - lo) as u32,
        });
        if hi - lo <= LEAF_SIZE {
            return me;
        }
        let mid = lo + part(&mut self.order[lo..hi]).clamp(1, hi - lo - 1);
        self.split(part, lo, mid);
        let right = self.split(part, mid, hi);
        self.nodes[me].start = right as u32;
        self.nodes[me].count = 0;
        me
    }

    /// Recomputes every box bottom-up from new primitive boxes (same
    /// primitives, moved): for the cloth's own triangles and deforming
    /// obstacles; on the team where the tree is large
    /// ([`Bvh::fold_up_shared`]).
    pub fn refit(&mut self, boxes: &[Aabb]) {
        self.boxes.copy_from_slice(boxes);
        let mut fitted = std::mem::take(&mut self.fitted);
        self.fold_up_shared(
            &mut fitted,
            |leaf| {
                leaf.iter()
                    .fold(Aabb::empty(), |b, &i| b.union(&boxes[i as usize]))
            },
            Aabb::union,
        );
        for (n, b) in self.nodes.iter_mut().zip(&fitted) {
            n.aabb = *b;
        }
        self.fitted = fitted;
    }

    /// The root box (empty for no primitives).
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or_else(Aabb::empty, |n| n.aabb)
    }

    /// Calls `f` with every primitive whose box overlaps `query` (in no
    /// particular order); returns
    /// the nodes visited.
    pub fn query(&self, query: &Aabb, mut f: impl FnMut(usize)) -> u64 {
        let mut visited = 0;
        if self.nodes.is_empty() {
            return 0;
        }
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let k = stack[top];
            let n = &self.nodes[k as usize];
            visited += 1;
            if !n.aabb.overlaps(query) {
                continue;
            }
            if n.count > 0 {
                let s = n.start as usize;
                for &i in &self.order[s..s + n.count as usize] {
                    if self.boxes[i as usize].overlaps(query) {
                        f(i as usize);
                    }
                }
            } else {
                stack[top] = n.start;
                stack[top + 1] = k + 1;
                top += 2;
            }
        }
        visited
    }

    /// The primitive nearest to `p` by `distance2(i)` (squared distance to
    /// primitive `i`, which must be at least its box's), searched
    /// branch-and-bound nearest box first; `None` without primitives.
    /// Returns `(primitive, squared distance, nodes visited)`.
    pub fn nearest(
        &self,
        p: &Vec3,
        mut distance2: impl FnMut(usize) -> Real,
    ) -> Option<(usize, Real, u64)> {
        let mut best: Option<(usize, Real)> = None;
        let mut visited = 0;
        if self.nodes.is_empty() {
            return None;
        }
        let mut stack = [(0u32, 0.0 as Real); 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (k, d2) = stack[top];
            if best.is_some_and(|(_, b)| d2 >= b) {
                continue;
            }
            visited += 1;
            let n = &self.nodes[k as usize];
            if n.count > 0 {
                let s = n.start as usize;
                for &i in &self.order[s..s + n.count as usize] {
                    let d = distance2(i as usize);
                    if best.is_none_or(|(_, b)| d < b) {
                        best = Some((i as usize, d));
                    }
                }
            } else {
                let (l, r) = (k + 1, n.start);
                let dl = self.nodes[l as usize].aabb.distance_squared(p);
                let dr = self.nodes[r as usize].aabb.distance_squared(p);
                // Push the farther first so the nearer is searched first.
                let (first, second) = if dl <= dr {
                    ((r, dr), (l, dl))
                } else {
                    ((l, dl), (r, dr))
                };
                stack[top] = first;
                stack[top + 1] = second;
                top += 2;
            }
        }
        best.map(|(i, d)| (i, d, visited))
    }

    /// Calls `f(i, j)` for every primitive `i` of this hierarchy and `j`
    /// of `other` whose boxes overlap: both trees descended together, so
    /// each overlapping pair of nodes is visited once (far fewer visits
    /// than one query per primitive when the primitives are many and
    /// close, as a cloth's are). The order is fixed by the trees.
    pub fn pairs(&self, other: &Bvh, mut f: impl FnMut(usize, usize)) {
        if self.nodes.is_empty() || other.nodes.is_empty() {
            return;
        }
        let mut stack = vec![(0u32, 0u32)];
        while let Some((a, b)) = stack.pop() {
            self.descend(other, a, b, &mut stack, &mut f);
        }
    }

    /// One step of a two-tree descent at nodes `a` (here) and `b` (in
    /// `other`): nothing if their boxes miss, the primitive pairs of two
    /// leaves, or the children's pairs pushed on `stack`.
    pub(super) fn descend(
        &self,
        other: &Bvh,
        a: u32,
        b: u32,
        stack: &mut Vec<(u32, u32)>,
        f: &mut impl FnMut(usize, usize),
    ) {
        let (na, nb) = (&self.nodes[a as usize], &other.nodes[b as usize]);
        if !na.aabb.overlaps(&nb.aabb) {
            return;
        }
        match (na.count > 0, nb.count > 0) {
            (true, true) => {
                for &i in self.leaf(na) {
                    let bi = &self.boxes[i as usize];
                    for &j in other.leaf(nb) {
                        if bi.overlaps(&other.boxes[j as usize]) {
                            f(i as usize, j as usize);
                        }
                    }
                }
            }
            (false, true) => stack.extend([(a + 1, b), (na.start, b)]),
            (true, false) => stack.extend([(a, b + 1), (a, nb.start)]),
            (false, false) => stack.extend([
                (a + 1, b + 1),
                (a + 1, nb.start),
                (na.start, b + 1),
                (na.start, nb.start),
            ]),
        }
    }

    pub(super) fn leaf(&self, n: &Node) -> &[u32] {
        let s = n.start as usize;
        &self.order[s..s + n.count as usize]
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Tree-against-tree and self traversals find exactly the overlapping
    /// pairs brute force finds.
    #[test]
    fn pair_traversals_match_brute_force() {
        let mut rng = StdRng::seed_from_u64(11);
        let a = random_boxes(&mut rng, 300);
        let b = random_boxes(&mut rng, 200);
        let (ta, tb) = (Bvh::build(&a), Bvh::build(&b));
        let mut found = Vec::new();
        ta.pairs(&tb, |i, j| found.push((i, j)));
        found.sort_unstable();
        let mut brute = Vec::new();
        for (i, x) in a.iter().enumerate() {
            for (j, y) in b.iter().enumerate() {
                if x.overlaps(y) {
                    brute.push((i, j));
                }
            }
        }
        assert!(!brute.is_empty());
        assert_eq!(found, brute);
        let mut found = Vec::new();
        ta.self_pairs(|i, j| found.push((i.min(j), i.max(j))));
        found.sort_unstable();
        let mut brute = Vec::new();
        for i in 0..a.len() {
            for j in i + 1..a.len() {
                if a[i].overlaps(&a[j]) {
                    brute.push((i, j));
                }
            }
        }
        assert_eq!(found, brute);
    }

    use rand::{RngExt, SeedableRng, rngs::StdRng};

    pub fn random_boxes(rng: &mut StdRng, n: usize) -> Vec<Aabb> {
        (0..n)
            .map(|_| {
                let c = Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                let e = Vec3::new(
                    rng.random_range(0.0..0.1),
                    rng.random_range(0.0..0.1),
                    rng.random_range(0.0..0.1),
                );
                Aabb {
                    lo: c - e,
                    hi: c + e,
                }
            })
            .collect()
    }

    #[test]
    fn every_primitive_is_reachable_and_queries_equal_brute_force() {
        let mut rng = StdRng::seed_from_u64(11);
        for n in [1, 3, 4, 5, 17, 300] {
            let boxes = random_boxes(&mut rng, n);
            let bvh = Bvh::build(&boxes);
            // The whole space reaches every primitive exactly once.
            let mut seen = vec![0; n];
            bvh.query(
                &Aabb {
                    lo: Vec3::repeat(-10.0),
                    hi: Vec3::repeat(10.0),
                },
                |i| seen[i] += 1,
            );
            assert!(seen.iter().all(|&c| c == 1), "n = {n}");
            for _ in 0..200 {
                let q = random_boxes(&mut rng, 1)[0].grown(rng.random_range(0.0..0.3));
                let mut got = Vec::new();
                bvh.query(&q, |i| got.push(i));
                got.sort_unstable();
                let want: Vec<usize> = (0..n).filter(|&i| boxes[i].overlaps(&q)).collect();
                assert_eq!(got, want);

                let p = q.center() * 1.5;
                let (k, d2, _) = bvh
                    .nearest(&p, |i| boxes[i].distance_squared(&p))
                    .expect("some");
                let best = boxes
                    .iter()
                    .map(|b| b.distance_squared(&p))
                    .fold(Real::INFINITY, Real::min);
                assert_eq!(d2, best);
                assert_eq!(boxes[k].distance_squared(&p), best);
            }
        }
        assert!(Bvh::build(&[]).nearest(&Vec3::zeros(), |_| 0.0).is_none());
    }

    #[test]
    fn refit_matches_a_rebuild_of_moved_boxes() {
        let mut rng = StdRng::seed_from_u64(5);
        let boxes = random_boxes(&mut rng, 100);
        let mut bvh = Bvh::build(&boxes);
        let shift = Vec3::new(0.5, -0.25, 2.0);
        let moved: Vec<Aabb> = boxes
            .iter()
            .map(|b| Aabb {
                lo: b.lo + shift,
                hi: b.hi + shift,
            })
            .collect();
        bvh.refit(&moved);
        assert_eq!(bvh.bounds(), Bvh::build(&moved).bounds());
        for _ in 0..100 {
            let q = random_boxes(&mut rng, 1)[0].grown(0.2);
            let q = Aabb {
                lo: q.lo + shift,
                hi: q.hi + shift,
            };
            let mut got = Vec::new();
            bvh.query(&q, |i| got.push(i));
            got.sort_unstable();
            let want: Vec<usize> = (0..100).filter(|&i| moved[i].overlaps(&q)).collect();
            assert_eq!(got, want);
        }
    }
}
