//! Pairs planned for several steps: one descent of the triangle
//! hierarchy serves every query whose motion stays within the bounds it
//! was planned for, instead of a refit with normal cones over each
//! query's motion and a descent per query (the couplings before the
//! solve, the proximity pass after it, the collision and zone passes when
//! the response moves the cloth again), and while the cloth moves slowly,
//! the queries of the steps after it too.
//!
//! A plan at positions `base` holds every vertex–triangle and edge–edge
//! pair a query over a motion from `x0` to `x1` could need if, at both
//! ends (and so, the bounds being convex, all along the straight paths
//! between them),
//!
//! - no particle `k` is more than its own `reach_k` from its place in
//!   `base` (so a feature's swept box grown by the query's pad lies in
//!   its box at `base` with each vertex's grown by `pad / 2 + reach_k`),
//! - no edge vector `e` differs by more than its own `bend_e` from its
//!   value in `base` (so each triangle's normal stays in its cone at
//!   `base` widened by `asin(ρ / |n|)`, `ρ` the larger bound of the two
//!   edges the cone takes, `Cone::of_turning_triangle`), and no boundary
//!   point of a patch strays from its place in `base` by more than its
//!   edge's ends' reach (the contour test with that slack,
//!   `contour::Sweep`).
//!
//! A patch flat under those bounds cannot meet itself in any such motion,
//! so its pairs are left out; every other pair whose boxes overlap is in
//! the plan. A query checks the bounds against its motion and takes the
//! plan's pairs whose boxes overlap for that motion, in the plan's
//! (hierarchy) order; out of bounds, it refits and descends as before.
//! The pairs a query acts on are the same whichever plan it takes them
//! from (the hierarchy's order is fixed, and a culled patch holds no pair
//! that acts), so when a plan is made does not change the frames, and a
//! resumed run, which makes a new one, continues exactly.
//!
//! At a step's start the plan is kept if the cloth, moving [`GROWTH`]
//! times as far as in the last step (`RunState::last_moved`), stays
//! within its bounds; otherwise it is made again at the step's start
//! positions for [`AHEAD`] such steps: each particle's and edge's bound
//! `AHEAD` times twice its own motion and change in the last step, at
//! least [`SHARE_OF_LARGEST`] of the largest one's, capped at
//! [`REACH_SHARE`] and [`BEND_SHARE`] of the spacing, and no plan at all
//! when even one step's exceeds the caps (fast motion, where the widened
//! cones would cull little). Bounds of their own keep the boxes and cones
//! of the still parts of a cloth tight while a corner of it flaps. When
//! the plan does not hold for the solve's motion, the response plans
//! again from the step's start with [`RESPONSE_GROWTH`] times the
//! solve's own motion ([`Plan::cover`]): the proximity pass and the
//! collision passes after it then share one descent, and a collision
//! pass after impulses gets pairs culled for its own motion, not for the
//! solve's.
//!
//! Faster motion than the caps allow leaves the step without a plan, and
//! each query of the response refits and descends on its own: seven a
//! step where two layers keep colliding (the proximity pass, four
//! collision sweeps, rounds of impact zones; rotating-sphere from 1.6 s
//! on). From its second query on, the response then plans for itself
//! ([`Plan::for_response`]): for this step's motion alone, so the caps
//! can be wider ([`RESPONSE_CAP`]); its first query, often its only one,
//! pays nothing for it. Where pairs are many (a cloth thrown onto
//! itself) it does not: a plan with wider boxes holds more still, and
//! the frames of such a cloth changed (docs/benchmarks.md 1ac). The
//! argument above covers crossings, not nearness: two features of a
//! patch culled as flat may come within the contact distance without
//! crossing, and then which cones culled the patch decides whether they
//! are tested. A crumpled cloth is where that can happen.

use super::cones::{self, Cone};
use super::contour::{Slack, Sweep};
use super::kept::extend_kept;
use super::topology::ClothMesh;
use crate::math::{Real, Vec3};
use crate::parallel;

