//! The reference run of a study and its file, `reference.bin`: a magic
//! number, then little-endian u64 particles, u64 frames, f64 frame
//! interval, step and tolerance, then every frame's positions as f64 xyz.
//! Binary f64, not text: the tight runs agree with the reference to far
//! more digits than an OBJ keeps.

use std::path::Path;

use anyhow::Context;
use drapery_sim::math::Vec3;

// NOTE: the f64 blocks are written and read in the machine's byte order
// (`bytemuck`); every target drapery builds for is little-endian, which is
// what the file format says.
#[cfg(target_endian = "big")]
compile_error!("reference.bin is little-endian: a big-endian target needs byte swaps here");

const MAGIC: &[u8; 8] = b"DRPREF01";
/// Magic, two counts, three numbers.
const HEADER: usize = 8 + 2 * 8 + 3 * 8;

/// Positions of every frame of a reference run, with how it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Time between frames, seconds.
    pub frame_dt: f64,
    /// The step it took.
    pub dt: f64,
    /// Its CG tolerance.
    pub tolerance: f64,
    /// Positions of every frame, frame 0 first.
    pub frames: Vec<Vec<Vec3>>,
}

impl Reference {
    /// Writes `reference.bin`.
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        let particles = self.frames.first().map_or(0, Vec::len);
        let mut bytes = Vec::with_capacity(HEADER + 24 * particles * self.frames.len());
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(bytemuck::bytes_of(&(particles as u64)));
        bytes.extend_from_slice(bytemuck::bytes_of(&(self.frames.len() as u64)));
        bytes.extend_from_slice(bytemuck::cast_slice(&[
            self.frame_dt,
            self.dt,
            self.tolerance,
        ]));
        for frame in &self.frames {
            let xyz: Vec<[f64; 3]> = frame.iter().map(|p| [p.x, p.y, p.z]).collect();
            bytes.extend_from_slice(bytemuck::cast_slice(&xyz));
        }
        std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
    }

    /// Reads a `reference.bin`, refusing a file of another kind or size.
    pub fn read(path: &Path) -> anyhow::Result<Self> {
        let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        let bad = || anyhow::anyhow!("{}: not a drapery reference", path.display());
        if bytes.len() < HEADER || &bytes[..8] != MAGIC {
            return Err(bad());
        }
        let word =
            |k: usize| -> u64 { bytemuck::pod_read_unaligned(&bytes[8 + 8 * k..16 + 8 * k]) };
        let (particles, frames) = (word(0) as usize, word(1) as usize);
        let [frame_dt, dt, tolerance] = [2, 3, 4].map(|k| f64::from_bits(word(k)));
        let expected = particles
            .checked_mul(frames)
            .and_then(|n| n.checked_mul(24))
            .and_then(|n| n.checked_add(HEADER));
        if expected != Some(bytes.len()) || particles == 0 || frames == 0 {
            return Err(bad());
        }
        // The payload need not be aligned for f64: collect copies it.
        let values: Vec<f64> = bytemuck::pod_collect_to_vec(&bytes[HEADER..]);
        let frames = values
            .chunks_exact(3 * particles)
            .map(|f| {
                f.chunks_exact(3)
                    .map(|p| Vec3::new(p[0], p[1], p[2]))
                    .collect()
            })
            .collect();
        Ok(Self {
            frame_dt,
            dt,
            tolerance,
            frames,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reference_round_trips_and_a_truncated_one_is_refused() {
        let dir = crate::test_dir("ref");
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("reference.bin");
        let r = Reference {
            frame_dt: 1.0 / 30.0,
            dt: 1e-4,
            tolerance: 1e-10,
            frames: vec![
                vec![Vec3::new(0.1, 0.2, 0.3), Vec3::new(-1.0, 1e-17, 7.0)],
                vec![Vec3::new(0.4, 0.5, 0.6), Vec3::new(2.0, 3.0, f64::MAX)],
            ],
        };
        r.write(&path).expect("writes");
        assert_eq!(Reference::read(&path).expect("reads"), r);
        let bytes = std::fs::read(&path).expect("bytes");
        assert_eq!(&bytes[8..16], &2u64.to_le_bytes(), "little-endian counts");
        std::fs::write(&path, &bytes[..bytes.len() - 8]).expect("truncate");
        assert!(Reference::read(&path).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }
}
