//! Bending against the exact elastica (Peirce's cantilever test): a cloth
//! strip clamped flat on one edge and overhanging by `L` sags under its
//! own weight `w` (N/m²) to the heavy elastica of `a = w L³ / B`,
//!
//! ```text
//! θ''(s) = -a (1 - s) cos θ(s),  θ(0) = 0,  θ'(1) = 0,   s ∈ [0, 1]
//! ```
//!
//! (θ the slope below horizontal, s the arc length over `L`). The test
//! solves it by shooting on `θ'(0)`, runs the cloth to rest, and compares
//! the chord angle from the clamp edge to the tip.

mod common;

use drapery_sim::sim::{Control, Simulation};

/// The elastica integrated from `θ'(0) = k0`, by RK4
/// with `steps` steps; returns `(θ(1), θ'(1), x(1), z(1))` with `x`
/// forward and `z` downward, in units of `L`.
fn shoot(a: f64, k0: f64, steps: usize) -> (f64, f64, f64, f64) {
    let h = 1.0 / steps as f64;
    // State: θ, θ', x, z.
    let f = |s: f64, y: [f64; 4]| [y[1], -a * (1.0 - s) * y[0].cos(), y[0].cos(), y[0].sin()];
    let mut y = [0.0, k0, 0.0, 0.0];
    for k in 0..steps {
        let s = k as f64 * h;
        let add = |y: [f64; 4], d: [f64; 4], t: f64| std::array::from_fn(|i| y[i] + d[i] * t);
        let k1 = f(s, y);
        let k2 = f(s + h / 2.0, add(y, k1, h / 2.0));
        let k3 = f(s + h / 2.0, add(y, k2, h / 2.0));
        let k4 = f(s + h, add(y, k3, h));
        y = std::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
    }
    (y[0], y[1], y[2], y[3])
}

/// The exact chord angle (radians below horizontal) of the heavy
/// cantilever of `w L³ / B = a`: bisection on `θ'(0)` until `θ'(1) = 0`.
fn elastica_chord_angle(a: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, a);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        // θ'(1) grows with θ'(0): too large a start leaves curvature at the tip.
        if shoot(a, mid, 4000).1 > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let (_, _, x, z) = shoot(a, 0.5 * (lo + hi), 4000);
    z.atan2(x)
}

/// The chord angle of a cloth cantilever of `n` spacings over the
/// overhang and `w L³ / B = a`, run to rest.
fn cloth_chord_angle(a: f64, n: usize) -> f64 {
    let (length, density): (f64, f64) = (0.04, 0.15);
    let bend = density * 9.81 * length.powi(3) / a;
    let material = format!(
        r#"{{"density": {density}, "stretch": 2e5, "shear": 50, "bend": {bend}, "damping": 0.01}}"#
    );
    cantilever(&material, length, n)
}

/// The chord angle (radians below horizontal, from the clamp edge to the
/// tip) of a strip of `material` (JSON) overhanging by `length` over `n`
/// spacings, clamped flat over three more, run to rest. Air drag is
/// raised so it settles in seconds: it changes how fast, not where.
fn cantilever(material: &str, length: f64, n: usize) -> f64 {
    let mut material: serde_json::Value = serde_json::from_str(material).expect("material");
    material["air_drag"] = serde_json::json!(2.0);
    let ds = length / n as f64;
    let clamp = 3;
    let nu = n + clamp + 1;
    let nv = 3;
    let pinned: Vec<String> = (0..=clamp)
        .flat_map(|i| (0..nv).map(move |j| format!("[{i}, {j}]")))
        .collect();
    let scene = common::scene_from_json(&format!(
        r#"{{"cloth": {{"grid": [{nu}, {nv}], "size": [{lu}, {lv}],
              "pinned": [{pins}]}},
            "material": {material},
            "duration": 20.0, "fps": 4,
            "solver": {{"dt": 0.01, "tolerance": 1e-10, "max_iterations": 5000}}}}"#,
        lu = ds * (nu - 1) as f64,
        lv = ds * (nv - 1) as f64,
        pins = pinned.join(", ")
    ));
    let mut sim = Simulation::new(&scene).expect("builds");
    // Until it rests: a strip of 1e-5 kg at 1e-16 J drifts a few
    // micrometres per second.
    while !sim.is_done() && (sim.frame() < 4 || sim.kinetic_energy() > 1e-16) {
        sim.advance_frame(&Control::default()).expect("steps");
    }
    assert!(
        sim.kinetic_energy() < 1e-16,
        "not at rest: {}",
        sim.kinetic_energy()
    );
    let x = &sim.state().x;
    let edge = x[clamp + nu]; // the clamp edge, middle row
    let tip = x[nu - 1 + nu];
    let d = tip - edge;
    (-d.z).atan2(d.x)
}

