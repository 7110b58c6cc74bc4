//! Conservation and dissipation laws of implicit Euler with the modified
//! PCG: exact oscillator decay, conserved linear momentum, no energy gain.

mod common;

use drapery_sim::cloth::{ForceModel, Spring, Stretch};
use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, Simulation};
use drapery_sim::solver::{
    BlockJacobi, ClothState, Constraints, Integrator, MpcgOptions, Physics, SolveStatus, update,
};
use rand::{RngExt, SeedableRng, rngs::StdRng};

/// A mass on a spring, its anchor fixed through the constraint filter,
/// moving along the spring: backward Euler maps `(ω x, v)` by a scaled
/// rotation, so `sqrt(k x² + m v²)` shrinks by exactly
/// `(1 + ω² h²)^(-1/2)` per step. The spring force is linear along its axis,
/// so the single linearisation per step is exact and only round-off and
/// the 1e-12 solver tolerance separate the result from the law.
#[test]
fn single_spring_oscillator_decays_by_the_backward_euler_factor() {
    let (k, m, rest, h) = (40.0, 0.1, 1.0, 0.01);
    let omega2 = k / m;
    let model = ForceModel {
        stretch: Stretch {
            springs: vec![Spring {
                a: 0,
                b: 1,
                rest,
                k,
            }],
        },
        ..ForceModel::default()
    };
    let mass = [1.0, m];
    let mut integrator = Integrator::from_parts(
        2,
        &model,
        Box::<BlockJacobi>::default(),
        MpcgOptions {
            tolerance: 1e-12,
            max_iterations: 100,
            reference: None,
        },
        false,
    );
    let mut c = Constraints::free(2);
    c.fix(0, Vec3::zeros(), Vec3::zeros());
    let a0 = 0.05;
    let mut state = ClothState {
        time: 0.0,
        x: vec![Vec3::zeros(), Vec3::new(rest + a0, 0.0, 0.0)],
        v: vec![Vec3::zeros(); 2],
    };
    let physics = Physics {
        model: &model,
        mass: &mass,
        gravity: Vec3::zeros(),
    };
    let norm = |s: &ClothState| {
        let x = s.x[1].x - rest;
        (k * x * x + m * s.v[1].norm_squared()).sqrt()
    };
    let n0 = norm(&state);
    let mut dv = vec![Vec3::zeros(); 2];
    let factor = (1.0 + omega2 * h * h).powf(-0.5);
    for n in 1..=200 {
        integrator.assemble(&physics, &state, &c, h);
        integrator.precondition(&physics, &c, h, &mut dv);
        let solve = integrator.solve(&c, &mut dv);
        update(&mut state, &dv, &c, h).expect("finite");
        assert_eq!(solve.status, SolveStatus::Converged);
        let expected = n0 * factor.powi(n);
        let got = norm(&state);
        assert!(
            ((got - expected) / expected).abs() < 1e-9,
            "step {n}: {got} vs {expected}"
        );
        assert!(state.x[1].y.abs() < 1e-15 && state.x[1].z.abs() < 1e-15);
    }
}

fn zero_g_cloth(seed: u64) -> Simulation {
    let scene = common::scene_from_json(
        r#"{"cloth": {"grid": [12, 10], "size": [0.5, 0.4]},
            "material": {"density": 0.15, "stretch": 2e4, "shear": 50, "bend": 1e-5, "damping": 0.002},
            "gravity": [0, 0, 0], "duration": 0.5, "fps": 50,
            "solver": {"dt": 0.005, "tolerance": 1e-12, "max_iterations": 5000}}"#,
    );
    let mut sim = Simulation::new(&scene).expect("builds");
    let mut rng = StdRng::seed_from_u64(seed);
    let mut r = || {
        Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        )
    };
    let mut st = sim.state().clone();
    for i in 0..st.x.len() {
        st.x[i] += r() * 0.01;
        st.v[i] = r() * 0.5;
    }
    sim.set_state(st).expect("same cloth");
    sim
}

/// Internal forces come in equal and opposite pairs and `K`'s columns sum
/// to zero, so with no gravity, drag or pins `Σ m dv = 1ᵀ b = 0` and
/// momentum is conserved up to the solver's residual: tolerance 1e-12 of
/// |b| ~ 1e-2 leaves momentum errors near 1e-14 kg·m/s per step; the bound
/// 1e-10 over 50 steps is generous yet six orders below the momentum.
#[test]
fn linear_momentum_is_conserved_without_gravity_or_pins() {
    let mut sim = zero_g_cloth(5);
    let m = sim.grid().mass.clone();
    let momentum = |x: &[Vec3]| x.iter().zip(&m).map(|(v, m)| v * *m).sum::<Vec3>();
    let p0 = momentum(&sim.state().v);
    assert!(p0.norm() > 1e-4);
    while !sim.is_done() {
        sim.advance_frame(&Control::default()).expect("steps");
        let p = momentum(&sim.state().v);
        assert!(
            (p - p0).norm() < 1e-10,
            "momentum drifted by {:e}",
            (p - p0).norm()
        );
    }
}

fn total_energy(sim: &Simulation) -> f64 {
    let g = sim.scene().gravity;
    let potential: f64 = sim
        .state()
        .x
        .iter()
        .zip(&sim.grid().mass)
        .map(|(x, m)| -m * g.dot(x))
        .sum();
    sim.kinetic_energy() + sim.model().elastic_energy(&sim.state().x) + potential
}

/// Backward Euler is dissipative and pins do no work, so total energy
/// (kinetic + elastic + gravitational) must not grow from step to step. The
/// one linearisation per step makes this hold up to its second-order error;
/// the allowance of 1e-6 of the energy scale covers that and round-off,
/// while any genuine instability grows energy by orders of magnitude.
#[test]
fn energy_does_not_increase_without_external_work() {
    for json in [
        // A crumpled cloth in zero gravity, free.
        None,
        // A cloth hanging from two corners under gravity.
        Some(
            r#"{"cloth": {"grid": [15, 15], "size": [0.6, 0.6], "pinned": [[0, 0], [14, 0]]},
            "material": "cotton", "duration": 1.0, "fps": 60,
            "solver": {"dt": 0.004166666666666667, "tolerance": 1e-10, "max_iterations": 5000}}"#,
        ),
    ] {
        let mut sim = match json {
            None => zero_g_cloth(9),
            Some(j) => Simulation::new(&common::scene_from_json(j)).expect("builds"),
        };
        let scale = total_energy(&sim).abs().max(sim.kinetic_energy()).max(1e-3);
        let mut last = total_energy(&sim);
        while !sim.is_done() {
            sim.advance_frame(&Control::default()).expect("steps");
            let e = total_energy(&sim);
            assert!(
                e <= last + 1e-6 * scale,
                "energy rose from {last} to {e} at t={}",
                sim.state().time
            );
            last = e;
        }
    }
}
