//! Convergence under refinement: the discrete cloth approaches its
//! continuum as the grid refines, because every coefficient is derived from
//! resolution-independent material parameters.

mod common;

use drapery_sim::math::Vec3;
use drapery_sim::sim::Simulation;
use drapery_sim::solver::ClothState;

/// The catenary of a 1 m chain hung between points 0.6 m apart:
/// `2a sinh(0.3/a) = 1` gives `a = 0.163227…` and sag
/// `a (cosh(0.3/a) - 1) = 0.36278 m`.
const CATENARY_SAG: f64 = 0.36278;

/// Settles a strip of `n` particles (2 rows, 2 cm wide, stiff stretch, no
/// bending) started in a V between pins 0.6 m apart; returns its sag.
fn catenary_sag(n: usize) -> f64 {
    let scene = common::scene_from_json(&format!(
        r#"{{"cloth": {{"grid": [{n}, 2], "size": [1.0, 0.02],
              "pinned": [[0, 0], [0, 1], [{last}, 0], [{last}, 1]]}},
            "material": {{"density": 0.15, "stretch": 1e6, "shear": 1.0, "bend": 0.0,
                          "damping": 0.005, "air_drag": 1.0}},
            "duration": 4.0, "fps": 10,
            "solver": {{"dt": 0.004166666666666667, "tolerance": 1e-9, "max_iterations": 5000}}}}"#,
        last = n - 1
    ));
    let mut sim = Simulation::new(&scene).expect("builds");
    // Lay the strip as a V of the right arc length: each half 0.5 m long,
    // spanning 0.3 m horizontally and 0.4 m vertically.
    let x: Vec<Vec3> = (0..2 * n)
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let s = i as f64 / (n - 1) as f64;
            Vec3::new(-0.3 + 0.6 * s, 0.02 * j as f64, -0.8 * s.min(1.0 - s))
        })
        .collect();
    sim.set_state(ClothState {
        time: 0.0,
        v: vec![Vec3::zeros(); x.len()],
        x,
    })
    .expect("same cloth");
    let frames = common::run_frames(&mut sim);
    let last = frames.last().expect("frames");
    assert!(
        sim.kinetic_energy() < 1e-8,
        "strip has not settled: KE {}",
        sim.kinetic_energy()
    );
    -common::lowest_z(last)
}

#[test]
fn catenary_sag_converges_to_the_analytic_value() {
    let errors: Vec<f64> = [11, 21, 41]
        .iter()
        .map(|&n| (catenary_sag(n) - CATENARY_SAG).abs())
        .collect();
    eprintln!("catenary sag errors at 11, 21, 41 particles: {errors:?}");
    // A chain of N links under-samples the curve by O(1/N²): each halving
    // of the spacing should cut the error by about 4; demand at least 2.
    assert!(
        errors[1] < errors[0] / 2.0 && errors[2] < errors[1] / 2.0,
        "errors {errors:?}"
    );
    assert!(errors[2] < 1e-3, "41 particles: sag error {} m", errors[2]);
}

/// `hanging-corners` at 20, 40 and 80 particles a side: the lowest point at
/// t = 1 s converges (successive differences shrink by a factor > 1.5).
#[test]
fn hanging_corners_lowest_point_converges_under_refinement() {
    let base = common::example_spec("hanging-corners.json");
    let lowest: Vec<f64> = [20u32, 40, 80]
        .iter()
        .map(|&n| {
            let mut spec = base.clone();
            spec.cloth.grid = [n, n];
            spec.cloth.pinned = vec![[0, 0].into(), [n - 1, 0].into()];
            spec.duration = 1.0;
            spec.fps = 10.0;
            let scene = spec.validate(&Default::default()).expect("valid");
            let mut sim = Simulation::new(&scene).expect("builds");
            let frames = common::run_frames(&mut sim);
            common::lowest_z(frames.last().expect("frames"))
        })
        .collect();
    let (d1, d2) = ((lowest[0] - lowest[1]).abs(), (lowest[1] - lowest[2]).abs());
    eprintln!("lowest points {lowest:?}, differences {d1:e} {d2:e}");
    assert!(d2 < d1 / 1.5, "no convergence: {lowest:?}");
    assert!(d2 < 0.01, "80 vs 40 still differ by {d2} m");
}
