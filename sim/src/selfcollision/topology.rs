//! The cloth as a triangle mesh for self-collision: its triangles (two per
//! grid quad, `Grid::triangles`), its edges once each, and one hierarchy
//! over the triangles that every query of a step shares.
//!
//! The hierarchy is built once over the rest shape (median splits, so its
//! nodes are patches of the grid) and only refitted afterwards: a
//! deforming cloth keeps its topology, and a patch of the grid stays a
//! compact region of the cloth however it folds.
//!
//! Vertices and edges are not in trees of their own: each is owned by the
//! first triangle that has it, and the triangles' boxes hold their
//! features' boxes, so two features whose boxes overlap have owners whose
//! boxes overlap (Curtis, Tamstorf & Manocha 2008, "Fast collision
//! detection for deformable models using representative-triangles"). One
//! self-traversal of the triangle tree then finds every vertex–triangle,
//! edge–edge and edge–triangle pair, and skips whole patches whose normal
//! cone shows they cannot meet themselves (`super::cones`).

use super::budget;
use super::cones::{self, Cone};
use super::contour::{self, Contours, Slack, Sweep};
use super::geometry::segment_crosses_triangle;
use super::kept::extend_kept;
use super::query_boxes::QueryBoxes;
use crate::cloth::Grid;
use crate::collision::{Aabb, Bvh, BvhTask as Task};
use crate::math::{Real, Vec3};
use crate::parallel;

/// Triangles, edges, their owners and the hierarchy.
#[derive(Debug, Clone)]
pub struct ClothMesh {
    /// Particles along `u` (particle `(i, j)` is `i + j * nu`).
    nu: usize,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Vertex indices of each edge, smaller first, sorted.
    pub edges: Vec<[u32; 2]>,
    /// The vertices and the edges each triangle owns.
    owned: Vec<Owned>,
    pub(super) tri_bvh: Bvh,
    /// The triangles' boxes the hierarchy is refitted to: those of
    /// `boxes`, in double precision.
    pub(super) tri_boxes: Vec<Aabb>,
    /// Each vertex's, edge's and triangle's box over the last refit's
    /// motion, in single precision rounded outward (`super::query_boxes`:
    /// the pairs that act are those of the exact boxes).
    boxes: QueryBoxes,
    /// Per hierarchy node, the cone of its patch's normals over the last
    /// refit's motion: a flat one cannot meet itself.
    cones: Vec<Cone>,
    /// Per triangle, the cone of its normals over the last refit's motion.
    tri_cones: Vec<Cone>,
    /// A planned query's boxes (`super::plan::Plan::pairs`).
    pub(super) query: QueryBoxes,
    /// Per hierarchy node, its boundary: a flat patch is culled only if
    /// its projected boundary stays simple.
    pub(super) contours: Contours,
    /// The shortest edge at rest.
    pub(super) spacing: Real,
    contour_scratch: contour::Scratch,
    /// A gather's seeds and pieces (`ClothMesh::gather`), kept between
    /// steps.
    seeds: Vec<Task>,
    pieces: Vec<Piece>,
    /// A planned query's pairs, filtered a piece at a time
    /// (`super::plan::Plan::pairs`), kept between steps.
    pub(super) filtered: Vec<Lists>,
    /// The last refit's motion.
    x0: Vec<Vec3>,
    x1: Vec<Vec3>,
    /// Candidate pairs a gather may hold (`super::budget`).
    pub(super) pair_budget: usize,
}

