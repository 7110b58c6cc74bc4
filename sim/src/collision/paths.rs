//! The collision stage's test of every particle's path over a step
//! against the obstacles (method.md §3): which particles cross an offset
//! surface, or start inside one.
//!
//! The particles are independent, so the test runs on the team in pieces
//! of [`PIECE`] particles, each listing its own crossings; the lists are
//! joined in piece order, which is particle order, so the crossings come
//! out as one pass over the particles would list them, whatever the
//! number of threads.

use super::aabb::Aabb;
use super::collider::Collider;
use super::scratch::PathPiece;
use super::stage::{CollisionStage, ON_SURFACE};
use crate::math::Vec3;
use crate::parallel;

/// Particles a piece of the test takes: a path's test is 0.05–0.5 µs (a
/// sphere's formula, a mesh's hierarchy), so a piece is worth handing to
/// another core.
const PIECE: usize = 256;

impl CollisionStage<'_> {
    /// Tests every free particle's path `a[i] -> b[i]` against every
    /// obstacle whose swept box meets the paths' box, leaving in
    /// `scratch.found` each `(particle, obstacle)` crossing that
    /// `accept(obstacle, end)` keeps, where `end` is the path's end in the
    /// obstacle's frame.
    pub(super) fn crossings(
        &mut self,
        a: &[Vec3],
        b: &[Vec3],
        pinned: &[bool],
        inside_start: bool,
        accept: impl Fn(&Collider, &Vec3, &mut u64) -> bool + Sync,
    ) {
        let mut found = std::mem::take(&mut self.scratch.found);
        found.clear();
        let mut pieces = std::mem::take(&mut self.scratch.pieces);
        pieces.resize_with(a.len().div_ceil(PIECE), Default::default);
        // The paths' box: an obstacle sweeping clear of it is skipped whole.
        let cloth = Aabb::of_points(a).union(&Aabb::of_points(b));
        for (k, c) in self.obstacles.colliders().iter().enumerate() {
            let world = self.scratch.swept[k];
            if !world.overlaps(&cloth) {
                continue;
            }
            let (p0, p1) = self.scratch.poses[k];
            let local_bounds = c.surface.bounds();
            let this = &*self;
            let test = |i: usize, nodes: &mut u64| {
                if pinned[i]
                    || !Aabb::of_segment(&a[i], &b[i]).overlaps(&world)
                    || this.has_contact(i, k)
                {
                    return false;
                }
                let la = p0.inverse_transform_point(&a[i].into()).coords;
                let lb = p1.inverse_transform_point(&b[i].into()).coords;
                if c.surface.first_hit(&la, &lb, nodes).is_some() {
                    accept(c, &lb, nodes)
                } else {
                    // Already inside (initial overlap, or a miss): the
                    // nearest offset-surface point pushes it out. A
                    // particle left exactly on the surface (a released
                    // contact) is not inside: round-off must not re-make it.
                    inside_start
                        && local_bounds.contains(&la)
                        && c.surface.project(&la, nodes).distance
                            < -ON_SURFACE * c.surface.offset() - 1e-12
                }
            };
            parallel::each(
                pieces.iter_mut().enumerate(),
                |(p, (list, nodes)): (usize, &mut PathPiece)| {
                    list.clear();
                    *nodes = 0;
                    for i in p * PIECE..((p + 1) * PIECE).min(a.len()) {
                        if test(i, nodes) {
                            list.push((i as u32, k as u32));
                        }
                    }
                },
            );
            for (list, nodes) in &pieces {
                found.extend_from_slice(list);
                self.scratch.counters.nodes += nodes;
            }
        }
        self.scratch.found = found;
        self.scratch.pieces = pieces;
    }
}

#[cfg(test)]
mod tests {
    use super::super::{CollisionScratch, CollisionStage, Obstacles, StepFrame};
    use crate::math::{Real, Vec3};
    use crate::parallel::with_threads;
    use crate::solver::{Constraints, Scheme};
    use crate::spec::{Obstacle, Sphere};

    /// 1,000 particles falling onto a ball, some far enough to reach its
    /// offset surface within the step: the contacts made are exactly
    /// those whose path enters it, in particle order, on teams of one to
    /// three threads.
    #[test]
    fn paths_are_tested_in_pieces_with_the_serial_result() {
        let (radius, offset, h) = (0.2, 0.01, 0.01);
        let ball = Obstacle {
            sphere: Some(Sphere {
                center: [0.0, 0.0, 0.0],
                radius,
            }),
            box_: None,
            plane: None,
            cylinder: None,
            mesh: None,
            friction: 0.0,
            offset: Some(offset),
            motion: None,
        };
        let obstacles = Obstacles::new(&[ball], 0.1)
            .expect("builds")
            .expect("obstacles");
        let (nu, nv) = (40, 25);
        let n = nu * nv;
        let x: Vec<Vec3> = (0..n)
            .map(|k| {
                let (i, j) = ((k % nu) as Real, (k / nu) as Real);
                Vec3::new(-0.4 + 0.8 * i / 39.0, -0.4 + 0.8 * j / 24.0, 0.3)
            })
            .collect();
        let drop = |k: usize| 0.05 + 0.03 * ((k * 7) % 10) as Real;
        let v: Vec<Vec3> = (0..n).map(|k| Vec3::new(0.0, 0.0, -drop(k) / h)).collect();
        let pinned = vec![false; n];
        let mass = vec![1.0; n];
        let step = StepFrame {
            mass: &mass,
            pinned: &pinned,
            time: 0.0,
            h,
            scheme: Scheme::euler(h),
        };
        let run = || {
            let mut contacts = Vec::new();
            let mut scratch = CollisionScratch::new(1);
            let mut c = Constraints::free(n);
            CollisionStage {
                obstacles: &obstacles,
                contacts: &mut contacts,
                scratch: &mut scratch,
            }
            .prepare(&step, &x, &v, &vec![Vec3::zeros(); n], &mut c);
            contacts.iter().map(|c| c.particle).collect::<Vec<u32>>()
        };
        // A straight drop enters the offset ball if it passes over it and
        // ends below its top.
        let big = radius + offset;
        let want: Vec<u32> = (0..n)
            .filter(|&k| {
                let rho2 = x[k].x * x[k].x + x[k].y * x[k].y;
                rho2 < big * big && x[k].z - drop(k) < (big * big - rho2).sqrt()
            })
            .map(|k| k as u32)
            .collect();
        assert!(want.len() > 20, "{} paths enter the ball", want.len());
        for threads in [1, 2, 3] {
            assert_eq!(with_threads(threads, run), want, "{threads} threads");
        }
    }
}
