//! Prints a hash of every frame's positions (the exact f64 bits) for each
//! scene given on the command line: a refactoring that must not change
//! results is checked by comparing these lines before and after.
//!
//! ```sh
//! cargo run --release -p drapery-sim --example frame_hashes -- examples/scenes/*.json
//! ```

use drapery_sim::sim::{Control, Simulation};
use drapery_sim::spec::{Limits, Spec};

/// FNV-1a, 64-bit, over the little-endian bytes of every coordinate.
fn fnv(hash: &mut u64, x: &[drapery_sim::math::Vec3]) {
    for p in x {
        for c in p.iter() {
            for b in c.to_le_bytes() {
                *hash = (*hash ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
            }
        }
    }
}

fn main() {
    for path in std::env::args().skip(1) {
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let spec: Spec = serde_json::from_str(&text).unwrap_or_else(|e| panic!("{path}: {e}"));
        let scene = spec
            .validate(&Limits::default())
            .unwrap_or_else(|e| panic!("{path}: {e}"));
        let mut sim = Simulation::new(&scene).unwrap_or_else(|e| panic!("{path}: {e}"));
        let mut hash = 0xcbf2_9ce4_8422_2325_u64;
        fnv(&mut hash, &sim.state().x);
        let start = std::time::Instant::now();
        while !sim.is_done() {
            sim.advance_frame(&Control::default())
                .unwrap_or_else(|e| panic!("{path}: {e}"));
            fnv(&mut hash, &sim.state().x);
        }
        println!(
            "{hash:016x} {} frames {} steps {:.2} s {path}",
            sim.frame(),
            sim.steps(),
            start.elapsed().as_secs_f64()
        );
    }
}