/// Largest `reach` planned for, as a share of the cloth's spacing.
pub const REACH_SHARE: Real = 0.25;
/// Largest `bend` planned for, as a share of the cloth's spacing: a
/// triangle's normal then turns by at most about 15°.
pub const BEND_SHARE: Real = 0.1;
/// A particle's (an edge's) bound at least this share of the largest:
/// a particle still beside a moving one soon moves too. At 0.25
/// sphere-drape-100 spends about 8 % less time in self-collision than
/// with one bound for all (the share 1), and sphere-drape-30 about the
/// same; at 0.1 the plans held for fewer steps and sphere-drape-30's
/// self-collision took 20 % longer (docs/benchmarks.md 1al).
const SHARE_OF_LARGEST: Real = 0.25;
/// The bounds' margin over the last step's motion, for one step.
const GROWTH: Real = 2.0;
/// Steps of motion a plan is made for. Larger bounds keep more pairs
/// (each query filters them) and widen the cones (fewer patches culled),
/// fewer plans are made: one thread, self-collision stage, two steps
/// against four, sphere-drape-30 0.271–0.284 s against 0.276–0.310 s,
/// table-drape 1.087–1.164 s against 1.039–1.060 s (docs/benchmarks.md
/// 1p).
const AHEAD: Real = 4.0;
/// The bounds' margin over a solve's motion, for its response: the
/// response's impulses change it by a fraction.
pub const RESPONSE_GROWTH: Real = 1.25;
/// The caps, as a share of the spacing, of a plan for one response
/// ([`Plan::for_response`]). Rotating-sphere's cloth, carried round by
/// the sphere, moves 0.2 spacings a step: at 0.3 it was not planned
/// (13.6 s, as without), at 0.5 it is (11.5–12.0 s against 13.1 s).
pub const RESPONSE_CAP: Real = 0.5;
/// The bounds' floor, as a share of the pad (a cloth at rest).
const FLOOR: Real = 0.01;
/// Planned pairs of each list filtered as one piece of a query
/// ([`Plan::pairs`]): a microsecond or two of work, so a 30² drape's ten
/// thousand pairs make a dozen pieces, and both cores finish together.
const FILTER_PIECE: usize = 512;
/// The planned boxes' margin over the bounds, as a share of the spacing:
/// far above the round-off of a query's box, far below any distance the
/// response acts on.
const ROUNDING: Real = 1e-9;

/// How far a plan reaches: `ahead` motions of `growth` times a motion's
/// extent, each bound capped at `caps` (reach, bend).
#[derive(Debug, Clone, Copy)]
struct Bounds {
    growth: Real,
    ahead: Real,
    caps: (Real, Real),
}

/// The pairs planned at `base` for motions within `reach` and `bend`, and
/// pads up to `pad`.
#[derive(Debug, Clone, Default)]
pub struct Plan {
    base: Vec<Vec3>,
    pad: Real,
    /// Per particle, how far it may move from `base`.
    reach_of: Vec<Real>,
    /// Per mesh edge, how far its vector may change from `base`'s.
    bend_of: Vec<Real>,
    /// Per triangle, then per hierarchy node, the cone of its normals
    /// under the bounds.
    tri_cones: Vec<Cone>,
    cones: Vec<Cone>,
    vf: Vec<(u32, u32)>,
    ee: Vec<(u32, u32)>,
    valid: bool,
}

/// How far a motion `moved` goes: the largest particle displacement and
/// the largest change of an edge vector.
pub fn extent(moved: &[Vec3], edges: &[[u32; 2]]) -> (Real, Real) {
    let reach = moved.iter().map(|d| d.norm_squared()).fold(0.0, Real::max);
    let bend = edges
        .iter()
        .map(|&[a, b]| (moved[b as usize] - moved[a as usize]).norm_squared())
        .fold(0.0, Real::max);
    (reach.sqrt(), bend.sqrt())
}

impl Plan {
    /// Plans the pairs of `mesh` for the queries of a step from `x` with
    /// pads up to `pad`, after a step that moved the cloth by
    /// `last_moved`: the plan is kept if it holds for [`GROWTH`] times
    /// that motion from `x`, else made again at `x`; no plan when that
    /// motion is too large (module doc). Returns whether there is a plan.
    pub fn make(
        &mut self,
        mesh: &mut ClothMesh,
        x: &[Vec3],
        pad: Real,
        last_moved: &[Vec3],
    ) -> bool {
        let kept = self.serves(pad)
            && last_moved.len() == x.len()
            && self.within(
                mesh,
                x.len(),
                |k| x[k] - self.base[k],
                |k| last_moved[k] * GROWTH,
            );
        kept || self.make_around(mesh, x, pad, last_moved, GROWTH)
    }

    /// Plans for the response of a step whose solve moved the cloth from
    /// `x` by `moved`, unless the plan already holds for that motion: the
    /// proximity pass takes its pairs, and so do the collision and zone
    /// passes while their impulses keep the motion within
    /// [`RESPONSE_GROWTH`] of the solve's (module doc).
    pub fn cover(&mut self, mesh: &mut ClothMesh, x: &[Vec3], pad: Real, moved: &[Vec3]) {
        let held = self.serves(pad) && self.holds(mesh, x, |k| x[k] + moved[k]);
        if !held {
            self.make_around(mesh, x, pad, moved, RESPONSE_GROWTH);
        }
    }

