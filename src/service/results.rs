//! Downloads of an ended job (`/result`): its stored frames as a zip of
//! OBJ files, a PC2 point cache or a binary glTF.

use std::io::{Cursor, Write};

use drapery_sim::cloth::Grid;
use drapery_sim::export::{Pc2Writer, write_glb, write_obj};
use drapery_sim::math::Vec3;

use super::frame_bytes::decode_positions;
use super::store::{JobRow, Store, StoreError};
use crate::specfile::SpecLoadError;

/// Download formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// A zip of `frames/frame_NNNNN.obj`.
    Obj,
    /// A PC2 point cache.
    Pc2,
    /// Binary glTF with the animation.
    Glb,
}

impl Format {
    /// The format named `obj`, `pc2` or `glb`.
    #[cfg(test)]
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "obj" => Some(Format::Obj),
            "pc2" => Some(Format::Pc2),
            "glb" => Some(Format::Glb),
            _ => None,
        }
    }

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

/// Why a download could not be built.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error("stored spec no longer loads: {0}")]
    Scene(SpecLoadError),
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Zip(#[from] zip::result::ZipError),
}

fn to_vec3(points: &[[f32; 3]]) -> Vec<Vec3> {
    points
        .iter()
        .map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()))
        .collect()
}

/// The job's stored frames in `format`.
pub fn build(store: &Store, row: &JobRow, format: Format) -> Result<Vec<u8>, ExportError> {
    let scene = row.scene().map_err(ExportError::Scene)?;
    let grid = Grid::new(&scene.cloth, scene.material.density);
    let triangles = grid.triangles();
    match format {
        Format::Obj => {
            let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
            let options = zip::write::SimpleFileOptions::default()
                .compression_method(zip::CompressionMethod::Deflated);
            store.each_frame(row.id, |f| {
                zip.start_file(format!("frames/frame_{:05}.obj", f.n), options)?;
                let mut obj = Vec::new();
                write_obj(
                    &mut obj,
                    &to_vec3(&decode_positions(&f.positions)),
                    &triangles,
                )?;
                zip.write_all(&obj)?;
                Ok::<_, ExportError>(())
            })?;
            Ok(zip.finish()?.into_inner())
        }
        Format::Pc2 => {
            let mut w = Pc2Writer::new(Vec::new(), grid.len(), row.frames_done as usize)?;
            store.each_frame(row.id, |f| {
                w.write_frame(&to_vec3(&decode_positions(&f.positions)))?;
                Ok::<_, ExportError>(())
            })?;
            Ok(w.finish()?)
        }
        Format::Glb => {
            let mut times = Vec::new();
            let mut frames = Vec::new();
            store.each_frame(row.id, |f| {
                times.push(f.time);
                frames.push(decode_positions(&f.positions));
                Ok::<_, ExportError>(())
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
    fn formats_parse_by_name() {
        for f in [Format::Obj, Format::Pc2, Format::Glb] {
            let name = match f {
                Format::Obj => "obj",
                Format::Pc2 => "pc2",
                Format::Glb => "glb",
            };
            assert_eq!(Format::parse(name), Some(f));
        }
        assert_eq!(Format::parse("fbx"), None);
    }
}
