//! One frame as Wavefront OBJ: `v` lines in grid order, then `f` lines.

use std::io::{self, Write};

use crate::math::Vec3;

/// Writes `positions` and the (zero-based) `triangles` as OBJ text.
pub fn write_obj<W: Write>(
    out: &mut W,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
) -> io::Result<()> {
    for p in positions {
        writeln!(out, "v {:.7} {:.7} {:.7}", p.x, p.y, p.z)?;
    }
    for t in triangles {
        writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_vertices_then_one_based_faces() {
        let mut buf = Vec::new();
        let p = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.5, -2.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        write_obj(&mut buf, &p, &[[0, 1, 2]]).expect("in memory");
        let text = String::from_utf8(buf).expect("utf8");
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[1], "v 1.0000000 0.5000000 -2.0000000");
        assert_eq!(lines[3], "f 1 2 3");
    }
}
