//! The WebSocket protocol's text messages (DESIGN.md "Service"), as one
//! type: [`StreamMessage`], tagged by `type`. A stream sends `hello`, then
//! per frame a `stats` message followed by the binary frame
//! (see `frame_bytes`), then one end: `done`, `failed` or `cancelled`
//! (or `interrupted` when the server shuts down first).
//!
//! NOTE: every message and every stored JSON document is written through
//! [`to_json`], by way of `serde_json::Value`: keys come out sorted and
//! `f32` values widened to `f64`, byte for byte as the hand-built
//! `json!` messages of earlier versions, so stored hellos and frames read
//! the same whichever version wrote them.

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use utoipa::ToSchema;

use super::job::{JobError, Status};

/// A text message of a job's stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum StreamMessage {
    /// First: what a viewer needs before the first frame.
    Hello(Hello),
    /// One frame's statistics; its binary frame follows.
    Stats(Stats),
    /// The job succeeded (`status` is `succeeded`) and every frame was sent.
    Done(End),
    /// The job failed; `error` says why.
    Failed(End),
    /// The job was cancelled.
    Cancelled(End),
    /// The server is shutting down; reconnect with `?from=N`.
    Interrupted(Interrupted),
}

impl StreamMessage {
    /// The end message of a job that ended with `end.status`; `None` for a
    /// job that has not ended.
    pub fn end(end: End) -> Option<Self> {
        match end.status {
            // The protocol names success `done`; the other ends keep the
            // status's name.
            Status::Succeeded => Some(Self::Done(end)),
            Status::Failed => Some(Self::Failed(end)),
            Status::Cancelled => Some(Self::Cancelled(end)),
            Status::Queued | Status::Running => None,
        }
    }

    /// The message as sent.
    pub fn to_json(&self) -> String {
        to_json(self)
    }
}

/// The grid's shape and triangles and each obstacle as a mesh, at its pose
/// at time 0 (each frame's `stats` carries the poses after that).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Hello {
    /// The job's id.
    pub job: String,
    /// The spec's name.
    pub name: String,
    /// `[nu, nv]`: particles along the two thread directions.
    pub grid: [usize; 2],
    /// Particles (`nu * nv`), the vertex count of every binary frame.
    pub vertices: usize,
    /// Frames the job will have, frame 0 included.
    pub frames: usize,
    pub fps: f64,
    /// Simulated seconds.
    pub duration: f64,
    /// The cloth's triangles, as indices `i + j*nu` into a frame's vertices.
    pub triangles: Vec<[u32; 3]>,
    /// The obstacles, in the spec's order.
    pub obstacles: Vec<ObstacleMesh>,
}

/// An obstacle as a triangle mesh to draw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct ObstacleMesh {
    /// Vertices at time 0, metres.
    pub vertices: Vec<[f32; 3]>,
    pub triangles: Vec<[u32; 3]>,
    /// It has a motion: follow `obstacles` in each `stats`.
    pub moving: bool,
}

/// `stats`: the `FrameReport` of frame `frame`, as stored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Stats {
    /// The frame; its binary frame is the next message.
    pub frame: u64,
    /// The stored report's fields, side by side with `frame` and `type`.
    #[serde(flatten)]
    #[schema(value_type = FrameReport)]
    pub report: Map<String, Value>,
}

impl Stats {
    /// The stats message of frame `frame` whose stored report is `report`
    /// (JSON text; an unreadable one sends the frame number alone).
    pub fn new(frame: u64, report: &str) -> Self {
        let mut report: Map<String, Value> = serde_json::from_str(report).unwrap_or_default();
        // `frame` and `type` are the message's own.
        report.remove("frame");
        report.remove("type");
        Self { frame, report }
    }
}

/// A frame's statistics as the worker records them: the core's per-frame
/// statistics (`time`, `steps`, `cg_iterations`, `contacts`,
/// `kinetic_energy`, `max_stretch`, `step_seconds`, ...), plus, with
/// obstacles, each obstacle's pose (so a viewer moves the hello's meshes)
/// and the particles in contact, and with self-collision the particles in
/// self contact (so it can highlight both).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct FrameReport {
    /// The core's `FrameStats`, field by field.
    #[serde(flatten)]
    #[schema(value_type = Object)]
    pub solver: Map<String, Value>,
    /// Each obstacle's pose at the frame, in the hello's order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obstacles: Option<Vec<Pose>>,
    /// Indices of the particles in contact at the frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_particles: Option<Vec<u32>>,
    /// Indices of the particles in contact with another part of the cloth
    /// in the frame's last step (self-collision on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub self_contact_particles: Option<Vec<u32>>,
}

/// A rigid pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Pose {
    /// Metres.
    pub translation: [f64; 3],
    /// A unit quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

/// `done`, `failed`, `cancelled`: how the job ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct End {
    /// `succeeded` (with `done`), `failed` or `cancelled`.
    pub status: Status,
    /// Frames stored.
    pub frames: u64,
    /// Why it failed.
    pub error: Option<JobError>,
    /// The run's statistics without the per-frame list, as in the job's
    /// `stats`.
    #[schema(value_type = Option<Object>)]
    pub stats: Option<Value>,
}

/// `interrupted`: the server is shutting down before the job ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Interrupted {
    /// For people: reconnect with `?from=N` once the server is back.
    pub message: String,
}

impl Interrupted {
    /// The server is shutting down.
    pub fn shutdown() -> Self {
        Self {
            message: "the server is shutting down; reconnect with ?from=N".into(),
        }
    }
}

