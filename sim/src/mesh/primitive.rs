//! Primitives as triangle meshes, with edges no longer than a target
//! length: for display (the stream's hello, the viewer) and for running a
//! primitive through the mesh pipeline. Collision itself treats primitives
//! exactly (`collision::analytic`); these meshes are their picture.
//!
//! Every mesh is closed (except the plane's square), shares vertices
//! between faces, and is oriented outward. Sizes that give no usable mesh
//! (zero, negative or non-finite, or beyond `TriMesh`'s coordinate bound)
//! are an error, not a panic.

use std::collections::HashMap;

use super::trimesh::{MeshError, TriMesh};
use crate::math::{Real, Vec3};

/// Fewest segments around any curve, so coarse targets still look round.
const MIN_SEGMENTS: usize = 12;

fn segments(length: Real, edge: Real) -> usize {
    ((length / edge).ceil() as usize).clamp(1, 4096)
}

fn finish(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<TriMesh, MeshError> {
    TriMesh::new(vertices, triangles)
}

/// Pushes `t`, flipped if needed so its normal points along `outward`.
fn push_oriented(v: &[Vec3], tris: &mut Vec<[u32; 3]>, t: [u32; 3], outward: Vec3) {
    let [a, b, c] = t.map(|i| v[i as usize]);
    if (b - a).cross(&(c - a)).dot(&outward) >= 0.0 {
        tris.push(t);
    } else {
        tris.push([t[0], t[2], t[1]]);
    }
}

/// A UV sphere.
pub fn tessellate_sphere(center: Vec3, radius: Real, edge: Real) -> Result<TriMesh, MeshError> {
    let lat = segments(std::f64::consts::PI * radius, edge).max(MIN_SEGMENTS / 2);
    let lon = segments(std::f64::consts::TAU * radius, edge).max(MIN_SEGMENTS);
    let mut v = vec![center + Vec3::z() * radius, center - Vec3::z() * radius];
    for i in 1..lat {
        let th = std::f64::consts::PI * i as Real / lat as Real;
        for j in 0..lon {
            let ph = std::f64::consts::TAU * j as Real / lon as Real;
            v.push(center + Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()) * radius);
        }
    }
    let ring = |i: usize, j: usize| (2 + (i - 1) * lon + j % lon) as u32;
    let mut t = Vec::new();
    for j in 0..lon {
        let out = |a: u32| v[a as usize] - center;
        push_oriented(&v, &mut t, [0, ring(1, j), ring(1, j + 1)], out(ring(1, j)));
        let (a, b) = (ring(lat - 1, j), ring(lat - 1, j + 1));
        push_oriented(&v, &mut t, [1, a, b], out(a));
        for i in 1..lat - 1 {
            let q = [
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            ];
            push_oriented(&v, &mut t, [q[0], q[1], q[2]], out(q[0]));
            push_oriented(&v, &mut t, [q[0], q[2], q[3]], out(q[0]));
        }
    }
    finish(v, t)
}

/// An axis-aligned box, every face a grid.
pub fn tessellate_box(center: Vec3, size: Vec3, edge: Real) -> Result<TriMesh, MeshError> {
    let n = [0, 1, 2].map(|k| segments(size[k], edge));
    let lo = center - size / 2.0;
    let mut index: HashMap<[usize; 3], u32> = HashMap::new();
    let mut v = Vec::new();
    let mut t = Vec::new();
    let mut vertex = |p: [usize; 3], v: &mut Vec<Vec3>| {
        *index.entry(p).or_insert_with(|| {
            v.push(
                lo + Vec3::new(
                    size.x * p[0] as Real / n[0] as Real,
                    size.y * p[1] as Real / n[1] as Real,
                    size.z * p[2] as Real / n[2] as Real,
                ),
            );
            (v.len() - 1) as u32
        })
    };
    for axis in 0..3 {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, n[axis]] {
            let mut outward = Vec3::zeros();
            outward[axis] = if side == 0 { -1.0 } else { 1.0 };
            for i in 0..n[a] {
                for j in 0..n[b] {
                    let at = |di: usize, dj: usize| {
                        let mut p = [0; 3];
                        p[axis] = side;
                        p[a] = i + di;
                        p[b] = j + dj;
                        p
                    };
                    let q = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)].map(|p| vertex(p, &mut v));
                    push_oriented(&v, &mut t, [q[0], q[1], q[2]], outward);
                    push_oriented(&v, &mut t, [q[0], q[2], q[3]], outward);
                }
            }
        }
    }
    finish(v, t)
}

/// Two unit vectors completing `n` to a right-handed frame.
pub fn frame_of(n: &Vec3) -> (Vec3, Vec3) {
    let helper = if n.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    let e1 = n.cross(&helper).normalize();
    (e1, n.cross(&e1))
}

