//! One implicit Euler step (method.md §2), as a table of stages:
//!
//! 1. assemble `A dv = b` with the corrections `y` (eq. [20]);
//! 2. update the preconditioner;
//! 3. solve with the modified PCG under the filters `S` and targets `z`;
//! 4. update `v += dv`, `x += h v + y`, and check both are finite;
//! 5. if that step stretched an edge past the guard, finish the nonlinear
//!    backward Euler solve with Newton iterations re-linearised at the new
//!    iterate: `(M - h D - h² K) δv = h f(x_k, v_k) - M (v_k - v0)`, with
//!    the constrained directions already at their targets (`z = 0`).
//!
//! One linearisation per step (Baraff & Witkin) is exact for small
//! rotations per step; a cloth swinging through a large angle in one long
//! step gets stretched by it. The guard keeps the cheap path for ordinary
//! steps and pays for Newton only where the linearisation fails.
//!
//! Constraints are an input: the caller (pins, and the collision stage)
//! fills them before the step and may read the solve's residual after it.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::assemble::{AssemblyInput, System};
use super::constraints::Constraints;
use super::mpcg::{self, MpcgOptions, MpcgWorkspace, Problem, SolveReport};
use super::precond::Preconditioner;
use crate::cloth::ForceModel;
use crate::math::{Real, Vec3, is_finite};

/// The cloth's state: serialisable so a run can checkpoint and resume.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClothState {
    /// Simulated time, seconds.
    pub time: Real,
    /// Positions.
    pub x: Vec<Vec3>,
    /// Velocities.
    pub v: Vec<Vec3>,
}

/// Wall time of each stage of a step, seconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct StageTimes {
    /// Collision detection and response setup.
    pub collision: f64,
    /// Force and Jacobian assembly.
    pub assemble: f64,
    /// Preconditioner update.
    pub precondition: f64,
    /// The modified PCG.
    pub solve: f64,
    /// State update and checks.
    pub update: f64,
}

impl StageTimes {
    /// Sum over stages.
    pub fn total(&self) -> f64 {
        self.collision + self.assemble + self.precondition + self.solve + self.update
    }

    /// Adds another step's times.
    pub fn add(&mut self, o: &StageTimes) {
        self.collision += o.collision;
        self.assemble += o.assemble;
        self.precondition += o.precondition;
        self.solve += o.solve;
        self.update += o.update;
    }
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// The linear solve.
    pub solve: SolveReport,
    /// Stage timings (the collision field is filled by the caller).
    pub times: StageTimes,
    /// Newton iterations after the first linearised solve.
    pub newton_iterations: usize,
}

/// A step that produced non-finite numbers.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("non-finite {quantity} at particle {particle}")]
pub struct StepError {
    /// The first offending particle.
    pub particle: usize,
    /// `"velocity change"` or `"position"`.
    pub quantity: &'static str,
}

/// The physical inputs of a step besides the state.
#[derive(Debug, Clone, Copy)]
pub struct Physics<'a> {
    /// The cloth's forces.
    pub model: &'a ForceModel,
    /// Lumped masses.
    pub mass: &'a [Real],
    /// Gravitational acceleration.
    pub gravity: Vec3,
}

/// When one linearised step leaves an edge longer than this (relative to
/// rest), Newton iterations finish the step.
pub const NEWTON_STRETCH_GUARD: Real = 1.01;
/// Newton iterations after the first linearised solve, at most.
pub const NEWTON_MAX_EXTRA: usize = 6;

/// The step pipeline with its reusable workspace (nothing allocates per
/// step).
#[derive(Debug)]
pub struct Integrator {
    system: System,
    precond: Box<dyn Preconditioner>,
    ws: MpcgWorkspace,
    dv: Vec<Vec3>,
    options: MpcgOptions,
    warm_start: bool,
    newton: NewtonScratch,
}

/// Buffers of the Newton iterations.
#[derive(Debug, Default)]
struct NewtonScratch {
    x0: Vec<Vec3>,
    v0: Vec<Vec3>,
    y: Vec<Vec3>,
    zero: Vec<Vec3>,
    delta: Vec<Vec3>,
}