/// `value` as the protocol writes JSON (see the module's note).
pub fn to_json(value: &impl Serialize) -> String {
    // Serialising these types cannot fail: every map key is a string.
    serde_json::to_value(value)
        .map(|v| v.to_string())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::error_code::ErrorCode;
    use serde_json::json;

    fn hello() -> Hello {
        Hello {
            job: "0190a6e5-0000-7000-8000-000000000000".into(),
            name: "drape".into(),
            grid: [2, 2],
            vertices: 4,
            frames: 31,
            fps: 30.0,
            duration: 1.0,
            triangles: vec![[0, 1, 3], [0, 3, 2]],
            obstacles: vec![ObstacleMesh {
                vertices: vec![[0.1, 0.2, 0.3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                triangles: vec![[0, 1, 2]],
                moving: false,
            }],
        }
    }

    /// The hello's bytes are those the hand-built `json!` message had.
    #[test]
    fn hello_is_written_as_before() {
        let h = hello();
        let before = json!({
            "type": "hello",
            "job": h.job,
            "name": h.name,
            "grid": h.grid,
            "vertices": h.vertices,
            "frames": h.frames,
            "fps": h.fps,
            "duration": h.duration,
            "triangles": h.triangles,
            "obstacles": [json!({
                "vertices": h.obstacles[0].vertices,
                "triangles": h.obstacles[0].triangles,
                "moving": false,
            })],
        })
        .to_string();
        assert_eq!(StreamMessage::Hello(h).to_json(), before);
    }

    /// The shape of each message: its `type`, its fields, their values.
    #[test]
    fn messages_have_their_documented_shape() {
        let v = |m: &StreamMessage| -> Value { serde_json::from_str(&m.to_json()).expect("JSON") };
        let h = v(&StreamMessage::Hello(hello()));
        assert_eq!(h["type"], json!("hello"));
        assert_eq!(h["grid"], json!([2, 2]));
        assert_eq!(h["frames"], json!(31));
        assert_eq!(h["triangles"], json!([[0, 1, 3], [0, 3, 2]]));
        assert_eq!(h["obstacles"][0]["moving"], json!(false));
        let keys = |v: &Value| -> Vec<String> {
            v.as_object()
                .map(|o| o.keys().cloned().collect())
                .unwrap_or_default()
        };
        assert_eq!(
            keys(&h),
            [
                "duration",
                "fps",
                "frames",
                "grid",
                "job",
                "name",
                "obstacles",
                "triangles",
                "type",
                "vertices"
            ]
        );

        let stats = Stats::new(
            7,
            r#"{"frame": 7, "time": 0.25, "steps": 8, "contact_particles": [3]}"#,
        );
        let s = v(&StreamMessage::Stats(stats));
        assert_eq!(
            s,
            json!({"type": "stats", "frame": 7, "time": 0.25, "steps": 8, "contact_particles": [3]})
        );
        assert_eq!(
            v(&StreamMessage::Stats(Stats::new(3, "not JSON"))),
            json!({"type": "stats", "frame": 3})
        );

        let end = |status| End {
            status,
            frames: 31,
            error: None,
            stats: Some(json!({"steps": 240})),
        };
        let done = StreamMessage::end(end(Status::Succeeded)).expect("an end");
        assert_eq!(
            v(&done),
            json!({"type": "done", "status": "succeeded", "frames": 31, "error": null, "stats": {"steps": 240}})
        );
        let failed = StreamMessage::end(End {
            error: Some(JobError {
                code: ErrorCode::NonFinite,
                message: "NaN".into(),
            }),
            stats: None,
            ..end(Status::Failed)
        })
        .expect("an end");
        assert_eq!(
            v(&failed),
            json!({"type": "failed", "status": "failed", "frames": 31,
                   "error": {"code": "non_finite", "message": "NaN"}, "stats": null})
        );
        let cancelled = StreamMessage::end(end(Status::Cancelled)).expect("an end");
        assert_eq!(v(&cancelled)["type"], json!("cancelled"));
        assert!(StreamMessage::end(end(Status::Running)).is_none());
        assert_eq!(
            v(&StreamMessage::Interrupted(Interrupted::shutdown())),
            json!({"type": "interrupted", "message": "the server is shutting down; reconnect with ?from=N"})
        );
    }

    /// A frame report is the core's statistics with the poses and contacts
    /// beside them, and reads back as a `stats` message.
    #[test]
    fn frame_report_flattens_the_core_statistics() {
        let mut solver = Map::new();
        solver.insert("frame".into(), json!(2));
        solver.insert("time".into(), json!(0.5));
        let report = FrameReport {
            solver,
            obstacles: Some(vec![Pose {
                translation: [0.0, 0.0, 1.0],
                rotation: [0.0, 0.0, 0.0, 1.0],
            }]),
            contact_particles: Some(vec![4, 5]),
            self_contact_particles: None,
        };
        let text = to_json(&report);
        assert_eq!(
            text,
            r#"{"contact_particles":[4,5],"frame":2,"obstacles":[{"rotation":[0.0,0.0,0.0,1.0],"translation":[0.0,0.0,1.0]}],"time":0.5}"#
        );
        let plain = FrameReport {
            solver: Map::new(),
            obstacles: None,
            contact_particles: None,
            self_contact_particles: None,
        };
        assert_eq!(to_json(&plain), "{}");
        let s = v_of(&StreamMessage::Stats(Stats::new(2, &text)));
        assert_eq!(s["obstacles"][0]["translation"], json!([0.0, 0.0, 1.0]));
        assert_eq!(s["frame"], json!(2));
    }

    fn v_of(m: &StreamMessage) -> Value {
        serde_json::from_str(&m.to_json()).expect("JSON")
    }
}
