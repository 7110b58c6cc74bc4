//! One frame as Wavefront OBJ: `v` lines in grid order, then `f` lines.

use std::io::{self, Write};

use super::decimal::{push_fixed9, push_u64};
use crate::math::Vec3;

/// Lines gathered before each write to `out`.
const LINES_PER_WRITE: usize = 256;

/// Writes `positions` (each coordinate to [`super::decimal::DECIMALS`]
/// decimals) and the (zero-based) `triangles` as OBJ text.
pub fn write_obj<W: Write>(
    out: &mut W,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
) -> io::Result<()> {
    let mut line = Vec::with_capacity(48 * LINES_PER_WRITE);
    for chunk in positions.chunks(LINES_PER_WRITE) {
        line.clear();
        for p in chunk {
            line.push(b'v');
            for c in [p.x, p.y, p.z] {
                line.push(b' ');
                push_fixed9(&mut line, c);
            }
            line.push(b'\n');
        }
        out.write_all(&line)?;
    }
    for chunk in triangles.chunks(LINES_PER_WRITE) {
        line.clear();
        for t in chunk {
            line.push(b'f');
            for &k in t {
                line.push(b' ');
                push_u64(&mut line, u64::from(k) + 1);
            }
            line.push(b'\n');
        }
        out.write_all(&line)?;
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
        assert_eq!(lines[1], "v 1.000000000 0.500000000 -2.000000000");
        assert_eq!(lines[3], "f 1 2 3");
    }

    /// Two neighbouring quads of a tight fold (rotating-sphere's last
    /// frame, particles 810, 811, 812, 870, 871, 872): the diagonal of
    /// each passes 40–70 nm beside the other quad's triangle. Written and
    /// read back, the fold still does not cross itself; rounded to seven
    /// decimals, as frames were written before, it did.
    #[test]
    fn a_tight_fold_reads_back_without_crossing() {
        use crate::selfcollision::segment_crosses_triangle;
        let x = [
            Vec3::new(0.200032024, 0.213857752, 0.161837169),
            Vec3::new(0.212634582, 0.200581245, 0.170666550),
            Vec3::new(0.202550738, 0.216569517, 0.163193486),
            Vec3::new(0.186107830, 0.209693893, 0.176033032),
            Vec3::new(0.200452520, 0.200315939, 0.186948793),
            Vec3::new(0.188328036, 0.213614806, 0.177457834),
        ];
        let crossings = |x: &[Vec3]| {
            usize::from(segment_crosses_triangle(&x[0], &x[4], &x[1], &x[2], &x[5]))
                + usize::from(segment_crosses_triangle(&x[1], &x[5], &x[0], &x[4], &x[3]))
        };
        assert_eq!(crossings(&x), 0);
        let mut buf = Vec::new();
        write_obj(&mut buf, &x, &[]).expect("in memory");
        let text = String::from_utf8(buf).expect("utf8");
        let read: Vec<Vec3> = text
            .lines()
            .map(|l| {
                let v: Vec<f64> = l
                    .split_whitespace()
                    .skip(1)
                    .map(|t| t.parse().expect("a number"))
                    .collect();
                Vec3::new(v[0], v[1], v[2])
            })
            .collect();
        assert_eq!(crossings(&read), 0);
        let seven: Vec<Vec3> = x
            .iter()
            .map(|p| p.map(|c| (c * 1e7).round() / 1e7))
            .collect();
        assert_eq!(crossings(&seven), 2);
    }
}
