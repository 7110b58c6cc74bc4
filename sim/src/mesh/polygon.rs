//! A face of more than three corners cut into triangles that cover it
//! exactly, concave or not: ear clipping in the face's own plane.
//!
//! A fan from the first corner (what OBJ readers usually do) covers a
//! convex face, but from a reflex corner of a concave one it lays a
//! triangle over the notch, a surface where the file has none. Here the
//! face is projected on the plane of its Newell normal (well defined for
//! any simple polygon, planar or nearly so), and a corner is cut off when
//! it is convex and no other corner lies in its triangle. Triangles keep
//! the face's winding, so outward normals stay outward.

use crate::math::{Real, Vec3};

/// The triangles of the face with corners `points` (in order), as index
/// triples into `points`, appended to `out`. A face whose corners are not
/// a simple polygon in its plane (self-crossing, or collinear) falls back
/// to a fan for what ear clipping cannot cut, and so does a face of more
/// than [`CLIP_MAX`] corners.
pub fn triangulate(points: &[Vec3], out: &mut Vec<[usize; 3]>) {
    let n = points.len();
    if n < 3 {
        return;
    }
    let normal = newell_normal(points);
    if n == 3 || n > CLIP_MAX || normal.norm() == 0.0 {
        fan(&(0..n).collect::<Vec<_>>(), out);
        return;
    }
    // Coordinates in the face's plane, counter-clockwise about `normal`.
    let u = any_perpendicular(&normal);
    let v = normal.normalize().cross(&u);
    let flat: Vec<[Real; 2]> = points.iter().map(|p| [p.dot(&u), p.dot(&v)]).collect();
    let mut left: Vec<usize> = (0..n).collect();
    while left.len() > 3 {
        let m = left.len();
        let ear = (0..m).find(|&k| {
            let (a, b, c) = (left[(k + m - 1) % m], left[k], left[(k + 1) % m]);
            cross(&flat[a], &flat[b], &flat[c]) > 0.0
                && !left.iter().any(|&q| {
                    q != a && q != b && q != c && inside(&flat[q], [&flat[a], &flat[b], &flat[c]])
                })
        });
        let Some(k) = ear else {
            // Not a simple polygon: no ear is clean. Cut the rest as a fan.
            break;
        };
        out.push([left[(k + m - 1) % m], left[k], left[(k + 1) % m]]);
        left.remove(k);
    }
    fan(&left, out);
}

/// Most corners a face is ear-clipped with. Clipping costs up to `n³`
/// tests a face (an ear search scans the corners, and each candidate
/// tests every other corner), so a spec's OBJ text, a face of thousands
/// of corners in a few kilobytes, must not reach it unbounded: with this
/// cap a mesh at the service's 2·10⁶-triangle limit costs at most about
/// 2·10⁹ tests. Larger faces are cut as a fan, as OBJ readers do.
pub const CLIP_MAX: usize = 32;

/// Triangles `(c₀, cₖ, cₖ₊₁)` over `corners`.
fn fan(corners: &[usize], out: &mut Vec<[usize; 3]>) {
    for k in 1..corners.len().saturating_sub(1) {
        out.push([corners[0], corners[k], corners[k + 1]]);
    }
}

/// Newell's normal: twice the polygon's vector area, along the normal
/// its winding makes counter-clockwise.
fn newell_normal(points: &[Vec3]) -> Vec3 {
    let n = points.len();
    (0..n).map(|k| points[k].cross(&points[(k + 1) % n])).sum()
}

/// A unit vector perpendicular to `n` (nonzero).
fn any_perpendicular(n: &Vec3) -> Vec3 {
    let axis = if n.x.abs() <= n.y.abs() && n.x.abs() <= n.z.abs() {
        Vec3::x()
    } else if n.y.abs() <= n.z.abs() {
        Vec3::y()
    } else {
        Vec3::z()
    };
    n.cross(&axis).normalize()
}