impl Integrator {
    /// A pipeline for `model` on `n` particles.
    pub fn new(
        n: usize,
        model: &ForceModel,
        precond: Box<dyn Preconditioner>,
        options: MpcgOptions,
        warm_start: bool,
    ) -> Self {
        Self {
            system: System::new(n, model),
            precond,
            ws: MpcgWorkspace::default(),
            dv: vec![Vec3::zeros(); n],
            options,
            warm_start,
            newton: NewtonScratch::default(),
        }
    }

    /// The filtered residual of the last solve: the constraint force
    /// direction the collision stage uses to release contacts.
    pub fn residual(&self) -> &[Vec3] {
        mpcg::residual(&self.ws)
    }

    /// The last step's velocity change.
    pub fn last_dv(&self) -> &[Vec3] {
        &self.dv
    }

    /// Forgets the warm start (after a rejected step or a teleport).
    pub fn reset_warm_start(&mut self) {
        self.dv.fill(Vec3::zeros());
    }

    /// Advances `state` by `h` under `constraints`.
    pub fn step(
        &mut self,
        state: &mut ClothState,
        physics: &Physics<'_>,
        constraints: &Constraints,
        h: Real,
    ) -> Result<StepReport, StepError> {
        let nw = &mut self.newton;
        nw.x0.clone_from(&state.x);
        nw.v0.clone_from(&state.v);
        let mut report = self.linear_step(state, physics, constraints, h)?;
        let mut extra = 0;
        while extra < NEWTON_MAX_EXTRA
            && physics.model.stretch.max_ratio(&state.x) > NEWTON_STRETCH_GUARD
        {
            let (solve, times) = self.newton_iteration(state, physics, constraints, h)?;
            report.solve.iterations += solve.iterations;
            report.solve.residual = solve.residual;
            report.solve.status = solve.status;
            report.times.add(&times);
            extra += 1;
            // Converged when the correction is small against the step.
            let step_dv: Real = state
                .v
                .iter()
                .zip(&self.newton.v0)
                .map(|(a, b)| (a - b).norm_squared())
                .sum();
            let corr: Real = self.newton.delta.iter().map(|d| d.norm_squared()).sum();
            if corr <= 1e-6 * step_dv {
                break;
            }
        }
        report.newton_iterations = extra;
        Ok(report)
    }

    /// One Newton iteration at the current iterate `(x_k, v_k)`.
    fn newton_iteration(
        &mut self,
        state: &mut ClothState,
        physics: &Physics<'_>,
        constraints: &Constraints,
        h: Real,
    ) -> Result<(SolveReport, StageTimes), StepError> {
        let mut times = StageTimes::default();
        let n = state.x.len();
        let nw = &mut self.newton;
        // y = -h v_k makes the K term of b vanish: b = h f(x_k, v_k).
        nw.y.clear();
        nw.y.extend(state.v.iter().map(|v| -v * h));
        nw.zero.clear();
        nw.zero.resize(n, Vec3::zeros());
        nw.delta.clear();
        nw.delta.resize(n, Vec3::zeros());
        let t = Instant::now();
        self.system.assemble(
            physics.model,
            &AssemblyInput {
                x: &state.x,
                v: &state.v,
                y: &nw.y,
                mass: physics.mass,
                gravity: physics.gravity,
                h,
            },
        );
        for i in 0..n {
            self.system.b[i] -= (state.v[i] - nw.v0[i]) * physics.mass[i];
        }
        times.assemble = t.elapsed().as_secs_f64();
        let t = Instant::now();
        self.precond.update(&self.system.a, &constraints.filter);
        times.precondition = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let options = MpcgOptions {
            reference: Some(
                filtered_norm(&self.system.b, constraints).max(gravity_impulse(
                    physics,
                    constraints,
                    h,
                )),
            ),
            ..self.options
        };
        let solve = mpcg::solve(
            &Problem {
                a: &self.system.a,
                b: &self.system.b,
                filter: &constraints.filter,
                z: &nw.zero,
            },
            self.precond.as_ref(),
            &mut nw.delta,
            &options,
            &mut self.ws,
        );
        times.solve = t.elapsed().as_secs_f64();
        let t = Instant::now();
        if let Some(particle) = nw.delta.iter().position(|d| !is_finite(d)) {
            return Err(StepError {
                particle,
                quantity: "velocity change",
            });
        }
        for i in 0..n {
            state.v[i] += nw.delta[i];
            self.dv[i] += nw.delta[i];
            state.x[i] = nw.x0[i] + state.v[i] * h + constraints.y[i];
        }
        times.update = t.elapsed().as_secs_f64();
        Ok((solve, times))
    }

