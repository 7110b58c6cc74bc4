//! Binary glTF 2.0 (`.glb`) with the cloth's animation, for Blender,
//! three.js, and any glTF viewer.
//!
//! A cloth's motion is per-vertex, so it is stored the way glTF stores
//! vertex animation: frame 0 is the mesh, every later frame a morph target
//! (its displacement from frame 0), and one animation channel drives the
//! morph weights so that at frame `k`'s time target `k` has weight 1 and
//! all others 0; linear interpolation between keys then blends linearly
//! between consecutive frames, exactly what the frame sequence means.
//! The weights, frames × targets numbers, are stored sparse (one non-zero
//! a key), so the file grows linearly in the frames.

use std::io::{self, Write};

use serde_json::json;

/// `ARRAY_BUFFER` and `ELEMENT_ARRAY_BUFFER` buffer-view targets.
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
/// Component types.
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// Writes `frames` (each a vertex list in grid order, at `times[k]`
/// seconds) over `triangles` as one binary glTF file.
pub fn write_glb<W: Write>(
    mut out: W,
    triangles: &[[u32; 3]],
    times: &[f64],
    frames: &[Vec<[f32; 3]>],
) -> io::Result<()> {
    let invalid = |m: &str| io::Error::new(io::ErrorKind::InvalidInput, m.to_owned());
    let Some(base) = frames.first() else {
        return Err(invalid("glTF export needs at least one frame"));
    };
    if times.len() != frames.len() || frames.iter().any(|f| f.len() != base.len()) {
        return Err(invalid(
            "every frame needs a time and the same vertex count",
        ));
    }
    let mut bin = Bin::default();
    let mut accessors = Vec::new();
    let mut views = Vec::new();

    let index_view = bin.view(&mut views, Some(ELEMENT_ARRAY_BUFFER), |b| {
        for t in triangles {
            for &i in t {
                b.extend_from_slice(&i.to_le_bytes());
            }
        }
    });
    accessors.push(json!({
        "bufferView": index_view, "componentType": UNSIGNED_INT,
        "count": triangles.len() * 3, "type": "SCALAR"
    }));

    let position = |bin: &mut Bin, views: &mut Vec<serde_json::Value>, points: &[[f32; 3]]| {
        let view = bin.view(views, Some(ARRAY_BUFFER), |b| {
            for p in points {
                for c in p {
                    b.extend_from_slice(&c.to_le_bytes());
                }
            }
        });
        let (min, max) = bounds(points);
        json!({
            "bufferView": view, "componentType": FLOAT, "count": points.len(),
            "type": "VEC3", "min": min, "max": max
        })
    };
    accessors.push(position(&mut bin, &mut views, base));

    let mut targets = Vec::new();
    for frame in &frames[1..] {
        let delta: Vec<[f32; 3]> = frame
            .iter()
            .zip(base)
            .map(|(p, q)| [p[0] - q[0], p[1] - q[1], p[2] - q[2]])
            .collect();
        targets.push(json!({ "POSITION": accessors.len() }));
        accessors.push(position(&mut bin, &mut views, &delta));
    }

    let mut primitive = json!({ "attributes": { "POSITION": 1 }, "indices": 0, "mode": 4 });
    let mut mesh = json!({ "name": "cloth", "primitives": [] });
    let mut doc = json!({
        "asset": { "version": "2.0", "generator": "drapery" },
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": "cloth", "mesh": 0 }],
    });
    if !targets.is_empty() {
        let n = targets.len();
        primitive["targets"] = json!(targets);
        mesh["weights"] = json!(vec![0.0; n]);
        let time_view = bin.view(&mut views, None, |b| {
            for &t in times {
                b.extend_from_slice(&(t as f32).to_le_bytes());
            }
        });
        let time_accessor = accessors.len();
        accessors.push(json!({
            "bufferView": time_view, "componentType": FLOAT, "count": times.len(),
            "type": "SCALAR", "min": [times[0] as f32], "max": [times[times.len() - 1] as f32]
        }));
        // Key k: target k-1 fully on (frame 0 is the base: all off). Dense,
        // that is frames x targets weights; sparse (zeros but for one
        // weight a key, glTF 2.0 §3.6.2.3), eight bytes a key.
        let ones: Vec<usize> = (1..frames.len()).map(|k| k * n + (k - 1)).collect();
        let index_view = bin.view(&mut views, None, |b| {
            for &i in &ones {
                b.extend_from_slice(&(i as u32).to_le_bytes());
            }
        });
        let value_view = bin.view(&mut views, None, |b| {
            for _ in &ones {
                b.extend_from_slice(&1.0f32.to_le_bytes());
            }
        });
        let count = frames.len() * n;
        if u32::try_from(count).is_err() {
            return Err(invalid("too many frames for one glTF animation"));
        }
        accessors.push(json!({
            "componentType": FLOAT, "count": count, "type": "SCALAR",
            "sparse": {
                "count": ones.len(),
                "indices": { "bufferView": index_view, "componentType": UNSIGNED_INT },
                "values": { "bufferView": value_view }
            }
        }));
        doc["animations"] = json!([{
            "name": "simulation",
            "samplers": [{ "input": time_accessor, "output": time_accessor + 1, "interpolation": "LINEAR" }],
            "channels": [{ "sampler": 0, "target": { "node": 0, "path": "weights" } }]
        }]);
    }
    mesh["primitives"] = json!([primitive]);
    doc["meshes"] = json!([mesh]);
    doc["accessors"] = json!(accessors);
    doc["bufferViews"] = json!(views);
    doc["buffers"] = json!([{ "byteLength": bin.0.len() }]);

    let mut text = serde_json::to_vec(&doc).map_err(io::Error::other)?;
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.0.len();
    let total = u32::try_from(total).map_err(|_| invalid("glTF files are limited to 4 GiB"))?;
    out.write_all(b"glTF")?;
    out.write_all(&2u32.to_le_bytes())?;
    out.write_all(&total.to_le_bytes())?;
    out.write_all(&(text.len() as u32).to_le_bytes())?;
    out.write_all(b"JSON")?;
    out.write_all(&text)?;
    out.write_all(&(bin.0.len() as u32).to_le_bytes())?;
    out.write_all(b"BIN\0")?;
    out.write_all(&bin.0)?;
    Ok(())
}

