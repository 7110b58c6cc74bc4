//! The specs the tests submit, and fresh data directories.

use std::path::PathBuf;

use serde_json::{Value, json};

/// A fresh data directory under cargo's scratch directory for tests
/// (`target/tmp`): kept for a look after a failure, gone with `cargo
/// clean`, never left in the system's temp dir.
pub fn data_dir(tag: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("drapery-test-{tag}-{}", uuid::Uuid::now_v7()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// A hanging cloth pinned at two corners: `n`² particles for `duration`
/// seconds at 30 fps.
pub fn hanging(n: u32, duration: f64) -> Value {
    json!({
        "name": format!("hanging-{n}"),
        "cloth": {"grid": [n, n], "size": [1.0, 1.0], "origin": [0, 0, 1],
                  "u": [1, 0, 0], "v": [0, 0, -1],
                  "pinned": [[0, 0], [n - 1, 0]]},
        "material": "cotton",
        "duration": duration,
        "fps": 30,
        "solver": {"dt": 1.0 / 240.0}
    })
}

/// A cloth dropping onto a sphere (collision in the loop).
pub fn drape(n: u32, duration: f64) -> Value {
    json!({
        "name": format!("drape-{n}"),
        "cloth": {"grid": [n, n], "size": [1.0, 1.0], "origin": [-0.5, -0.5, 0.35]},
        "material": "cotton",
        "obstacles": [{"sphere": {"center": [0, 0, 0], "radius": 0.25}, "friction": 0.4}],
        "duration": duration,
        "fps": 30,
        "solver": {"dt": 1.0 / 240.0}
    })
}
