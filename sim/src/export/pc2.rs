//! The PC2 point cache (Blender, 3ds Max, Maya importers): a 32-byte header
//! then `f32` xyz per point per sample, little-endian.
//!
//! Header: `"POINTCACHE2\0"`, version `i32 = 1`, points `i32`, start frame
//! `f32`, sample rate `f32` (frames between samples), samples `i32`.

use std::io::{self, Write};

use crate::math::Vec3;

/// Streams frames into a PC2 file whose frame count is known up front.
#[derive(Debug)]
pub struct Pc2Writer<W: Write> {
    out: W,
    points: usize,
    remaining: usize,
}

impl<W: Write> Pc2Writer<W> {
    /// Writes the header for `samples` frames of `points` points.
    pub fn new(mut out: W, points: usize, samples: usize) -> io::Result<Self> {
        let too_big = || io::Error::new(io::ErrorKind::InvalidInput, "PC2 counts must fit in i32");
        let p = i32::try_from(points).map_err(|_| too_big())?;
        let s = i32::try_from(samples).map_err(|_| too_big())?;
        out.write_all(b"POINTCACHE2\0")?;
        out.write_all(&1i32.to_le_bytes())?;
        out.write_all(&p.to_le_bytes())?;
        out.write_all(&0f32.to_le_bytes())?;
        out.write_all(&1f32.to_le_bytes())?;
        out.write_all(&s.to_le_bytes())?;
        Ok(Self {
            out,
            points,
            remaining: samples,
        })
    }

    /// Appends one frame.
    pub fn write_frame(&mut self, positions: &[Vec3]) -> io::Result<()> {
        if positions.len() != self.points || self.remaining == 0 {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                "frame does not match the PC2 header",
            ));
        }
        let mut buf = Vec::with_capacity(12 * positions.len());
        for p in positions {
            for c in [p.x, p.y, p.z] {
                buf.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        self.remaining -= 1;
        self.out.write_all(&buf)
    }

    /// Flushes and returns the writer; errors if frames are missing.
    pub fn finish(mut self) -> io::Result<W> {
        if self.remaining != 0 {
            return Err(io::Error::new(
                io::ErrorKind::UnexpectedEof,
                format!("{} PC2 frames were never written", self.remaining),
            ));
        }
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_and_frames_have_the_documented_layout() {
        let mut w = Pc2Writer::new(Vec::new(), 2, 2).expect("header");
        let f = [Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1.0, 0.0, 0.5)];
        w.write_frame(&f).expect("frame");
        assert!(w.write_frame(&f[..1]).is_err());
        w.write_frame(&f).expect("frame");
        let buf = w.finish().expect("complete");
        assert_eq!(buf.len(), 32 + 2 * 2 * 12);
        assert_eq!(&buf[..12], b"POINTCACHE2\0");
        assert_eq!(i32::from_le_bytes(buf[16..20].try_into().expect("4")), 2);
        assert_eq!(i32::from_le_bytes(buf[28..32].try_into().expect("4")), 2);
        assert_eq!(f32::from_le_bytes(buf[32..36].try_into().expect("4")), 1.0);
    }
}