impl ClothMesh {
    /// The mesh of `grid`, its hierarchy over the rest positions.
    pub fn new(grid: &Grid) -> Self {
        let triangles = grid.triangles();
        // Every edge with the triangles that have it, in edge then triangle
        // order: the first of each edge is its owner.
        let mut with_triangle: Vec<([u32; 2], u32)> = triangles
            .iter()
            .enumerate()
            .flat_map(|(t, tri)| {
                [[tri[0], tri[1]], [tri[1], tri[2]], [tri[2], tri[0]]]
                    .map(|[a, b]| ([a.min(b), a.max(b)], t as u32))
            })
            .collect();
        with_triangle.sort_unstable();
        with_triangle.dedup_by_key(|(e, _)| *e);
        let (edges, edge_owner): (Vec<[u32; 2]>, Vec<u32>) = with_triangle.into_iter().unzip();
        let x = &grid.rest;
        // A vertex's owner: the first triangle with it.
        let mut vertex_owner = vec![u32::MAX; x.len()];
        for (t, tri) in triangles.iter().enumerate() {
            for &v in tri {
                if vertex_owner[v as usize] == u32::MAX {
                    vertex_owner[v as usize] = t as u32;
                }
            }
        }
        let mut owned = vec![Owned::default(); triangles.len()];
        for (v, &t) in vertex_owner.iter().enumerate() {
            if let Some(o) = owned.get_mut(t as usize) {
                o.vertices.push(v as u32);
            }
        }
        for (e, &t) in edge_owner.iter().enumerate() {
            owned[t as usize].edges.push(e as u32);
        }
        let tri_boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| Aabb::of_points(t.iter().map(|&k| &x[k as usize])))
            .collect();
        // Nodes are rectangles of grid quads (both triangles of each), cut
        // across their longer side: every node's boundary is one loop,
        // which the contour test needs (median splits of the triangles
        // left three nodes in four pinched at a vertex or in pieces).
        let cells = grid.nu - 1;
        let tri_bvh = Bvh::build_by(&tri_boxes, |part| {
            let cell = |t: u32| ((t as usize / 2) % cells, (t as usize / 2) / cells);
            let (mut lo, mut hi) = ((usize::MAX, usize::MAX), (0, 0));
            for &t in part.iter() {
                let (i, j) = cell(t);
                lo = (lo.0.min(i), lo.1.min(j));
                hi = (hi.0.max(i), hi.1.max(j));
            }
            let along_u = hi.0 - lo.0 >= hi.1 - lo.1;
            let key = |t: u32| if along_u { cell(t).0 } else { cell(t).1 };
            let cut = if along_u { lo.0 + hi.0 } else { lo.1 + hi.1 }.div_ceil(2);
            part.sort_unstable_by_key(|&t| (key(t) >= cut, t));
            part.partition_point(|&t| key(t) < cut)
        });
        let contours = Contours::build(&tri_bvh, &triangles, &edges);
        // The boxes at rest until the first refit.
        let mut boxes = QueryBoxes::default();
        boxes.fit(x, x, 0.0, &edges);
        boxes.fit_triangles(&triangles);
        let spacing = edges
            .iter()
            .map(|e| (x[e[0] as usize] - x[e[1] as usize]).norm())
            .fold(Real::INFINITY, Real::min);
        Self {
            spacing,
            nu: grid.nu,
            tri_bvh,
            contours,
            contour_scratch: contour::Scratch::default(),
            seeds: Vec::new(),
            pieces: Vec::new(),
            filtered: Vec::new(),
            query: QueryBoxes::default(),
            x0: Vec::new(),
            x1: Vec::new(),
            triangles,
            edges,
            owned,
            tri_boxes,
            boxes,
            cones: Vec::new(),
            tri_cones: Vec::new(),
            pair_budget: super::budget::of_particles(x.len()),
        }
    }

    /// Refits every box to the motion from `x0` to `x1`, grown by `pad` on
    /// every side (a feature's box then holds its whole path and
    /// everything within `pad` of it), and bounds every patch's normals
    /// over that motion, for [`ClothMesh::feature_pairs`].
    pub fn refit(&mut self, x0: &[Vec3], x1: &[Vec3], pad: Real) {
        self.refit_boxes(x0, x1, pad);
        self.x0.clear();
        self.x0.extend_from_slice(x0);
        self.x1.clear();
        self.x1.extend_from_slice(x1);
        // Each triangle's cone (the costly part: square roots and
        // divisions) on the team, then the merges up the tree, in the
        // same order as ever.
        let triangles = &self.triangles;
        self.tri_cones.resize(triangles.len(), Cone::WHOLE);
        parallel::for_chunks_min(&mut self.tri_cones, parallel::ROWS_MIN, |start, cones| {
            for (c, tri) in cones.iter_mut().zip(&triangles[start..]) {
                let k = tri.map(|k| k as usize);
                *c = Cone::of_triangle(k.map(|k| &x0[k]), k.map(|k| &x1[k]));
            }
        });
        cones::fold(&self.tri_bvh, &self.tri_cones, &mut self.cones);
    }

    /// Refits the boxes only (as [`ClothMesh::refit`]), for queries that
    /// cull nothing.
    pub fn refit_boxes(&mut self, x0: &[Vec3], x1: &[Vec3], pad: Real) {
        self.refit_boxes_each(x0, x1, |_| 0.5 * pad);
    }

    /// [`Self::refit_boxes`] with each vertex's box grown by its own
    /// `grow(k)` (half a pad).
    pub fn refit_boxes_each(
        &mut self,
        x0: &[Vec3],
        x1: &[Vec3],
        grow: impl Fn(usize) -> Real + Sync,
    ) {
        self.boxes.fit_each(x0, x1, grow, &self.edges);
        self.boxes.fit_triangles(&self.triangles);
        let boxes = &self.boxes.triangles;
        parallel::for_chunks_min(&mut self.tri_boxes, 4 * parallel::ROWS_MIN, |start, out| {
            for (b, t) in out.iter_mut().zip(&boxes[start..]) {
                *b = t.to_aabb();
            }
        });
        self.tri_bvh.refit(&self.tri_boxes);
    }

    /// Whether node `node`'s patch cannot meet itself over the last
    /// [`ClothMesh::refit`]'s motion (with `cull`; never without).
    fn flat(&self, cull: bool, node: usize, scratch: &mut contour::Scratch) -> bool {
        let sweep = Sweep {
            x0: &self.x0,
            x1: &self.x1,
            slack: Slack::None,
        };
        cull && self.cones.get(node).is_some_and(|c| {
            c.is_flat()
                && self
                    .contours
                    .simple(node, c.axis(), &self.edges, &sweep, scratch)
        })
    }

    /// Every pair of distinct triangles whose boxes overlap, less the
    /// pairs inside patches that `flat` says cannot meet themselves, each
    /// handed to `body` with two lists to fill: on the team, a piece of
    /// the hierarchy's seeds per task (`Bvh::self_pair_seeds`). The pieces
    /// come back in seed order, so their lists one after another are what
    /// one descent would have filled, whatever the thread count.
    pub(super) fn gather(
        &mut self,
        flat: impl Fn(&Self, usize, &mut contour::Scratch) -> bool + Sync,
        body: impl Fn(&Self, usize, usize, &mut Lists) + Sync,
        budget: usize,
    ) -> (Vec<Piece>, bool) {
        let mut pieces = std::mem::take(&mut self.pieces);
        let mut seeds = std::mem::take(&mut self.seeds);
        let mut scratch = std::mem::take(&mut self.contour_scratch);
        let this = &*self;
        // Alone, one seed: the whole descent, with no opening of seeds.
        let target = if parallel::sharing() { SEEDS } else { 1 };
        this.tri_bvh
            .self_pair_seeds(target, |node| flat(this, node, &mut scratch), &mut seeds);
        // Sixteen pieces a thread: the seeds' descents differ tenfold in
        // cost (a fold against a flat patch), and with four a thread one
        // core waited on the other's last piece (docs/benchmarks.md 1r).
        let count = (parallel::threads() * 16).clamp(1, seeds.len().max(1));
        pieces.resize_with(count, Piece::default);
        for p in &mut pieces {
            p.lists.first.clear();
            p.lists.second.clear();
        }
        let per = seeds.len().div_ceil(count).max(1);
        let tally = budget::Tally::new(budget);
        parallel::each(
            pieces.iter_mut().zip(seeds.chunks(per)),
            |(piece, group)| {
                let Piece {
                    lists,
                    scratch,
                    stack,
                } = piece;
                let mut counter = tally.counter();
                for &seed in group {
                    if counter.over() {
                        break;
                    }
                    let mut stop = false;
                    this.tri_bvh.self_pairs_under(
                        seed,
                        &mut |node| flat(this, node, scratch),
                        stack,
                        &mut |s, t| {
                            if !stop {
                                let before = lists.first.len() + lists.second.len();
                                body(this, s, t, lists);
                                let found = lists.first.len() + lists.second.len() - before;
                                stop = counter.add(found);
                            }
                        },
                    );
                }
            },
        );
        self.seeds = seeds;
        self.contour_scratch = scratch;
        (pieces, tally.complete())
    }

    /// A pair's four particles: a vertex then a triangle's corners, or two
    /// edges' ends (`a`, `b` as [`ClothMesh::feature_pairs`] lists them).
    pub fn particles(&self, kind: super::ccd::Kind, a: u32, b: u32) -> [usize; 4] {
        match kind {
            super::ccd::Kind::VertexFace => {
                let t = self.triangles[b as usize];
                [a as usize, t[0] as usize, t[1] as usize, t[2] as usize]
            }
            super::ccd::Kind::EdgeEdge => {
                let (e, f) = (self.edges[a as usize], self.edges[b as usize]);
                [e[0], e[1], f[0], f[1]].map(|k| k as usize)
            }
        }
    }

    /// Whether a pair's two features (a vertex then a triangle, or two
    /// edges: `idx` as `ccd::Kind` orders them) have particles in the same
    /// or touching grid cells: at most one grid step apart along `u` and
    /// along `v`.
    pub fn grid_neighbours(&self, kind: super::ccd::Kind, idx: &[usize; 4]) -> bool {
        let split = if kind == super::ccd::Kind::VertexFace {
            1
        } else {
            2
        };
        let cell = |k: usize| ((k % self.nu) as i64, (k / self.nu) as i64);
        idx[..split].iter().any(|&p| {
            let (pi, pj) = cell(p);
            idx[split..].iter().any(|&q| {
                let (qi, qj) = cell(q);
                (pi - qi).abs() <= 1 && (pj - qj).abs() <= 1
            })
        })
    }

    /// Every vertex–triangle pair whose boxes overlap, the vertex not a
    /// corner of the triangle, into `vf`, and every pair of edges with
    /// overlapping boxes and no shared vertex, once each (first index
    /// smaller), into `ee`: both in the hierarchy's fixed order, less the
    /// pairs inside patches that cannot meet themselves.
    pub fn feature_pairs(&mut self, vf: &mut Vec<(u32, u32)>, ee: &mut Vec<(u32, u32)>) -> bool {
        let (pieces, complete) = self.gather(
            |m, node, s| m.flat(true, node, s),
            Self::feature_body,
            self.pair_budget,
        );
        self.join(pieces, vf, ee);
        complete
    }

    /// The vertex–triangle and edge–edge pairs of the features two
    /// triangles `s` and `t` own, whose boxes overlap
    /// ([`ClothMesh::feature_pairs`]).
    pub(super) fn feature_body(&self, s: usize, t: usize, out: &mut Lists) {
        let (os, ot) = (&self.owned[s], &self.owned[t]);
        for (mine, tri) in [(os, t), (ot, s)] {
            let corners = self.triangles[tri];
            let tri_box = &self.boxes.triangles[tri];
            extend_kept(
                &mut out.first,
                mine.vertices.as_slice().iter().map(|&v| {
                    let keep =
                        not_one_of(corners, v) & self.boxes.vertices[v as usize].overlaps(tri_box);
                    ((v, tri as u32), keep)
                }),
            );
        }
        for &e in os.edges.as_slice() {
            let [a0, a1] = self.edges[e as usize];
            let edge_box = &self.boxes.edges[e as usize];
            extend_kept(
                &mut out.second,
                ot.edges.as_slice().iter().map(|&f| {
                    let ends = self.edges[f as usize];
                    let keep = not_one_of(ends, a0)
                        & not_one_of(ends, a1)
                        & edge_box.overlaps(&self.boxes.edges[f as usize]);
                    ((e.min(f), e.max(f)), keep)
                }),
            );
        }
    }

    /// The pieces' lists one after another into `first` and `second`;
    /// the pieces kept for the next gather.
    pub(super) fn join(
        &mut self,
        pieces: Vec<Piece>,
        first: &mut Vec<(u32, u32)>,
        second: &mut Vec<(u32, u32)>,
    ) {
        first.clear();
        second.clear();
        for p in &pieces {
            first.extend_from_slice(&p.lists.first);
            second.extend_from_slice(&p.lists.second);
        }
        self.pieces = pieces;
    }

    /// Every edge–triangle pair sharing no vertex whose edge crosses the
    /// triangle's interior at `x`, in the hierarchy's fixed order, for
    /// the crossing count; with `cull`, less the pairs inside patches
    /// that the last [`ClothMesh::refit`] found cannot meet themselves.
    /// PERF: each candidate is tested where the descent finds it, on the
    /// team, and only the (rare) crossings are listed: the count of every
    /// frame listed its candidates (~470 a frame on sphere-drape-30) and
    /// tested them one after another.
    pub fn crossing_pairs(&mut self, x: &[Vec3], cull: bool, out: &mut Vec<(u32, u32)>) {
        let crossing = |m: &Self, e: u32, tri: usize| {
            let [p, q] = m.edges[e as usize].map(|k| x[k as usize]);
            let [a, b, c] = m.triangles[tri].map(|k| x[k as usize]);
            segment_crosses_triangle(&p, &q, &a, &b, &c)
        };
        let pieces = self.gather(
            |m, node, s| m.flat(cull, node, s),
            |m, s, t, lists| {
                for (owner, tri) in [(s, t), (t, s)] {
                    let corners = m.triangles[tri];
                    for &e in m.owned[owner].edges.as_slice() {
                        let [a0, a1] = m.edges[e as usize];
                        if not_one_of(corners, a0)
                            && not_one_of(corners, a1)
                            && m.boxes.edges[e as usize].overlaps(&m.boxes.triangles[tri])
                            && crossing(m, e, tri)
                        {
                            lists.first.push((e, tri as u32));
                        }
                    }
                }
            },
            usize::MAX,
        );
        self.join(pieces.0, out, &mut Vec::new());
    }
}

