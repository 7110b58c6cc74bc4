//! Conservation and dissipation laws of the implicit integrators with the
//! modified PCG: the exact oscillator laws of backward Euler and BDF2,
//! BDF2's order on a nonlinear swing, conserved linear momentum, no energy
//! gain.

mod common;

use drapery_sim::cloth::{ForceModel, Spring, Stretch};
use drapery_sim::math::Vec3;
use drapery_sim::sim::{Control, ENERGY_ALLOWANCE, Simulation};
use drapery_sim::solver::{
    BlockJacobi, ClothState, Constraints, Integrator, MpcgOptions, Physics, Scheme, SolveStatus,
    update,
};
use rand::{RngExt, SeedableRng, rngs::StdRng};

/// One spring of stiffness `k` and rest length `rest` between particles 0
/// and 1.
fn one_spring(k: f64, rest: f64) -> ForceModel {
    ForceModel {
        stretch: Stretch {
            springs: vec![Spring {
                a: 0,
                b: 1,
                rest,
                k,
            }],
        },
        ..ForceModel::default()
    }
}

/// An integrator over two particles of `model` with block Jacobi, solving
/// to the residual `tolerance` from a zero start (no warm start).
fn tight_integrator(model: &ForceModel, tolerance: f64) -> Integrator {
    let options = MpcgOptions {
        tolerance,
        max_iterations: 100,
        reference: None,
        error_bound: None,
    };
    Integrator::from_parts(2, model, Box::<BlockJacobi>::default(), options, false)
}

/// Particles 0 and 1 at rest, `length` apart along x, at time 0.
fn pair_at_rest(length: f64) -> ClothState {
    ClothState {
        time: 0.0,
        x: vec![Vec3::zeros(), Vec3::new(length, 0.0, 0.0)],
        v: vec![Vec3::zeros(); 2],
    }
}

/// A mass `m` on a spring of stiffness `k` along x, its anchor fixed
/// through the constraint filter, started stretched by 0.05.
struct Oscillator {
    model: ForceModel,
    mass: [f64; 2],
    rest: f64,
    k: f64,
}

impl Oscillator {
    fn new() -> Self {
        let (k, m, rest) = (40.0, 0.1, 1.0);
        Self {
            model: one_spring(k, rest),
            mass: [1.0, m],
            rest,
            k,
        }
    }

    /// The states `(x, v)` of the moving mass over `steps` steps of `h`,
    /// with BDF2 when `bdf2` (its first step backward Euler).
    fn run(&self, h: f64, steps: usize, bdf2: bool) -> Vec<(f64, f64)> {
        let mut integrator = tight_integrator(&self.model, 1e-12);
        let mut c = Constraints::free(2);
        c.fix(0, Vec3::zeros(), Vec3::zeros());
        let mut state = pair_at_rest(self.rest + 0.05);
        let physics = Physics {
            model: &self.model,
            mass: &self.mass,
            gravity: Vec3::zeros(),
        };
        let mut out = vec![(state.x[1].x, state.v[1].x)];
        let (mut dv, mut moved) = (vec![Vec3::zeros(); 2], vec![Vec3::zeros(); 2]);
        let (mut last_moved, mut last_dv, mut last_h) = (moved.clone(), dv.clone(), 0.0);
        for _ in 0..steps {
            let scheme = if bdf2 {
                Scheme::bdf2(h, last_h, &last_moved, &last_dv)
            } else {
                Scheme::euler(h)
            };
            integrator.assemble(&physics, &state, &c, &scheme);
            integrator.precondition(&physics, &c, &scheme, 0.0, &state.v, &mut dv);
            let solve = integrator.solve(&c, &mut dv);
            update(&mut state, &dv, &c, &scheme, &mut moved).expect("finite");
            assert_eq!(solve.status, SolveStatus::Converged);
            assert!(state.x[1].y.abs() < 1e-15 && state.x[1].z.abs() < 1e-15);
            (last_moved, last_dv, last_h) = (moved.clone(), dv.clone(), h);
            out.push((state.x[1].x, state.v[1].x));
        }
        out
    }
}

