//! The sharp-feature stage's pairs: the obstacles' corners this step, the
//! cloth elements near them, and each pair's four points.

use super::stage::{Point, SharpStage};
use crate::collision::{Aabb, Obstacles};
use crate::math::{Real, Vec3};
use crate::selfcollision::{Kind, Moving};

/// What a gather found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Gathered {
    /// Some pair.
    pub(super) any: bool,
    /// More pairs than the budget: those past it were left out.
    pub(super) over_budget: bool,
}

impl SharpStage {
    /// Every obstacle's corners at the step's start and end poses, their
    /// swept boxes and the features' hierarchies refitted to them; nothing
    /// to do when no obstacle with features moves (placed once by
    /// [`SharpStage::new`]).
    pub(super) fn corners(&mut self, obstacles: &Obstacles, time: Real, h: Real) {
        if !self.moves {
            return;
        }
        self.place_corners(obstacles, time, h);
        self.corner_tree.refit(&self.corner_boxes);
        self.fedge_tree.refit(&self.fedge_boxes);
    }

    /// The corners at the step's start and end poses, and the swept boxes
    /// of corners and feature edges, grown by what the cloth keeps from
    /// them.
    pub(super) fn place_corners(&mut self, obstacles: &Obstacles, time: Real, h: Real) {
        self.f0.clear();
        self.f1.clear();
        for c in obstacles.colliders() {
            let Some(f) = &c.features else { continue };
            let (p0, p1) = (c.trajectory.pose(time), c.trajectory.pose(time + h));
            for p in &f.points {
                self.f0.push(p0.transform_point(&(*p).into()).coords);
                self.f1.push(p1.transform_point(&(*p).into()).coords);
            }
        }
        let (f0, f1, keep) = (&self.f0, &self.f1, &self.keep);
        let corner = |k: u32| {
            let k = k as usize;
            Aabb::of_segment(&f0[k], &f1[k]).grown(keep[k])
        };
        self.corner_boxes.clear();
        self.corner_boxes.extend((0..f0.len() as u32).map(corner));
        self.fedge_boxes.clear();
        self.fedge_boxes.extend(
            self.fedges
                .iter()
                .map(|e| corner(e[0]).union(&corner(e[1]))),
        );
    }

    /// Refits the cloth's hierarchies to the step's motion and lists the
    /// pairs whose swept boxes come within the kept distance, at most
    /// `budget` of them.
    ///
    /// The budget bounds the memory a step can take whatever the scene: a
    /// feature swept across the cloth in one step meets every cloth
    /// element its box overlaps, so a mesh of many sharp edges moving
    /// fast through a large cloth would pair each of its edges with each
    /// cloth element beneath it.
    pub(super) fn gather(&mut self, x0: &[Vec3]) -> Gathered {
        // PERF: the features are few and the cloth's elements many, so each
        // element's box is tested against the features' small hierarchies
        // (most miss at the root) rather than refitting hierarchies over
        // the cloth: 2-3× cheaper on table-drape.
        self.swept.clear();
        self.swept.extend(
            x0.iter()
                .zip(&self.end)
                .map(|(a, b)| Aabb::of_segment(a, b)),
        );
        self.ee.clear();
        self.vf.clear();
        let (swept, ee, vf) = (&self.swept, &mut self.ee, &mut self.vf);
        let (edge_root, corner_root) = (self.fedge_tree.bounds(), self.corner_tree.bounds());
        let (mut room, mut over) = (self.budget, false);
        let mut keep = |list: &mut Vec<(u32, u32)>, pair| {
            if room > 0 {
                room -= 1;
                list.push(pair);
            } else {
                over = true;
            }
        };
        for (e, [a, b]) in self.edges.iter().enumerate() {
            let bx = swept[*a as usize].union(&swept[*b as usize]);
            if bx.overlaps(&edge_root) {
                self.fedge_tree
                    .query(&bx, |f| keep(ee, (e as u32, f as u32)));
            }
        }
        for (t, tri) in self.triangles.iter().enumerate() {
            let bx = swept[tri[0] as usize]
                .union(&swept[tri[1] as usize])
                .union(&swept[tri[2] as usize]);
            if bx.overlaps(&corner_root) {
                self.corner_tree
                    .query(&bx, |p| keep(vf, (p as u32, t as u32)));
            }
        }
        Gathered {
            any: !(ee.is_empty() && vf.is_empty()),
            over_budget: over,
        }
    }

    /// A pair's kind, its four points (cloth particle or feature corner)
    /// and the distance it keeps.
    pub(super) fn pair(&self, kind: Kind, a: u32, b: u32) -> ([Point; 4], Real) {
        match kind {
            Kind::EdgeEdge => {
                let (e, f) = (self.edges[a as usize], self.fedges[b as usize]);
                (
                    [
                        Point::Cloth(e[0]),
                        Point::Cloth(e[1]),
                        Point::Corner(f[0]),
                        Point::Corner(f[1]),
                    ],
                    self.keep[f[0] as usize],
                )
            }
            Kind::VertexFace => {
                let t = self.triangles[b as usize];
                (
                    [
                        Point::Corner(a),
                        Point::Cloth(t[0]),
                        Point::Cloth(t[1]),
                        Point::Cloth(t[2]),
                    ],
                    self.keep[a as usize],
                )
            }
        }
    }

    /// The pair's motion over the step with the current ends.
    pub(super) fn moving(&self, x0: &[Vec3], points: &[Point; 4]) -> Moving {
        let start = |p: &Point| match *p {
            Point::Cloth(k) => x0[k as usize],
            Point::Corner(k) => self.f0[k as usize],
        };
        let stop = |p: &Point| match *p {
            Point::Cloth(k) => self.end[k as usize],
            Point::Corner(k) => self.f1[k as usize],
        };
        Moving {
            x: points.each_ref().map(start),
            d: points.each_ref().map(|p| stop(p) - start(p)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::world::World;

    /// A 12² cloth lying over a box's top, swept 5 cm down through it:
    /// every pair the boxes give, and with a budget one short of them the
    /// same pairs less the last, and the gather says it passed its budget.
    #[test]
    fn a_gather_keeps_at_most_its_budget_of_pairs_and_says_so() {
        let scene = crate::testing::scene_from_json(
            r#"{"cloth": {"grid": [12, 12], "size": [0.6, 0.6], "origin": [-0.3, -0.3, 0.21]},
                "material": "cotton",
                "obstacles": [{"box": {"center": [0, 0, 0], "size": [0.4, 0.4, 0.4]}}],
                "duration": 0.1, "fps": 30}"#,
        );
        let world = World::new(&scene).expect("builds");
        let mut stage =
            SharpStage::new(&world.grid, 1.0, world.obstacles.as_ref()).expect("a box has edges");
        let x0 = world.grid.rest.clone();
        stage.end = x0.iter().map(|x| x - Vec3::new(0.0, 0.0, 0.05)).collect();
        let pairs = |s: &SharpStage| [s.ee.clone(), s.vf.clone()].concat();
        let whole = Gathered {
            any: true,
            over_budget: false,
        };
        assert_eq!(stage.gather(&x0), whole);
        let all = pairs(&stage);
        assert!(
            !stage.ee.is_empty() && !stage.vf.is_empty(),
            "{}",
            all.len()
        );
        stage.budget = all.len();
        assert_eq!(stage.gather(&x0), whole);
        assert_eq!(pairs(&stage), all);
        stage.budget = all.len() - 1;
        assert_eq!(
            stage.gather(&x0),
            Gathered {
                any: true,
                over_budget: true
            }
        );
        assert_eq!(pairs(&stage), all[..all.len() - 1]);
    }
}
