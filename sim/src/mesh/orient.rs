//! Triangles turned to face one way: every obstacle test reads "outside"
//! from a triangle's winding (the pseudo-normals' sign, the offset
//! surface's direction), and meshes from other tools arrive wound
//! clockwise, or with some faces reversed. Within each connected part,
//! triangles across an edge of two faces are turned to traverse it in
//! opposite directions (what a consistently oriented surface does); a
//! closed part then faces outward (positive enclosed volume), an open
//! part the way most of its triangles already faced. Edges of three or
//! more faces join nothing, and a part that cannot be oriented (a Möbius
//! band) keeps the first choice made around it.

use super::edges::faces_by_edge;
use crate::math::{Real, Vec3};

/// What [`orient`] changed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Turned {
    /// Triangles whose winding was reversed.
    pub triangles: usize,
    /// Closed parts found facing inward.
    pub inward_parts: usize,
}

/// Rewinds `triangles` (indices into `vertices`) as the module describes.
pub fn orient(vertices: &[Vec3], triangles: &mut [[u32; 3]]) -> Turned {
    let faces = faces_by_edge(triangles);
    let mut flip = vec![false; triangles.len()];
    let mut seen = vec![false; triangles.len()];
    let mut turned = Turned::default();
    let mut part = Vec::new();
    for start in 0..triangles.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        part.clear();
        part.push(start);
        let mut closed = true;
        let mut next = 0;
        while next < part.len() {
            let t = part[next];
            next += 1;
            for (a, b) in directed_edges(triangles[t], flip[t]) {
                let across = &faces[&(a.min(b), a.max(b))];
                if across.len() != 2 {
                    closed = false;
                    continue;
                }
                let u = if across[0] as usize == t {
                    across[1]
                } else {
                    across[0]
                } as usize;
                if !seen[u] {
                    seen[u] = true;
                    // `u` must run `b → a`; wound as given it runs `a → b`
                    // exactly when it is reversed relative to `t`.
                    flip[u] = directed_edges(triangles[u], false).contains(&(a, b));
                    part.push(u);
                }
            }
        }
        // Reverse the part as a whole if it faces inward (closed) or
        // against most of its triangles as given (open).
        let reversed = part.iter().filter(|&&t| flip[t]).count();
        let invert = if closed {
            let inward = enclosed_volume(vertices, triangles, &part, &flip) < 0.0;
            turned.inward_parts += usize::from(inward);
            inward
        } else {
            2 * reversed > part.len()
        };
        for &t in &part {
            if flip[t] != invert {
                triangles[t].swap(1, 2);
                turned.triangles += 1;
            }
        }
    }
    turned
}

/// The three edges of `t` in its winding, reversed if `flip`.
fn directed_edges(t: [u32; 3], flip: bool) -> [(u32, u32); 3] {
    let [a, b, c] = if flip { [t[0], t[2], t[1]] } else { t };
    [(a, b), (b, c), (c, a)]
}

/// Six times the volume the triangles of `part` enclose as wound (with
/// `flip`), taken about the part's first vertex so that far-off meshes
/// lose no digits.
fn enclosed_volume(
    vertices: &[Vec3],
    triangles: &[[u32; 3]],
    part: &[usize],
    flip: &[bool],
) -> Real {
    let origin = vertices[triangles[part[0]][0] as usize];
    part.iter()
        .map(|&t| {
            let [a, b, c] = triangles[t].map(|i| vertices[i as usize] - origin);
            let v = a.dot(&b.cross(&c));
            if flip[t] { -v } else { v }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tessellate_box;

    fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let m = tessellate_box(Vec3::new(3.0, 0.0, 0.0), Vec3::repeat(2.0), 0.7).expect("box");
        (m.vertices().to_vec(), m.triangles().to_vec())
    }

    #[test]
    fn an_outward_closed_mesh_is_left_as_it_is() {
        let (v, mut t) = cube();
        let before = t.clone();
        assert_eq!(orient(&v, &mut t), Turned::default());
        assert_eq!(t, before);
    }

    #[test]
    fn an_inward_closed_mesh_is_turned_outward() {
        let (v, outward) = cube();
        let mut t: Vec<[u32; 3]> = outward.iter().map(|t| [t[0], t[2], t[1]]).collect();
        let turned = orient(&v, &mut t);
        assert_eq!((turned.triangles, turned.inward_parts), (t.len(), 1));
        assert!(t.iter().zip(&outward).all(|(a, b)| same_winding(*a, *b)));
    }

    #[test]
    fn scattered_reversed_faces_follow_their_neighbours() {
        let (v, outward) = cube();
        let mut t = outward.clone();
        for k in (0..t.len()).step_by(3) {
            t[k].swap(0, 1);
        }
        let turned = orient(&v, &mut t);
        assert_eq!(turned.triangles, outward.len().div_ceil(3));
        assert!(t.iter().zip(&outward).all(|(a, b)| same_winding(*a, *b)));
    }

    #[test]
    fn an_open_sheet_keeps_the_winding_most_of_it_has() {
        // A 3 x 3 quad sheet, two triangles a quad, all facing +z but one.
        let v: Vec<Vec3> = (0..16)
            .map(|i| Vec3::new((i % 4) as Real, (i / 4) as Real, 0.0))
            .collect();
        let mut up = Vec::new();
        for j in 0..3u32 {
            for i in 0..3u32 {
                let (a, b, c, d) = (i + 4 * j, i + 1 + 4 * j, i + 5 + 4 * j, i + 4 + 4 * j);
                up.extend([[a, b, c], [a, c, d]]);
            }
        }
        let mut t = up.clone();
        t[7].swap(1, 2);
        assert_eq!(orient(&v, &mut t).triangles, 1);
        assert_eq!(t, up);
    }

    fn same_winding(a: [u32; 3], b: [u32; 3]) -> bool {
        (0..3).any(|r| [a[r], a[(r + 1) % 3], a[(r + 2) % 3]] == b)
    }
}