/// Backward Euler maps `(ω x, v)` by a scaled rotation, so
/// `sqrt(k x² + m v²)` shrinks by exactly `(1 + ω² h²)^(-1/2)` per step.
/// The spring force is linear along its axis, so the single linearisation
/// per step is exact and only round-off and the 1e-12 solver tolerance
/// separate the result from the law.
#[test]
fn single_spring_oscillator_decays_by_the_backward_euler_factor() {
    let o = Oscillator::new();
    let (h, m) = (0.01, o.mass[1]);
    let factor = (1.0 + o.k / m * h * h).powf(-0.5);
    let norm = |(x, v): (f64, f64)| (o.k * (x - o.rest).powi(2) + m * v * v).sqrt();
    let states = o.run(h, 200, false);
    for (n, s) in states.iter().enumerate() {
        let expected = norm(states[0]) * factor.powi(n as i32);
        assert!(((norm(*s) - expected) / expected).abs() < 1e-9, "step {n}");
    }
}

/// BDF2's exact discrete law on the same oscillator: after one backward
/// Euler step, every step satisfies
/// `x' - 4/3 x + 1/3 x'' = 2/3 h v'` and
/// `v' - 4/3 v + 1/3 v'' = -2/3 h (k/m) (x' - L)` to round-off (the force
/// is linear, so the linearisation is exact). BDF2's damping is of fourth
/// order in `ωh`: its principal root has modulus 0.99964 at `ωh = 0.2`,
/// so a period keeps 0.989 of the amplitude (0.970 with the backward Euler
/// start, 0.98), where backward Euler keeps `(1 + ω²h²)^(-15.7) = 0.54`.
#[test]
fn single_spring_oscillator_follows_the_bdf2_recurrence() {
    let o = Oscillator::new();
    let (h, m) = (0.01, o.mass[1]);
    let w = o.k / m;
    let s = o.run(h, 200, true);
    let scale = 0.05 * w.sqrt();
    for n in 1..s.len() - 1 {
        let (x2, v2) = s[n + 1];
        let (x1, v1) = s[n];
        let (x0, v0) = s[n - 1];
        let rx = x2 - 4.0 / 3.0 * x1 + x0 / 3.0 - 2.0 / 3.0 * h * v2;
        let rv = v2 - 4.0 / 3.0 * v1 + v0 / 3.0 + 2.0 / 3.0 * h * w * (x2 - o.rest);
        assert!(
            rx.abs() < 1e-12 && rv.abs() < 1e-9 * scale,
            "step {n}: {rx:e} {rv:e}"
        );
    }
    // One period (2π/ω = 0.314 s, 31.4 steps); the bound leaves room for
    // the parasitic root's start-up transient (modulus 0.33 per step).
    let energy = |(x, v): (f64, f64)| o.k * (x - o.rest).powi(2) + m * v * v;
    let kept = (energy(s[31]) / energy(s[0])).sqrt();
    assert!(kept > 0.95, "BDF2 kept {kept} of the amplitude");
    let euler = o.run(h, 31, false);
    assert!((energy(euler[31]) / energy(euler[0])).sqrt() < 0.6);
}

