//! The contour condition of normal-cone culling (Volino &
//! Magnenat-Thalmann 1994): a patch whose normals all lie within 90° of
//! an axis `a` is locally a graph over the plane normal to `a`, but it is
//! a graph (and so cannot meet itself) only if its boundary, projected on
//! that plane, does not cross itself — an immersed disk whose boundary
//! curve is simple is embedded. The cone alone is not enough: the crumpled
//! free corner of a cloth folded fast onto itself (the stress suite's
//! "fast fold" under BDF2) wound a 2 × 4 patch over itself with every
//! normal inside the cone, and an edge passed through a triangle there
//! unseen.
//!
//! Each hierarchy node's boundary edges are found once, bottom-up: an
//! edge is on a node's boundary if exactly one of the node's triangles
//! has it, so a parent's boundary is the symmetric difference of its
//! children's. A node whose boundary is not one closed loop (its
//! triangles touch at a vertex only, or enclose a hole) is never culled.
//!
//! Over a step the test is conservative: two boundary edges that share
//! no vertex must be farther apart in projection at the start than the
//! most their ends move, within the plane, relative to each other over
//! the step, so the projected boundary stays simple throughout. (A piecewise-linear
//! patch can also wind twice about one vertex with every triangle
//! inside the cone; that needs an angle sum of 720° at a vertex, which
//! is not tested.)

use crate::collision::Bvh;
use crate::math::{Real, Vec3};

use super::geometry::segment_segment;

/// Every hierarchy node's boundary, or none where it is not one loop.
#[derive(Debug, Clone, Default)]
pub struct Contours {
    /// Boundary edges (indices into the mesh's edges), node after node.
    edges: Vec<u32>,
    /// Per node, its range in `edges`; `None` if not one closed loop.
    ranges: Vec<Option<(u32, u32)>>,
}

/// A motion the contour test holds over: every particle moves linearly
/// from `x0` to `x1` and, besides, anywhere within `slack` of that path.
#[derive(Debug, Clone, Copy)]
pub struct Sweep<'a> {
    /// Positions at the start.
    pub x0: &'a [Vec3],
    /// Positions at the end.
    pub x1: &'a [Vec3],
    /// How far each particle may stray from its path, metres.
    pub slack: Slack<'a>,
}

/// How far particles may stray from their paths.
#[derive(Debug, Clone, Copy)]
pub enum Slack<'a> {
    /// Not at all.
    None,
    /// Each particle its own distance.
    Each(&'a [Real]),
}

impl Slack<'_> {
    /// Particle `k`'s.
    #[inline]
    fn of(&self, k: usize) -> Real {
        match self {
            Slack::None => 0.0,
            Slack::Each(s) => s[k],
        }
    }
}

/// Scratch of one test: each boundary edge's projected ends, its reach
/// (how far its ends move within the plane) and its extent along the
/// sweep direction.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    items: Vec<Item>,
}

#[derive(Debug, Clone, Copy)]
struct Item {
    ends: [u32; 2],
    p: Vec3,
    q: Vec3,
    /// The ends' motions within the plane.
    dp: Vec3,
    dq: Vec3,
    /// How far its points may stray besides (the larger of its ends').
    slack: Real,
    lo: Real,
    hi: Real,
}

impl Contours {
    /// The boundaries of `bvh`'s nodes over `triangles`, whose edges are
    /// `mesh_edges` (sorted, smaller vertex first); a node whose boundary
    /// is not one closed loop gets none.
    pub fn build(bvh: &Bvh, triangles: &[[u32; 3]], mesh_edges: &[[u32; 2]]) -> Self {
        let edge = |a: u32, b: u32| {
            let key = [a.min(b), a.max(b)];
            mesh_edges.partition_point(|e| *e < key) as u32
        };
        let mut sets: Vec<Vec<u32>> = Vec::new();
        bvh.fold_up(
            &mut sets,
            |leaf| {
                let mut all: Vec<u32> = leaf
                    .iter()
                    .flat_map(|&t| {
                        let [a, b, c] = triangles[t as usize];
                        [edge(a, b), edge(b, c), edge(c, a)]
                    })
                    .collect();
                all.sort_unstable();
                odd_ones(&all)
            },
            |l, r| symmetric_difference(l, r),
        );
        let mut out = Self::default();
        for set in &sets {
            let start = out.edges.len() as u32;
            out.edges.extend_from_slice(set);
            let looped = !set.is_empty() && one_loop(set, mesh_edges);
            out.ranges
                .push(Some((start, out.edges.len() as u32)).filter(|_| looped));
        }
        out
    }