/// The binary chunk, built view by view, each 4-byte aligned.
#[derive(Default)]
struct Bin(Vec<u8>);

impl Bin {
    /// Appends what `fill` writes as a new buffer view; returns its index.
    fn view(
        &mut self,
        views: &mut Vec<serde_json::Value>,
        target: Option<u32>,
        fill: impl FnOnce(&mut Vec<u8>),
    ) -> usize {
        let offset = self.0.len();
        fill(&mut self.0);
        let length = self.0.len() - offset;
        while !self.0.len().is_multiple_of(4) {
            self.0.push(0);
        }
        let mut v = json!({ "buffer": 0, "byteOffset": offset, "byteLength": length });
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        views.push(v);
        views.len() - 1
    }
}

/// Component-wise bounds (glTF requires them on position accessors).
fn bounds(points: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut min = [f32::INFINITY; 3];
    let mut max = [f32::NEG_INFINITY; 3];
    for p in points {
        for c in 0..3 {
            min[c] = min[c].min(p[c]);
            max[c] = max[c].max(p[c]);
        }
    }
    (min, max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles moving up over three frames: the file parses and
    /// validates as glTF, and reading the accessors back gives frame `k`
    /// as base + target `k-1`.
    #[test]
    fn animation_round_trips_through_a_gltf_reader() {
        let tris = [[0, 1, 2], [1, 3, 2]];
        let frame = |z: f32| {
            vec![
                [0.0, 0.0, z],
                [1.0, 0.0, z],
                [0.0, 1.0, z],
                [1.0, 1.0, z + 0.5],
            ]
        };
        let frames = vec![frame(0.0), frame(0.1), frame(0.3)];
        let mut buf = Vec::new();
        write_glb(&mut buf, &tris, &[0.0, 0.5, 1.0], &frames).expect("writes");
        assert_eq!(buf.len() % 4, 0);

        // `from_slice` validates the document (indices, accessors, bounds).
        let gltf = gltf::Gltf::from_slice(&buf).expect("a valid glTF file");
        let blob = gltf.blob.clone().expect("a binary chunk");
        let doc = gltf.document;
        let mesh = doc.meshes().next().expect("one mesh");
        let prim = mesh.primitives().next().expect("one primitive");
        let reader = prim.reader(|_| Some(&blob[..]));
        let base: Vec<[f32; 3]> = reader.read_positions().expect("positions").collect();
        assert_eq!(base, frames[0]);
        let indices: Vec<u32> = reader.read_indices().expect("indices").into_u32().collect();
        assert_eq!(indices, vec![0, 1, 2, 1, 3, 2]);
        for (k, (pos, _, _)) in reader.read_morph_targets().enumerate() {
            let delta: Vec<[f32; 3]> = pos.expect("position deltas").collect();
            for (v, d) in delta.iter().enumerate() {
                for c in 0..3 {
                    assert!((base[v][c] + d[c] - frames[k + 1][v][c]).abs() < 1e-6);
                }
            }
        }
        let anim = doc.animations().next().expect("an animation");
        let channel = anim.channels().next().expect("a channel");
        let r = channel.reader(|_| Some(&blob[..]));
        let times: Vec<f32> = r.read_inputs().expect("times").collect();
        assert_eq!(times, vec![0.0, 0.5, 1.0]);
        let weights: Vec<f32> = match r.read_outputs().expect("weights") {
            gltf::animation::util::ReadOutputs::MorphTargetWeights(w) => w.into_f32().collect(),
            _ => panic!("the channel drives morph weights"),
        };
        assert_eq!(weights, vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn refuses_ragged_frames() {
        let e = write_glb(Vec::new(), &[], &[0.0, 1.0], &[vec![[0.0; 3]], vec![]]);
        assert!(e.is_err());
    }
}