    /// Plans for the rest of one response when no other plan holds: at the
    /// step's start `x`, for [`RESPONSE_GROWTH`] times the motion `moved`
    /// it is resolving (one step, not [`AHEAD`]), with the caps
    /// [`RESPONSE_CAP`]; no plan past them. Returns whether there is one.
    pub fn for_response(
        &mut self,
        mesh: &mut ClothMesh,
        x: &[Vec3],
        pad: Real,
        moved: &[Vec3],
    ) -> bool {
        let cap = RESPONSE_CAP * mesh.spacing;
        let bounds = Bounds {
            growth: RESPONSE_GROWTH,
            ahead: 1.0,
            caps: (cap, cap),
        };
        self.make_bounded(mesh, x, pad, moved, bounds)
    }

    /// Drops the plan: no query takes its pairs until it is made again.
    pub fn forget(&mut self) {
        self.valid = false;
    }

    /// Whether there is a plan, made for queries with pads up to `pad`.
    fn serves(&self, pad: Real) -> bool {
        self.valid && pad <= self.pad
    }

    /// Whether the motion from `x0` to `x1(k)` keeps within the bounds:
    /// both ends, and so the straight paths between them (a cloth of
    /// another size is not within them: [`Plan::within`]).
    fn holds(&self, mesh: &ClothMesh, x0: &[Vec3], x1: impl Fn(usize) -> Vec3) -> bool {
        let zero = |_| Vec3::zeros();
        (x0 == self.base.as_slice() || self.within(mesh, x0.len(), |k| x0[k] - self.base[k], zero))
            && self.within(mesh, x0.len(), |k| x1(k) - self.base[k], zero)
    }

    /// Whether particles `n` away from the base by `off(k)` each, and
    /// moving by up to `ahead(k)` further, keep within the bounds.
    fn within(
        &self,
        mesh: &ClothMesh,
        n: usize,
        off: impl Fn(usize) -> Vec3,
        ahead: impl Fn(usize) -> Vec3,
    ) -> bool {
        // |d| + |a| <= bound, without square roots: implied by
        // 2 (|d|² + |a|²) <= bound² (a little stricter when both count).
        let inside = |d: Vec3, a: Vec3, bound: Real| {
            let (d, a) = (d.norm_squared(), a.norm_squared());
            let scale = if a == 0.0 { 1.0 } else { 2.0 };
            scale * (d + a) <= bound * bound
        };
        n == self.base.len()
            && (0..n).all(|k| inside(off(k), ahead(k), self.reach_of[k]))
            && mesh
                .edges
                .iter()
                .zip(&self.bend_of)
                .all(|(&[a, b], &bend)| {
                    let (a, b) = (a as usize, b as usize);
                    inside(off(b) - off(a), ahead(b) - ahead(a), bend)
                })
    }

    /// Plans at `x` for [`AHEAD`] motions up to `growth` times `motion`'s
    /// extent, within the caps; no plan if one such motion exceeds them.
    fn make_around(
        &mut self,
        mesh: &mut ClothMesh,
        x: &[Vec3],
        pad: Real,
        motion: &[Vec3],
        growth: Real,
    ) -> bool {
        let bounds = Bounds {
            growth,
            ahead: AHEAD,
            caps: (REACH_SHARE * mesh.spacing, BEND_SHARE * mesh.spacing),
        };
        self.make_bounded(mesh, x, pad, motion, bounds)
    }