    /// Whether node `node`'s boundary, projected along `axis` (unit), is
    /// simple at the start of `sweep` and stays so over it.
    pub fn simple(
        &self,
        node: usize,
        axis: &Vec3,
        mesh_edges: &[[u32; 2]],
        sweep: &Sweep<'_>,
        scratch: &mut Scratch,
    ) -> bool {
        let Sweep { x0, x1, slack } = *sweep;
        let Some(Some((s, e))) = self.ranges.get(node).copied() else {
            return false;
        };
        let flat = |v: Vec3| v - axis * axis.dot(&v);
        // Sweep along a direction of the plane.
        let sweep = flat(if axis.x.abs() < 0.9 {
            Vec3::x()
        } else {
            Vec3::y()
        })
        .normalize();
        let items = &mut scratch.items;
        items.clear();
        for &k in &self.edges[s as usize..e as usize] {
            let ends = mesh_edges[k as usize];
            let [a, b] = ends.map(|v| v as usize);
            let (p, q) = (flat(x0[a]), flat(x0[b]));
            let (dp, dq) = (flat(x1[a] - x0[a]), flat(x1[b] - x0[b]));
            let slack = slack.of(a).max(slack.of(b));
            let reach = dp.norm().max(dq.norm()) + slack;
            let (u, v) = (sweep.dot(&p), sweep.dot(&q));
            items.push(Item {
                ends,
                p,
                q,
                dp,
                dq,
                slack,
                lo: u.min(v) - reach,
                hi: u.max(v) + reach,
            });
        }
        items.sort_unstable_by(|a, b| a.lo.total_cmp(&b.lo));
        for (i, a) in items.iter().enumerate() {
            for b in &items[i + 1..] {
                if b.lo > a.hi {
                    break;
                }
                if a.ends.iter().any(|v| b.ends.contains(v)) {
                    continue;
                }
                let (s, t) = segment_segment(&a.p, &a.q, &b.p, &b.q);
                let gap = (a.p + (a.q - a.p) * s) - (b.p + (b.q - b.p) * t);
                // A point of each edge moves by a mix of its ends'
                // motions, so their distance changes by at most the
                // largest difference of an end's motion from another's.
                let relative = [a.dp, a.dq]
                    .iter()
                    .flat_map(|u| [b.dp, b.dq].map(|v| (u - v).norm()))
                    .fold(0.0, Real::max);
                // Crossing edges are at a distance of rounding error.
                let margin = 1e-9 * (a.q - a.p).norm().max((b.q - b.p).norm());
                if gap.norm() <= relative + a.slack + b.slack + margin {
                    return false;
                }
            }
        }
        true
    }
}

/// The values of a sorted list that occur an odd number of times.
fn odd_ones(sorted: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    let mut k = 0;
    while k < sorted.len() {
        let mut n = 1;
        while k + n < sorted.len() && sorted[k + n] == sorted[k] {
            n += 1;
        }
        if n % 2 == 1 {
            out.push(sorted[k]);
        }
        k += n;
    }
    out
}

/// The values in exactly one of two sorted lists.
fn symmetric_difference(a: &[u32], b: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            std::cmp::Ordering::Less => {
                out.push(a[i]);
                i += 1;
            }
            std::cmp::Ordering::Greater => {
                out.push(b[j]);
                j += 1;
            }
            std::cmp::Ordering::Equal => {
                i += 1;
                j += 1;
            }
        }
    }
    out.extend_from_slice(&a[i..]);
    out.extend_from_slice(&b[j..]);
    out
}

