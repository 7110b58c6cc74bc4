//! Helpers shared by the core's unit tests.

use crate::spec::{Limits, Scene, Spec};

/// Parses and validates a JSON spec, panicking with the errors if invalid.
pub fn scene_from_json(json: &str) -> Scene {
    let spec: Spec = serde_json::from_str(json).expect("spec parses");
    spec.validate(&Limits::default()).expect("spec validates")
}

/// The shared scenes directory (`../shared/scenes` beside the repository).
pub fn shared_scene(name: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/scenes")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    scene_from_json(&text)
}
