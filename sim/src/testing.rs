//! Helpers shared by the core's unit tests.

use crate::spec::{Limits, Scene, Spec};

/// Parses and validates a JSON spec, panicking with the errors if invalid.
pub fn scene_from_json(json: &str) -> Scene {
    let spec: Spec = serde_json::from_str(json).expect("spec parses");
    spec.validate(&Limits::default()).expect("spec validates")
}