/// A crumpled cloth in zero gravity (1 cm jitter, 0.5 m/s), free, one
/// frame of `fps` a step of 5 ms, under `integrator`.
fn zero_g_cloth(seed: u64, integrator: &str, fps: u32) -> Simulation {
    let scene = common::scene_from_json(&format!(
        r#"{{"cloth": {{"grid": [12, 10], "size": [0.5, 0.4]}},
            "material": {{"density": 0.15, "stretch": 2e4, "shear": 50, "bend": 1e-5, "damping": 0.002}},
            "gravity": [0, 0, 0], "duration": 0.5, "fps": {fps},
            "solver": {{"dt": 0.005, "tolerance": 1e-12, "stopping": "residual",
                       "max_iterations": 5000, "integrator": "{integrator}"}}}}"#
    ));
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
/// momentum is conserved up to the solver's residual (the residual rule
/// alone stops it here): tolerance 1e-12 of
/// |b| ~ 1e-2 leaves momentum errors near 1e-14 kg·m/s per step; the bound
/// 1e-10 over 50 steps is generous yet six orders below the momentum.
#[test]
fn linear_momentum_is_conserved_without_gravity_or_pins() {
    let mut sim = zero_g_cloth(5, "euler", 50);
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

/// Kinetic plus elastic energy: the scale of the BDF2 guard.
fn active_energy(sim: &Simulation) -> f64 {
    sim.kinetic_energy() + sim.model().elastic_energy(&sim.state().x)
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
///
/// BDF2 is not dissipative where its linearisation is poor: without its
/// guard the crumpled cloth below gained 56 % of its kinetic and elastic
/// energy in one step, the hanging one 0.11 %. The guard
/// (`sim::ENERGY_ALLOWANCE`) redoes such a step as two halves, so each
/// step (one a frame here) gains at most that share of the energy at its
/// start; twice the share per step taken bounds a frame whose step was
/// split (its second half starts from the first's end).
#[test]
fn energy_does_not_increase_without_external_work() {
    let hanging = |integrator: &str, fps: u32| {
        common::scene_from_json(&format!(
            r#"{{"cloth": {{"grid": [15, 15], "size": [0.6, 0.6], "pinned": [[0, 0], [14, 0]]}},
            "material": "cotton", "duration": 1.0, "fps": {fps},
            "solver": {{"dt": 0.004166666666666667, "tolerance": 1e-10, "max_iterations": 5000,
                       "integrator": "{integrator}"}}}}"#
        ))
    };
    for (integrator, fps_zero_g, fps_hanging) in [("euler", 50, 60), ("bdf2", 200, 240)] {
        for mut sim in [
            zero_g_cloth(9, integrator, fps_zero_g),
            Simulation::new(&hanging(integrator, fps_hanging)).expect("builds"),
        ] {
            let scale0 = total_energy(&sim).abs().max(sim.kinetic_energy()).max(1e-3);
            let mut last = total_energy(&sim);
            let mut active = active_energy(&sim);
            let mut split = 0;
            while !sim.is_done() {
                let frame = sim.advance_frame(&Control::default()).expect("steps");
                split += frame.energy_subdivided_steps;
                let e = total_energy(&sim);
                let allowed = if integrator == "euler" {
                    1e-6 * scale0
                } else {
                    // One step a frame, each halving one step more.
                    assert_eq!(frame.steps, 1 + frame.subdivided_steps);
                    2.0 * ENERGY_ALLOWANCE * frame.steps as f64 * active.max(active_energy(&sim))
                        + 1e-12 * scale0
                };
                assert!(
                    e <= last + allowed,
                    "{integrator}: energy rose from {last} to {e} at t={}",
                    sim.state().time
                );
                last = e;
                active = active_energy(&sim);
            }
            if integrator == "bdf2" {
                assert!(split > 0, "the guard split no step");
            }
        }
    }
}

/// A stiff spring pendulum (k = 10⁴ N/m, m = 0.1 kg: `ω h` from 0.63 to
/// 0.08 over the steps below), released horizontal under gravity and
/// followed for 0.5 s: a nonlinear swing through large angles against a
/// run at `h = 2.5·10⁻⁵ s`. BDF2 linearised about its prediction converges
/// at second order (each halving cuts the error at least `2^1.8`), backward
/// Euler at first.
#[test]
fn stiff_pendulum_converges_at_second_order_with_bdf2() {
    let (k, m, rest) = (1e4, 0.1, 1.0);
    let model = one_spring(k, rest);
    let mass = [1.0, m];
    let physics = Physics {
        model: &model,
        mass: &mass,
        gravity: Vec3::new(0.0, 0.0, -9.81),
    };
    // Positions every 0.05 s (a multiple of every step).
    let run = |h: f64, bdf2: bool| -> Vec<Vec3> {
        let every = (0.05 / h).round() as usize;
        let mut samples = Vec::new();
        let mut integrator = tight_integrator(&model, 1e-13);
        let mut c = Constraints::free(2);
        let mut state = pair_at_rest(rest);
        let (mut dv, mut moved) = (vec![Vec3::zeros(); 2], vec![Vec3::zeros(); 2]);
        let (mut last_moved, mut last_dv, mut last_h) = (moved.clone(), dv.clone(), 0.0);
        for n in 1..=(0.5 / h).round() as usize {
            let scheme = if bdf2 {
                Scheme::bdf2(h, last_h, &last_moved, &last_dv)
            } else {
                Scheme::euler(h)
            };
            c.clear();
            c.fix(0, Vec3::zeros(), Vec3::zeros());
            integrator.assemble(&physics, &state, &c, &scheme);
            integrator.precondition(&physics, &c, &scheme, 0.0, &state.v, &mut dv);
            integrator.solve(&c, &mut dv);
            update(&mut state, &dv, &c, &scheme, &mut moved).expect("finite");
            (last_moved, last_dv, last_h) = (moved.clone(), dv.clone(), h);
            if n % every == 0 {
                samples.push(state.x[1]);
            }
        }
        samples
    };
    let rms = |a: &[Vec3], b: &[Vec3]| {
        let sum: f64 = a.iter().zip(b).map(|(p, q)| (p - q).norm_squared()).sum();
        (sum / a.len() as f64).sqrt()
    };
    let steps = [2e-3, 1e-3, 5e-4, 2.5e-4];
    for (bdf2, lo, hi) in [(true, 1.8, 2.6), (false, 0.7, 1.3)] {
        let reference = run(2.5e-5, bdf2);
        let errors: Vec<f64> = steps
            .iter()
            .map(|&h| rms(&run(h, bdf2), &reference))
            .collect();
        for w in errors.windows(2) {
            let order = (w[0] / w[1]).log2();
            assert!(
                (lo..hi).contains(&order),
                "bdf2 {bdf2}: errors {errors:?}, order {order}"
            );
        }
    }
}