/// The `a = w L³ / B` whose elastica has chord angle `angle`: the chord
/// angle grows with `a`, so bisection.
fn elastica_load_of(angle: f64) -> f64 {
    let (mut lo, mut hi): (f64, f64) = (1e-6, 200.0);
    for _ in 0..60 {
        let mid = (lo * hi).sqrt();
        if elastica_chord_angle(mid) > angle {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    (lo * hi).sqrt()
}

#[test]
fn the_shooting_solve_matches_small_deflection_beam_theory() {
    // For small a the chord angle tends to the linear cantilever's tip
    // deflection over its length, a / 8.
    let a = 0.01;
    let angle = elastica_chord_angle(a);
    assert!((angle / (a / 8.0) - 1.0).abs() < 1e-3, "{angle}");
}

/// Within 1 % of the elastica at 30 spacings over the overhang, for a
/// stiff (`a = 4`), a middling (8) and a limp (16) cloth.
#[test]
fn clamped_cantilever_matches_the_elastica_within_one_percent_at_30_spacings() {
    for a in [4.0, 8.0, 16.0] {
        let exact = elastica_chord_angle(a);
        let got = cloth_chord_angle(a, 30);
        let error = got / exact - 1.0;
        eprintln!(
            "a = {a}: {:.3}° against {:.3}°, {:+.3} %",
            got.to_degrees(),
            exact.to_degrees(),
            100.0 * error
        );
        assert!(error.abs() < 0.01, "a = {a}: {:+.3} %", 100.0 * error);
    }
}

/// Second order in the spacing: each halving (8, 16, 32 spacings) divides
/// the error by at least 2.8 (4 in the limit).
#[test]
fn cantilever_error_falls_at_second_order_in_the_spacing() {
    let a = 8.0;
    let exact = elastica_chord_angle(a);
    let errors: Vec<f64> = [8, 16, 32]
        .iter()
        .map(|&n| (cloth_chord_angle(a, n) / exact - 1.0).abs())
        .collect();
    eprintln!("errors at 8, 16, 32 spacings: {errors:?}");
    for w in errors.windows(2) {
        assert!(w[0] / w[1] >= 2.8, "errors {errors:?}");
    }
}

/// Peirce's cantilever test on every preset: overhang each by twice its
/// bending length `c = (B / w)^(1/3)` (the Shirley tester's 41.5°, `a =
/// 8`), read the chord angle, and recover `c = L / a^(1/3)` through the
/// elastica: within 2 % of the preset's own.
#[test]
fn every_preset_shows_its_bending_length_in_the_cantilever_test() {
    for (name, params) in drapery_sim::spec::PRESETS {
        let w = params.density * 9.81;
        let c = (params.bend / w).cbrt();
        let length = 2.0 * c;
        let material = serde_json::to_string(&params).expect("serialises");
        let angle = cantilever(&material, length, 30);
        let read = length / elastica_load_of(angle).cbrt();
        eprintln!(
            "{name}: c = {:.2} cm, read back {:.2} cm (chord angle {:.1}°)",
            100.0 * c,
            100.0 * read,
            angle.to_degrees()
        );
        assert!((read / c - 1.0).abs() < 0.02, "{name}: {read} against {c}");
    }
}