/// Twice the signed area of `(a, b, c)`: positive counter-clockwise.
fn cross(a: &[Real; 2], b: &[Real; 2], c: &[Real; 2]) -> Real {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Whether `p` lies in the counter-clockwise triangle `t`, its edges
/// included: a corner on an ear's edge would be cut off with it.
fn inside(p: &[Real; 2], t: [&[Real; 2]; 3]) -> bool {
    cross(t[0], t[1], p) >= 0.0 && cross(t[1], t[2], p) >= 0.0 && cross(t[2], t[0], p) >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[Vec3], tris: &[[usize; 3]]) -> Vec3 {
        tris.iter()
            .map(|t| (points[t[1]] - points[t[0]]).cross(&(points[t[2]] - points[t[0]])) * 0.5)
            .sum()
    }

    /// An L-shaped face listed from the corner before its reflex one: the
    /// triangles cover the L exactly (their vector areas add up to the
    /// face's, each with the face's orientation), and none lies over the
    /// notch.
    #[test]
    fn a_concave_face_is_covered_exactly() {
        // The L: the square [0, 2]² without [1, 2]², in z = 1, listed
        // counter-clockwise from (2, 1), before the reflex corner (1, 1).
        let l: Vec<Vec3> = [
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 2.0],
            [0.0, 2.0],
            [0.0, 0.0],
            [2.0, 0.0],
        ]
        .iter()
        .map(|p| Vec3::new(p[0], p[1], 1.0))
        .collect();
        let mut tris = Vec::new();
        triangulate(&l, &mut tris);
        assert_eq!(tris.len(), 4);
        assert!((area(&l, &tris) - Vec3::new(0.0, 0.0, 3.0)).norm() < 1e-12);
        for t in &tris {
            let a = (l[t[1]] - l[t[0]]).cross(&(l[t[2]] - l[t[0]]));
            assert!(a.z > 0.0, "{t:?} flipped");
            let c = (l[t[0]] + l[t[1]] + l[t[2]]) / 3.0;
            assert!(!(c.x > 1.0 && c.y > 1.0), "{t:?} over the notch");
        }
        // A fan from the first corner does lay a (flipped) triangle over
        // the notch: its signed areas still add up, which is why the test
        // looks at each triangle.
        let mut fan_tris = Vec::new();
        fan(&[0, 1, 2, 3, 4, 5], &mut fan_tris);
        assert!(fan_tris.iter().any(|t| {
            let a = (l[t[1]] - l[t[0]]).cross(&(l[t[2]] - l[t[0]]));
            a.z < 0.0
        }));
    }

    /// Convex faces, both windings, and triangles are cut as a fan would.
    #[test]
    fn convex_faces_and_triangles() {
        let quad: Vec<Vec3> = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
            .iter()
            .map(|p| Vec3::new(p[0], 0.0, p[1]))
            .collect();
        for face in [quad.clone(), quad.iter().rev().copied().collect()] {
            let mut tris = Vec::new();
            triangulate(&face, &mut tris);
            assert_eq!(tris.len(), 2);
            assert!((area(&face, &tris) - newell_normal(&face) * 0.5).norm() < 1e-12);
        }
        let mut tris = Vec::new();
        triangulate(&quad[..3], &mut tris);
        assert_eq!(tris, vec![[0, 1, 2]]);
    }

    /// A face of more corners than [`CLIP_MAX`] is cut as a fan, at once.
    #[test]
    fn large_faces_are_cut_as_a_fan() {
        let n = 100_000;
        let circle: Vec<Vec3> = (0..n)
            .map(|k| {
                let a = k as Real / n as Real * std::f64::consts::TAU;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let mut tris = Vec::new();
        triangulate(&circle, &mut tris);
        assert_eq!(tris.len(), n - 2);
        assert_eq!(tris[0], [0, 1, 2]);
    }

    /// A degenerate face (all corners on a line) still yields triangles
    /// (degenerate ones, which the mesh then leaves out), never a hang.
    #[test]
    fn collinear_corners_fall_back_to_a_fan() {
        let line: Vec<Vec3> = (0..5).map(|k| Vec3::new(k as Real, 0.0, 0.0)).collect();
        let mut tris = Vec::new();
        triangulate(&line, &mut tris);
        assert_eq!(tris.len(), 3);
    }
}
