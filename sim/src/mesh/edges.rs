//! Which triangles share each edge: the topology the normals, the
//! offsets and the windings (`orient`) read, from bare triangles, so a
//! mesh still being checked has it too.

use std::collections::HashMap;

/// For every edge (as a sorted vertex pair) the triangles that use it.
pub fn faces_by_edge(triangles: &[[u32; 3]]) -> HashMap<(u32, u32), Vec<u32>> {
    let mut map: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (k, t) in triangles.iter().enumerate() {
        for c in 0..3 {
            let (a, b) = (t[c], t[(c + 1) % 3]);
            map.entry((a.min(b), a.max(b))).or_default().push(k as u32);
        }
    }
    map
}