/// A closed cylinder: side rings and fan caps.
pub fn tessellate_cylinder(
    center: Vec3,
    axis: Vec3,
    radius: Real,
    height: Real,
    edge: Real,
) -> Result<TriMesh, MeshError> {
    let a = axis.normalize();
    let (e1, e2) = frame_of(&a);
    let around = segments(std::f64::consts::TAU * radius, edge).max(MIN_SEGMENTS);
    let along = segments(height, edge);
    let mut v = vec![center - a * (height / 2.0), center + a * (height / 2.0)];
    for i in 0..=along {
        let z = -height / 2.0 + height * i as Real / along as Real;
        for j in 0..around {
            let ph = std::f64::consts::TAU * j as Real / around as Real;
            v.push(center + a * z + (e1 * ph.cos() + e2 * ph.sin()) * radius);
        }
    }
    let ring = |i: usize, j: usize| (2 + i * around + j % around) as u32;
    let mut t = Vec::new();
    for j in 0..around {
        push_oriented(&v, &mut t, [0, ring(0, j), ring(0, j + 1)], -a);
        push_oriented(&v, &mut t, [1, ring(along, j), ring(along, j + 1)], a);
        for i in 0..along {
            let q = [
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            ];
            let out = v[q[0] as usize] - center - a * a.dot(&(v[q[0] as usize] - center));
            push_oriented(&v, &mut t, [q[0], q[1], q[2]], out);
            push_oriented(&v, &mut t, [q[0], q[2], q[3]], out);
        }
    }
    finish(v, t)
}

/// A square of side `2 half` on a plane, facing along `normal`: the visible
/// part of an infinite plane.
pub fn tessellate_plane(
    point: Vec3,
    normal: Vec3,
    half: Real,
    edge: Real,
) -> Result<TriMesh, MeshError> {
    let n = normal.normalize();
    let (e1, e2) = frame_of(&n);
    let k = segments(2.0 * half, edge).min(256);
    let mut v = Vec::new();
    for i in 0..=k {
        for j in 0..=k {
            let s = -half + 2.0 * half * i as Real / k as Real;
            let r = -half + 2.0 * half * j as Real / k as Real;
            v.push(point + e1 * s + e2 * r);
        }
    }
    let id = |i: usize, j: usize| (i * (k + 1) + j) as u32;
    let mut t = Vec::new();
    for i in 0..k {
        for j in 0..k {
            push_oriented(&v, &mut t, [id(i, j), id(i + 1, j), id(i + 1, j + 1)], n);
            push_oriented(&v, &mut t, [id(i, j), id(i + 1, j + 1), id(i, j + 1)], n);
        }
    }
    finish(v, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Volume by the divergence theorem: positive only if every face points
    /// outward, equal to the solid's only if the mesh is closed.
    fn volume(m: &TriMesh) -> Real {
        (0..m.triangles().len())
            .map(|k| {
                let [a, b, c] = m.corners(k);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum()
    }

    fn max_edge(m: &TriMesh) -> Real {
        (0..m.triangles().len())
            .flat_map(|k| {
                let p = m.corners(k);
                [
                    (p[0] - p[1]).norm(),
                    (p[1] - p[2]).norm(),
                    (p[2] - p[0]).norm(),
                ]
            })
            .fold(0.0, Real::max)
    }

    #[test]
    fn primitives_are_closed_outward_and_fine_enough() {
        let c = Vec3::new(0.1, -0.2, 0.3);
        let s = tessellate_sphere(c, 0.5, 0.05).expect("tessellates");
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.125;
        assert!((volume(&s) - exact).abs() / exact < 0.01);
        assert!(max_edge(&s) < 0.05 * 1.01 * std::f64::consts::PI / 3.0 * 2.0);

        let b = tessellate_box(c, Vec3::new(1.0, 0.5, 0.25), 0.1).expect("tessellates");
        assert!((volume(&b) - 0.125).abs() < 1e-12);
        assert!(max_edge(&b) <= 0.1 * 2f64.sqrt() + 1e-12);

        let y =
            tessellate_cylinder(c, Vec3::new(0.0, 1.0, 1.0), 0.2, 0.6, 0.02).expect("tessellates");
        let exact = std::f64::consts::PI * 0.04 * 0.6;
        assert!((volume(&y) - exact).abs() / exact < 0.01);

        let p = tessellate_plane(c, Vec3::new(0.0, 0.0, 2.0), 1.0, 0.25).expect("tessellates");
        assert!((0..p.triangles().len()).all(|k| p.face_normal(k).z > 0.999));

        // Unusable sizes are errors.
        assert!(tessellate_sphere(c, 0.0, 0.05).is_err());
        assert!(tessellate_box(c, Vec3::new(1.0, Real::NAN, 1.0), 0.1).is_err());
        assert!(tessellate_cylinder(c, Vec3::z(), 1.0, 1.0e7, 1.0e5).is_err());
    }
}