/// The nonlinear velocity law of a BDF2 step, `M (v1 - v0 - q) = h' f(x1)`
/// (`f` the spring and gravity), as its residual's norm for the moving
/// mass of a spring pendulum.
fn pendulum_residual(
    model: &ForceModel,
    m: f64,
    g: Vec3,
    end: &ClothState,
    dv: Vec3,
    scheme: &Scheme<'_>,
) -> f64 {
    let s = &model.stretch.springs[0];
    let d = end.x[1] - end.x[0];
    let l = d.norm();
    let f = -d / l * (s.k * (l - s.rest)) + g * m;
    ((dv - scheme.velocity_carry(1)) * m - f * scheme.h_eff()).norm()
}

/// BDF2's Newton correction (`Integrator::correct`, which the step
/// pipeline runs after every two-step solve): a stiff pendulum released
/// horizontally swings down through 40 steps of 1/120 s, its spring
/// turning by up to ~2° per step, and the system linearised about
/// the prediction leaves a residual in the nonlinear velocity law. One
/// correction (a second linearisation at the step's end) must cut that
/// residual a thousandfold: Newton's method near the root squares the
/// relative residual (measured: 10⁶–10⁹, down to the solver's 10⁻¹³).
#[test]
fn bdf2_newton_correction_cuts_the_linearisation_residual() {
    let (k, m, rest) = (1e4, 0.1, 1.0);
    let model = one_spring(k, rest);
    let mass = [1.0, m];
    let g = Vec3::new(0.0, 0.0, -9.81);
    let physics = Physics {
        model: &model,
        mass: &mass,
        gravity: g,
    };
    let mut integrator = tight_integrator(&model, 1e-13);
    let mut c = Constraints::free(2);
    let mut state = pair_at_rest(rest);
    let h = 1.0 / 120.0;
    let (mut dv, mut moved) = (vec![Vec3::zeros(); 2], vec![Vec3::zeros(); 2]);
    let (mut last_moved, mut last_dv, mut last_h) = (moved.clone(), dv.clone(), 0.0);
    let mut cut = Vec::new();
    for _ in 0..40 {
        let scheme = Scheme::bdf2(h, last_h, &last_moved, &last_dv);
        c.clear();
        c.fix(0, Vec3::zeros(), Vec3::zeros());
        let start = state.clone();
        integrator.assemble(&physics, &state, &c, &scheme);
        integrator.precondition(&physics, &c, &scheme, 0.0, &state.v, &mut dv);
        integrator.solve(&c, &mut dv);
        update(&mut state, &dv, &c, &scheme, &mut moved).expect("finite");
        if scheme.is_two_step() {
            let before = pendulum_residual(&model, m, g, &state, dv[1], &scheme);
            integrator.correct(&physics, &state, &c, &scheme, &mut dv);
            assert_eq!(integrator.solve(&c, &mut dv).status, SolveStatus::Converged);
            state = start;
            update(&mut state, &dv, &c, &scheme, &mut moved).expect("finite");
            let after = pendulum_residual(&model, m, g, &state, dv[1], &scheme);
            cut.push(before / after);
        }
        (last_moved, last_dv, last_h) = (moved.clone(), dv.clone(), h);
    }
    assert!(cut.iter().all(|&c| c > 1e3), "residual cut by {cut:?}");
    // It swung: the mass has left the horizontal by more than 20°.
    assert!(
        state.x[1].z < -rest * 20f64.to_radians().sin(),
        "{:?}",
        state.x[1]
    );
}
