//! Downloads of a finished job (`/result`) and the binary frame layout
//! shared by `/frames/{n}` and the stream.

use std::io::{Cursor, Write};

use drapery_sim::cloth::Grid;
use drapery_sim::export::{Pc2Writer, write_glb, write_obj};
use drapery_sim::math::Vec3;

use super::store::{JobRow, Store};

/// Download formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Format {
    /// A zip of `frames/frame_NNNNN.obj`.
    Obj,
    /// A PC2 point cache.
    Pc2,
    /// Binary glTF with the animation.
    Glb,
}

impl Format {
    pub fn extension(self) -> &'static str {
        match self {
            Format::Obj => "zip",
            Format::Pc2 => "pc2",
            Format::Glb => "glb",
        }
    }

    pub fn content_type(self) -> &'static str {
        match self {
            Format::Obj => "application/zip",
            Format::Pc2 => "application/octet-stream",
            Format::Glb => "model/gltf-binary",
        }
    }
}

/// A binary frame: frame index u32, vertex count u32, time f64
/// (little-endian), then the stored f32 xyz block.
pub fn binary_frame(n: u64, time: f64, positions: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + positions.len());
    out.extend_from_slice(&(n as u32).to_le_bytes());
    out.extend_from_slice(&((positions.len() / 12) as u32).to_le_bytes());
    out.extend_from_slice(&time.to_le_bytes());
    out.extend_from_slice(positions);
    out
}

/// The stored f32 xyz block as points.
pub fn decode_positions(bytes: &[u8]) -> Vec<[f32; 3]> {
    bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |k: usize| f32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
            [f(0), f(4), f(8)]
        })
        .collect()
}

fn to_vec3(points: &[[f32; 3]]) -> Vec<Vec3> {
    points
        .iter()
        .map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()))
        .collect()
}

/// The job's stored frames in `format`.
pub fn build(store: &Store, row: &JobRow, format: Format) -> anyhow::Result<Vec<u8>> {
    let scene = row.scene()?;
    let grid = Grid::new(&scene.cloth, scene.material.density);
    let triangles = grid.triangles();
    match format {
        Format::Obj => {
            let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
            let options = zip::write::SimpleFileOptions::default()
                .compression_method(zip::CompressionMethod::Deflated);
            store.each_frame(row.seq, |f| {
                zip.start_file(format!("frames/frame_{:05}.obj", f.n), options)
                    .map_err(std::io::Error::other)?;
                let mut obj = Vec::new();
                write_obj(
                    &mut obj,
                    &to_vec3(&decode_positions(&f.positions)),
                    &triangles,
                )?;
                zip.write_all(&obj)
            })?;
            Ok(zip.finish()?.into_inner())
        }
        Format::Pc2 => {
            let mut w = Pc2Writer::new(Vec::new(), grid.len(), row.frames_done as usize)?;
            store.each_frame(row.seq, |f| {
                w.write_frame(&to_vec3(&decode_positions(&f.positions)))
            })?;
            Ok(w.finish()?)
        }
        Format::Glb => {
            let mut times = Vec::new();
            let mut frames = Vec::new();
            store.each_frame(row.seq, |f| {
                times.push(f.time);
                frames.push(decode_positions(&f.positions));
                Ok(())
            })?;
            let mut out = Vec::new();
            write_glb(&mut out, &triangles, &times, &frames)?;
            Ok(out)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binary_frame_layout() {
        let pos: Vec<u8> = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let b = binary_frame(7, 0.5, &pos);
        assert_eq!(&b[0..4], &7u32.to_le_bytes());
        assert_eq!(&b[4..8], &2u32.to_le_bytes());
        assert_eq!(&b[8..16], &0.5f64.to_le_bytes());
        assert_eq!(
            decode_positions(&b[16..]),
            [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
        );
    }
}