/// Whether `v` is none of `these` (a vertex not a corner of a triangle,
/// not an end of an edge): every comparison made, none branched on, so
/// the candidate filters that call it stay without branches (`kept`).
#[inline]
fn not_one_of<const N: usize>(these: [u32; N], v: u32) -> bool {
    let mut apart = true;
    for t in these {
        apart &= t != v;
    }
    apart
}

/// Seeds of the triangle hierarchy's self-descent shared out per gather.
/// The seeds are the descent's first tasks in its own order, opened depth
/// first, so a few of them hold most of its pairs: with 64, two threads
/// gathered sphere-drape-30's plans only 1.15× faster than one; with
/// 1,024, 1.4× (the descents 1.7×, after ~35 µs of opening on the caller
/// a gather; docs/benchmarks.md 1s).
const SEEDS: usize = 1024;

/// Two lists of pairs a gather fills.
#[derive(Debug, Clone, Default)]
pub(super) struct Lists {
    pub(super) first: Vec<(u32, u32)>,
    pub(super) second: Vec<(u32, u32)>,
}

/// One task's share of a gather: its lists and scratch.
#[derive(Debug, Clone, Default)]
pub(super) struct Piece {
    lists: Lists,
    scratch: contour::Scratch,
    stack: Vec<Task>,
}

/// The features a triangle owns: at most its three vertices and edges.
#[derive(Debug, Clone, Copy, Default)]
struct Owned {
    vertices: Few,
    edges: Few,
}

/// Up to three indices.
#[derive(Debug, Clone, Copy, Default)]
struct Few {
    items: [u32; 3],
    len: u8,
}

impl Few {
    fn push(&mut self, k: u32) {
        self.items[self.len as usize] = k;
        self.len += 1;
    }

    fn as_slice(&self) -> &[u32] {
        &self.items[..self.len as usize]
    }
}
