//! A frame's positions as bytes: the f32 xyz block stored per frame, and
//! the binary frame that `/frames/{n}` and the stream send (header: frame
//! index u32, vertex count u32, time f64, little-endian; then the block).

use drapery_sim::math::Vec3;

// The block is the platform's f32s seen as bytes (`bytemuck`), which is
// the little-endian wire layout only on a little-endian target (x86-64,
// aarch64).
#[cfg(target_endian = "big")]
compile_error!("the binary frame layout assumes a little-endian target");

/// f32 x, y, z per particle, little-endian.
pub fn encode_positions(x: &[Vec3]) -> Vec<u8> {
    let points: Vec<[f32; 3]> = x
        .iter()
        .map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    bytemuck::cast_slice(&points).to_vec()
}

/// The block as points (a trailing partial point is ignored; stored blocks
/// have none).
pub fn decode_positions(bytes: &[u8]) -> Vec<[f32; 3]> {
    let n = bytes.len() / 12;
    let mut points = vec![[0.0f32; 3]; n];
    // NOTE: copied rather than cast in place: a `Vec<u8>` read from SQLite
    // is not aligned for f32.
    bytemuck::cast_slice_mut::<[f32; 3], u8>(&mut points).copy_from_slice(&bytes[..n * 12]);
    points
}

/// The binary frame of frame `n` at `time` with the stored block
/// `positions`.
pub fn binary_frame(n: u64, time: f64, positions: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(16 + positions.len());
    out.extend_from_slice(&(n as u32).to_le_bytes());
    out.extend_from_slice(&((positions.len() / 12) as u32).to_le_bytes());
    out.extend_from_slice(&time.to_le_bytes());
    out.extend_from_slice(positions);
    out
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

    #[test]
    fn positions_are_little_endian_f32_and_decode_back() {
        let x = [Vec3::new(1.0, -2.5, 0.1), Vec3::new(3.0, 4.0, 5.0)];
        let bytes = encode_positions(&x);
        let mut expected = Vec::new();
        for p in &x {
            for c in [p.x, p.y, p.z] {
                expected.extend_from_slice(&(c as f32).to_le_bytes());
            }
        }
        assert_eq!(bytes, expected);
        // Unaligned input, as a BLOB read from the database may be.
        let mut shifted = vec![0u8];
        shifted.extend_from_slice(&bytes);
        assert_eq!(
            decode_positions(&shifted[1..]),
            [[1.0, -2.5, 0.1], [3.0, 4.0, 5.0]]
        );
    }
}
