//! The cloth as a triangle mesh for self-collision: its triangles (two per
//! grid quad, `Grid::triangles`), its edges once each, and the swept boxes
//! and hierarchies over both that every query of a step shares.
//!
//! The hierarchies are built once over the rest shape (median splits, so
//! their nodes are patches of the grid) and only refitted afterwards: a
//! deforming cloth keeps its topology, and a patch of the grid stays a
//! compact region of the cloth however it folds.

use crate::cloth::Grid;
use crate::collision::{Aabb, Bvh};
use crate::math::{Real, Vec3};

/// Triangles, edges and their hierarchies.
#[derive(Debug, Clone)]
pub struct ClothMesh {
    /// Particles along `u` (particle `(i, j)` is `i + j * nu`).
    nu: usize,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Vertex indices of each edge, smaller first, sorted.
    pub edges: Vec<[u32; 2]>,
    vertex_bvh: Bvh,
    tri_bvh: Bvh,
    edge_bvh: Bvh,
    tri_boxes: Vec<Aabb>,
    edge_boxes: Vec<Aabb>,
    /// Each vertex's swept box of the current query.
    pub vertex_boxes: Vec<Aabb>,
}

impl ClothMesh {
    /// The mesh of `grid`, its hierarchies over the rest positions.
    pub fn new(grid: &Grid) -> Self {
        let triangles = grid.triangles();
        let mut edges: Vec<[u32; 2]> = triangles
            .iter()
            .flat_map(|t| [[t[0], t[1]], [t[1], t[2]], [t[2], t[0]]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let x = &grid.rest;
        let tri_boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| Aabb::of_points(t.iter().map(|&k| &x[k as usize])))
            .collect();
        let edge_boxes: Vec<Aabb> = edges
            .iter()
            .map(|e| Aabb::of_segment(&x[e[0] as usize], &x[e[1] as usize]))
            .collect();
        let vertex_boxes: Vec<Aabb> = x.iter().map(|p| Aabb::of_segment(p, p)).collect();
        Self {
            nu: grid.nu,
            vertex_bvh: Bvh::build(&vertex_boxes),
            tri_bvh: Bvh::build(&tri_boxes),
            edge_bvh: Bvh::build(&edge_boxes),
            triangles,
            edges,
            tri_boxes,
            edge_boxes,
            vertex_boxes,
        }
    }

    /// Refits every box to the motion from `x0` to `x1`, grown by `pad` on
    /// every side: a feature's box then holds its whole path and everything
    /// within `pad` of it.
    pub fn refit(&mut self, x0: &[Vec3], x1: &[Vec3], pad: Real) {
        for (b, (a, c)) in self.vertex_boxes.iter_mut().zip(x0.iter().zip(x1)) {
            *b = Aabb::of_segment(a, c).grown(0.5 * pad);
        }
        let vb = &self.vertex_boxes;
        for (b, t) in self.tri_boxes.iter_mut().zip(&self.triangles) {
            *b = vb[t[0] as usize]
                .union(&vb[t[1] as usize])
                .union(&vb[t[2] as usize]);
        }
        for (b, e) in self.edge_boxes.iter_mut().zip(&self.edges) {
            *b = vb[e[0] as usize].union(&vb[e[1] as usize]);
        }
        self.vertex_bvh.refit(&self.vertex_boxes);
        self.tri_bvh.refit(&self.tri_boxes);
        self.edge_bvh.refit(&self.edge_boxes);
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
    /// corner of the triangle, in the hierarchies' fixed order.
    pub fn vertex_face_pairs(&self, out: &mut Vec<(u32, u32)>) {
        out.clear();
        self.vertex_bvh.pairs(&self.tri_bvh, |v, t| {
            if !self.triangles[t].contains(&(v as u32)) {
                out.push((v as u32, t as u32));
            }
        });
    }

    /// Every pair of edges with overlapping boxes and no shared vertex,
    /// each once (first index smaller), in the hierarchy's fixed order.
    pub fn edge_edge_pairs(&self, out: &mut Vec<(u32, u32)>) {
        out.clear();
        self.edge_bvh.self_pairs(|e, f| {
            let ([a0, a1], [b0, b1]) = (self.edges[e], self.edges[f]);
            if a0 != b0 && a0 != b1 && a1 != b0 && a1 != b1 {
                out.push((e.min(f) as u32, e.max(f) as u32));
            }
        });
    }

    /// Whether every vertex box holds `x` with `margin` to spare: pairs
    /// gathered from these boxes then include every pair of the motion
    /// from `x0` to `x` within `2 margin`.
    pub fn holds(&self, x: &[Vec3], margin: Real) -> bool {
        self.vertex_boxes
            .iter()
            .zip(x)
            .all(|(b, p)| b.grown(-margin).contains(p))
    }

    /// Every edge–triangle pair with overlapping boxes that share no
    /// vertex, in edge then triangle order (for the crossing count).
    pub fn edge_face_pairs(&self, out: &mut Vec<(u32, u32)>) {
        out.clear();
        self.edge_bvh.pairs(&self.tri_bvh, |e, t| {
            let ([a0, a1], tri) = (self.edges[e], &self.triangles[t]);
            if !tri.contains(&a0) && !tri.contains(&a1) {
                out.push((e as u32, t as u32));
            }
        });
    }
}
