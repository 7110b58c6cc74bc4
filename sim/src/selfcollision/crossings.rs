//! The exact measure of a cloth passing through itself: the number of
//! (edge, triangle) pairs sharing no vertex where the edge crosses the
//! triangle's interior. Zero for every state of a cloth that never
//! self-intersects; the acceptance test of self-collision, a statistic of
//! every frame, and what an outside reader of the frames can recompute.

use super::topology::ClothMesh;
use crate::math::Vec3;

/// Counts the cloth edges that pass through cloth triangles at `x`, over
/// every candidate pair: the measure tests hold the response (and its
/// culling) to.
pub fn count_crossings(mesh: &mut ClothMesh, x: &[Vec3]) -> usize {
    mesh.refit_boxes(x, x, 0.0);
    count_pairs(mesh, x, false)
}

/// [`count_crossings`] without the pairs inside patches whose normal cone
/// shows they cannot cross themselves (`super::cones`): the statistic of
/// every frame, at a fraction of the cost. `sim/tests/self_collision.rs`
/// checks it against the full count frame by frame.
pub fn count_crossings_culled(mesh: &mut ClothMesh, x: &[Vec3]) -> usize {
    mesh.refit(x, x, 0.0);
    count_pairs(mesh, x, true)
}

fn count_pairs(mesh: &mut ClothMesh, x: &[Vec3], cull: bool) -> usize {
    let mut pairs = Vec::new();
    mesh.crossing_pairs(x, cull, &mut pairs);
    pairs.len()
}

#[cfg(test)]
mod tests {
    use super::super::geometry::segment_crosses_triangle;
    use super::*;
    use crate::cloth::Grid;
    use crate::math::Real;

    fn grid(n: usize) -> Grid {
        crate::testing::flat_grid(n, n, [1.0, 1.0])
    }

    /// A flat sheet and one folded over itself without touching have no
    /// crossings; pushing the folded half's tip through the lower half
    /// gives crossings, and brute force over all pairs agrees.
    #[test]
    fn counts_a_flap_pushed_through_the_sheet() {
        let g = grid(11);
        let mut mesh = ClothMesh::new(&g);
        assert_eq!(count_crossings(&mut mesh, &g.rest), 0);
        // Fold about x = 0.5 onto a layer 0.05 above.
        let fold = |depth: Real| -> Vec<Vec3> {
            g.rest
                .iter()
                .map(|p| {
                    if p.x <= 0.5 {
                        *p
                    } else {
                        let back = 1.0 - p.x;
                        // The flap tip dips by `depth` below the sheet.
                        let z = 0.05 - (depth + 0.05) * ((p.x - 0.5) / 0.5).powi(2);
                        Vec3::new(back, p.y, z)
                    }
                })
                .collect()
        };
        // The fold line itself is shared geometry: keep a small gap there
        // by lifting the flap; at depth -0.04 the flap stays above.
        let above = fold(-0.049);
        assert_eq!(count_crossings(&mut mesh, &above), 0);
        let through = fold(0.05);
        let n = count_crossings(&mut mesh, &through);
        assert!(n > 0);
        let mut brute = 0;
        for e in &mesh.edges {
            for t in &mesh.triangles {
                if t.contains(&e[0]) || t.contains(&e[1]) {
                    continue;
                }
                let [p, q] = e.map(|k| through[k as usize]);
                let [a, b, c] = t.map(|k| through[k as usize]);
                brute += usize::from(segment_crosses_triangle(&p, &q, &a, &b, &c));
            }
        }
        assert_eq!(n, brute);
        // The flap and the sheet under it are no one flat patch: the
        // culled count sees the same crossings.
        assert_eq!(count_crossings_culled(&mut mesh, &through), n);
        assert_eq!(count_crossings_culled(&mut mesh, &above), 0);
    }
}
