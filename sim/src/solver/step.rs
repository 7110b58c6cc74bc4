//! One implicit Euler step (method.md §2), as a table of stages:
//!
//! 1. assemble `A dv = b` with the corrections `y` (eq. [20]);
//! 2. update the preconditioner;
//! 3. solve with the modified PCG under the filters `S` and targets `z`;
//! 4. update `v += dv`, `x += h v + y`, and check both are finite.
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
        }
    }

    /// The filtered residual of the last solve: the constraint force
    /// direction the collision stage uses to release contacts.
    pub fn residual(&self) -> &[Vec3] {
        mpcg::residual(&self.ws)
    }

    /// The impulse the constraints exerted on particle `i` in the last
    /// solve, `(A dv - b)_i`: zero on free directions (to solver
    /// tolerance), the constraint force times `h` on blocked ones. Contact
    /// release reads its normal part (method.md §4).
    pub fn constraint_impulse(&self, i: usize) -> Vec3 {
        let ad: Vec3 = self
            .system
            .a
            .row(i)
            .map(|(j, block)| block * self.dv[j])
            .sum();
        ad - self.system.b[i]
    }

    /// The last step's velocity change.
    pub fn last_dv(&self) -> &[Vec3] {
        &self.dv
    }

    /// Restores a velocity change as the next solve's warm start (a
    /// checkpoint resumed); ignored if its length does not match.
    pub fn set_warm_start(&mut self, dv: &[Vec3]) {
        if dv.len() == self.dv.len() {
            self.dv.copy_from_slice(dv);
        }
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
            for (b, j) in self.system.b.iter_mut().zip(&constraints.impulse) {
                *b += j;
            }
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
            let sb = mpcg::filtered_norm(&self.system.b, &constraints.filter);
            let gravity_impulse = physics
                .mass
                .iter()
                .zip(&constraints.filter)
                .map(|(m, f)| f.apply(&(physics.gravity * (h * m))).norm_squared())
                .sum::<Real>()
                .sqrt();
            let options = MpcgOptions {
                reference: Some(sb.max(gravity_impulse)),
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
        Ok(StepReport { solve, times })
    }
}