/// Whether `boundary` (edge indices) is one closed loop: every vertex on
/// it has two of its edges, and walking from one edge visits them all.
fn one_loop(boundary: &[u32], mesh_edges: &[[u32; 2]]) -> bool {
    let mut ends: Vec<(u32, u32)> = boundary
        .iter()
        .flat_map(|&k| {
            let [a, b] = mesh_edges[k as usize];
            [(a, k), (b, k)]
        })
        .collect();
    ends.sort_unstable();
    // Each vertex exactly twice.
    if ends.len() < 6 || ends.chunks(2).any(|c| c[0].0 != c[1].0) {
        return false;
    }
    for w in ends.windows(3) {
        if w[0].0 == w[2].0 {
            return false;
        }
    }
    let other_edge = |v: u32, k: u32| -> u32 {
        let at = ends.partition_point(|&(u, _)| u < v);
        if ends[at].1 == k {
            ends[at + 1].1
        } else {
            ends[at].1
        }
    };
    // Walk the loop from the first edge.
    let start = boundary[0];
    let [first, mut v] = mesh_edges[start as usize];
    let mut k = start;
    let mut steps = 1;
    while v != first {
        k = other_edge(v, k);
        let [a, b] = mesh_edges[k as usize];
        v = if a == v { b } else { a };
        steps += 1;
        if steps > boundary.len() {
            return false;
        }
    }
    steps == boundary.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_ones_and_symmetric_difference() {
        assert_eq!(odd_ones(&[1, 2, 2, 3, 3, 3, 4]), vec![1, 3, 4]);
        assert_eq!(
            symmetric_difference(&[1, 3, 5, 7], &[3, 4, 7, 9]),
            vec![1, 4, 5, 9]
        );
    }

    /// A square of two triangles has one loop of four edges; two
    /// triangles meeting at a vertex only have none.
    #[test]
    fn loops() {
        let edges = [
            [0, 1],
            [1, 2],
            [2, 3],
            [0, 3],
            [0, 2],
            [2, 4],
            [4, 5],
            [2, 5],
        ];
        assert!(one_loop(&[0, 1, 2, 3], &edges));
        // Triangles (0, 1, 2) and (2, 4, 5): a bow tie at vertex 2.
        assert!(!one_loop(&[0, 1, 4, 5, 6, 7], &edges));
    }

    /// A strip wound one and a quarter turns about a vertical axis, its
    /// turns 1 cm apart: every normal within 3° of the axis, so the cone
    /// alone would skip the whole strip, but its projected boundary
    /// overlaps itself, so the turns' pairs are found; laid out flat, the
    /// same strip is skipped whole and has no pair at all.
    #[test]
    fn a_wound_strip_is_not_skipped_but_a_flat_one_is() {
        use super::super::topology::ClothMesh;
        let (nu, nv) = (40, 3);
        let (radius, pitch, width) = (0.3, 0.01, 0.04);
        let turns = 1.25;
        let length = turns * std::f64::consts::TAU * radius;
        let grid = crate::testing::flat_grid(nu, nv, [length, width]);
        let wound: Vec<Vec3> = (0..nu * nv)
            .map(|k| {
                let (i, j) = ((k % nu) as Real, (k / nu) as Real);
                let theta = turns * std::f64::consts::TAU * i / (nu - 1) as Real;
                let r = radius + width * j / (nv - 1) as Real;
                Vec3::new(
                    r * theta.cos(),
                    r * theta.sin(),
                    pitch * theta / std::f64::consts::TAU,
                )
            })
            .collect();
        let pairs = |x: &[Vec3]| {
            let mut mesh = ClothMesh::new(&grid);
            mesh.refit(x, x, 2.0 * pitch);
            let (mut vf, mut ee) = (Vec::new(), Vec::new());
            mesh.feature_pairs(&mut vf, &mut ee);
            // Pairs between the turns: columns more than a turn's
            // worth apart.
            let apart = |p: u32, q: u32| (p as usize % nu).abs_diff(q as usize % nu) > nu / 2;
            let across = vf
                .iter()
                .filter(|&&(v, t)| apart(v, mesh.triangles[t as usize][0]))
                .count();
            (vf.len() + ee.len(), across)
        };
        let (_, across) = pairs(&wound);
        assert!(across > 0, "the turns' vertex-triangle pairs are found");
        let (all, _) = pairs(&grid.rest);
        assert_eq!(all, 0, "a flat strip is skipped whole");
    }
}