    /// Plans at `x` for motions within `bounds` of `motion`'s extent; no
    /// plan if one such motion exceeds the caps.
    fn make_bounded(
        &mut self,
        mesh: &mut ClothMesh,
        x: &[Vec3],
        pad: Real,
        motion: &[Vec3],
        bounds: Bounds,
    ) -> bool {
        let Bounds {
            growth,
            ahead,
            caps,
        } = bounds;
        self.valid = false;
        if motion.len() != x.len() {
            return false;
        }
        let floor = FLOOR * pad;
        let (reach, bend) = extent(motion, &mesh.edges);
        if growth * reach + floor > caps.0 || growth * bend + floor > caps.1 {
            return false;
        }
        // Each particle's and edge's bound: `ahead` of its own motion, but
        // at least a share of the largest's, within the cap.
        let bound = |d: Real, largest: Real, cap: Real| {
            let of = |d: Real| ahead * growth * d + floor;
            of(d).max(SHARE_OF_LARGEST * of(largest)).min(cap)
        };
        let edge = |[a, b]: [u32; 2]| (motion[b as usize] - motion[a as usize]).norm();
        self.reach_of.clear();
        self.reach_of
            .extend(motion.iter().map(|d| bound(d.norm(), reach, caps.0)));
        self.bend_of.clear();
        self.bend_of
            .extend(mesh.edges.iter().map(|&e| bound(edge(e), bend, caps.1)));
        self.base.clear();
        self.base.extend_from_slice(x);
        self.pad = pad;
        // A hair more than the bounds: a query box, rounded, stays inside.
        let (reach_of, rounding) = (&self.reach_of, ROUNDING * mesh.spacing);
        mesh.refit_boxes_each(x, x, |k| 0.5 * (pad + 2.0 * reach_of[k] + rounding));
        let triangles = &mesh.triangles;
        self.tri_cones.resize(triangles.len(), Cone::WHOLE);
        parallel::for_chunks_min(&mut self.tri_cones, parallel::ROWS_MIN, |start, cones| {
            for (c, tri) in cones.iter_mut().zip(&triangles[start..]) {
                // Its two edges from the first corner, as the cone takes them.
                let bend = bound(edge([tri[0], tri[1]]), bend, caps.1).max(bound(
                    edge([tri[0], tri[2]]),
                    bend,
                    caps.1,
                ));
                *c = Cone::of_turning_triangle(tri.map(|k| &x[k as usize]), bend);
            }
        });
        cones::fold(&mesh.tri_bvh, &self.tri_cones, &mut self.cones);
        let (cones, sweep) = (
            &self.cones,
            Sweep {
                x0: x,
                x1: x,
                slack: Slack::Each(&self.reach_of),
            },
        );
        let budget = mesh.pair_budget;
        let (pieces, complete) = mesh.gather(
            |m, node, scratch| {
                cones[node].is_flat()
                    && m.contours
                        .simple(node, cones[node].axis(), &m.edges, &sweep, scratch)
            },
            ClothMesh::feature_body,
            budget,
        );
        mesh.join(pieces, &mut self.vf, &mut self.ee);
        // A plan over the budget would be no plan's worth: each query
        // gathers (and is bounded) on its own.
        self.valid = complete;
        complete
    }

    /// The pairs of `mesh` for the motion from `x0` to `x1` with pad
    /// `pad`, as [`ClothMesh::feature_pairs`] after [`ClothMesh::refit`]
    /// would list them, less pairs the plan shows cannot meet: from the
    /// plan, if it holds for this motion and pad. The boxes are the
    /// query's own, in single precision rounded outward (`query_boxes`:
    /// the pairs that act are the same), each vertex's and edge's made
    /// once; a triangle's is the union of its vertices', made per planned
    /// pair (as many as there are triangles). Returns whether it did.
    pub fn pairs(
        &self,
        mesh: &mut ClothMesh,
        (x0, x1): (&[Vec3], &[Vec3]),
        pad: Real,
        vf: &mut Vec<(u32, u32)>,
        ee: &mut Vec<(u32, u32)>,
    ) -> bool {
        if !self.serves(pad) || x1.len() != x0.len() || !self.holds(mesh, x0, |k| x1[k]) {
            return false;
        }
        mesh.query.fit(x0, x1, pad, &mesh.edges);
        // Pieces of fixed length, on the team, joined in order: the same
        // lists whatever the number of threads.
        let pieces = self.vf.len().max(self.ee.len()).div_ceil(FILTER_PIECE);
        let (vb, triangles, eb) = (&mesh.query.vertices, &mesh.triangles, &mesh.query.edges);
        let tri = |t: u32| {
            let [a, b, c] = triangles[t as usize].map(|k| &vb[k as usize]);
            a.union(b).union(c)
        };
        let out = &mut mesh.filtered;
        out.resize_with(pieces, Default::default);
        let (planned_vf, planned_ee) = (&self.vf, &self.ee);
        let range =
            |k: usize, len: usize| (k * FILTER_PIECE).min(len)..((k + 1) * FILTER_PIECE).min(len);
        parallel::each(out.iter_mut().enumerate(), |(k, lists)| {
            lists.first.clear();
            extend_kept(
                &mut lists.first,
                planned_vf[range(k, planned_vf.len())]
                    .iter()
                    .map(|&(v, t)| ((v, t), vb[v as usize].overlaps(&tri(t)))),
            );
            lists.second.clear();
            extend_kept(
                &mut lists.second,
                planned_ee[range(k, planned_ee.len())]
                    .iter()
                    .map(|&(e, f)| ((e, f), eb[e as usize].overlaps(&eb[f as usize]))),
            );
        });
        vf.clear();
        ee.clear();
        for lists in &out[..pieces] {
            vf.extend_from_slice(&lists.first);
            ee.extend_from_slice(&lists.second);
        }
        true
    }
}

#[cfg(test)]
mod tests;