    /// The single linearised solve of method.md §2.
    fn linear_step(
        &mut self,
        state: &mut ClothState,
        physics: &Physics<'_>,
        constraints: &Constraints,
        h: Real,
    ) -> Result<StepReport, StepError> {
        let mut times = StageTimes::default();

        let t = Instant::now();
        {
            let _s = tracing::trace_span!("assemble").entered();
            self.system.assemble(
                physics.model,
                &AssemblyInput {
                    x: &state.x,
                    v: &state.v,
                    y: &constraints.y,
                    mass: physics.mass,
                    gravity: physics.gravity,
                    h,
                },
            );
        }
        times.assemble = t.elapsed().as_secs_f64();

        let t = Instant::now();
        {
            let _s = tracing::trace_span!("precondition").entered();
            self.precond.update(&self.system.a, &constraints.filter);
        }
        times.precondition = t.elapsed().as_secs_f64();

        let t = Instant::now();
        let solve = {
            let _s = tracing::trace_span!("solve").entered();
            if !self.warm_start {
                self.dv.fill(Vec3::zeros());
            }
            // NOTE: at rest b -> 0, and a tolerance relative to |S b| alone
            // would demand ever more digits of nothing; the gravity impulse
            // h M g sets the scale of a step's velocity change instead.
            let sb = filtered_norm(&self.system.b, constraints);
            let options = MpcgOptions {
                reference: Some(sb.max(gravity_impulse(physics, constraints, h))),
                ..self.options
            };
            mpcg::solve(
                &Problem {
                    a: &self.system.a,
                    b: &self.system.b,
                    filter: &constraints.filter,
                    z: &constraints.z,
                },
                self.precond.as_ref(),
                &mut self.dv,
                &options,
                &mut self.ws,
            )
        };
        times.solve = t.elapsed().as_secs_f64();

        let t = Instant::now();
        {
            let _s = tracing::trace_span!("update").entered();
            if let Some(particle) = self.dv.iter().position(|d| !is_finite(d)) {
                return Err(StepError {
                    particle,
                    quantity: "velocity change",
                });
            }
            for i in 0..state.x.len() {
                state.v[i] += self.dv[i];
                state.x[i] += state.v[i] * h + constraints.y[i];
            }
            state.time += h;
            if let Some(particle) = state.x.iter().position(|x| !is_finite(x)) {
                return Err(StepError {
                    particle,
                    quantity: "position",
                });
            }
        }
        times.update = t.elapsed().as_secs_f64();
        Ok(StepReport {
            solve,
            times,
            newton_iterations: 0,
        })
    }
}

/// `|S h M g|`: the scale of a step's velocity change under gravity.
fn gravity_impulse(physics: &Physics<'_>, constraints: &Constraints, h: Real) -> Real {
    physics
        .mass
        .iter()
        .zip(&constraints.filter)
        .map(|(m, f)| f.apply(&(physics.gravity * (h * m))).norm_squared())
        .sum::<Real>()
        .sqrt()
}

fn filtered_norm(b: &[Vec3], c: &Constraints) -> Real {
    b.iter()
        .zip(&c.filter)
        .map(|(b, f)| f.apply(b).norm_squared())
        .sum::<Real>()
        .sqrt()
}
