//! The implicit Euler step of method.md §2, solved by the modified PCG, as
//! four stages the step pipeline (`sim::step`) calls in order:
//!
//! 1. [`Integrator::assemble`]: `A dv = b` with the corrections `y`
//!    (eq. [20]) and the constraints' impulses;
//! 2. [`Integrator::precondition`]: rebuild the preconditioner;
//! 3. [`Integrator::solve`]: the modified PCG under the filters `S` and
//!    targets `z`;
//! 4. [`update`]: `v += dv`, `x += p + h' v + y`, and check both are
//!    finite.
//!
//! Every stage takes the step's [`Scheme`] (backward Euler or BDF2).
//!
//! Constraints are an input: the caller (pins, and the collision stage)
//! fills them before the step and may read the constraint impulses after
//! it. The velocity change `dv` is the caller's too (it is part of the
//! run's state: the next solve starts from it).

use super::assemble::{AssemblyInput, System};
use super::constraints::{Constraints, Filter};
use super::coupling;
use super::error_rule::{CORRECTION_SHARE, PREDICTOR_SHARE, SOLVER_SHARE, error_floor};
use super::lines::AlternatingLines;
use super::mpcg::{self, MpcgOptions, MpcgWorkspace, Problem, SolveReport};
use super::multigrid::Multigrid;
use super::precond::{BlockJacobi, Jacobi, Preconditioner};
use super::redo::RedoPatch;
use super::scheme::Scheme;
use super::state::ClothState;
use crate::cloth::{ForceModel, Grid};
use crate::math::{Mat3, Real, Vec3, is_finite};
use crate::spec::{PreconditionerKind, SolverScene, StoppingRule};

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

/// The linear system of a step, its preconditioner and the solver's
/// scratch, reused across steps (nothing allocates per step).
#[derive(Debug)]
pub struct Integrator {
    system: System,
    precond: Box<dyn Preconditioner>,
    ws: MpcgWorkspace,
    options: MpcgOptions,
    stopping: StoppingRule,
    warm_start: bool,
    /// BDF2's linearisation point, the prediction `x0 + p + h' v0`.
    predicted: Vec<Vec3>,
    /// `√M_free err / h'`: the energy-norm error bound per unit share
    /// under the error rule (`None`: the residual rule alone).
    error_scale: Option<Real>,
    /// Scratch of the Newton correction: `A1 dv`, and zero corrections.
    product: Vec<Vec3>,
    zero: Vec<Vec3>,
    /// The couplings' blocks outside `A`'s pattern (`coupling::Remote`),
    /// and their product with the last solve's `dv`.
    remote: Vec<coupling::Remote>,
    remote_dv: Vec<Vec3>,
    /// The preconditioner's boost of those couplings' diagonal blocks
    /// (`coupling::Boost`), and the blocks it replaced while it is built.
    boost: Vec<coupling::Boost>,
    unboosted: Vec<Mat3>,
    /// A redone solve's `b` without a second assembly (`redo`).
    redo: RedoPatch,
}

impl Integrator {
    /// The system of `model` on `grid`, with the preconditioner and
    /// stopping rule `settings` ask for, for steps up to `h_max` (what
    /// the line preconditioner weighs, `LeftOut`).
    pub fn new(grid: &Grid, model: &ForceModel, settings: &SolverScene, h_max: Real) -> Self {
        let mut integrator = Self::from_parts(
            grid.len(),
            model,
            preconditioner(settings.preconditioner, grid, model, h_max),
            MpcgOptions {
                tolerance: settings.tolerance,
                max_iterations: settings.max_iterations,
                reference: None,
                error_bound: None,
            },
            settings.warm_start,
        );
        integrator.stopping = settings.stopping;
        integrator
    }

    /// An integrator over `n` particles with a given preconditioner and
    /// stopping rule: for tests and benchmarks of the parts (a scene's
    /// simulation uses [`Self::new`]).
    pub fn from_parts(
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
            options,
            stopping: StoppingRule::Residual,
            warm_start,
            predicted: vec![Vec3::zeros(); n],
            error_scale: None,
            product: vec![Vec3::zeros(); n],
            zero: vec![Vec3::zeros(); n],
            remote: Vec::new(),
            remote_dv: vec![Vec3::zeros(); n],
            boost: Vec::new(),
            unboosted: Vec::new(),
            redo: RedoPatch::new(n, model),
        }
    }

    /// The filtered residual of the last solve.
    pub fn residual(&self) -> &[Vec3] {
        mpcg::residual(&self.ws)
    }

    /// The impulse the constraints exerted on particle `i` in the last
    /// solve (whose solution is `dv`), `(A dv - b)_i`: zero on free
    /// directions (to solver tolerance), the constraint force times `h` on
    /// blocked ones. Contact release reads its normal part (method.md §4).
    pub fn constraint_impulse(&self, i: usize, dv: &[Vec3]) -> Vec3 {
        let ad: Vec3 = self.system.a.row(i).map(|(j, block)| block * dv[j]).sum();
        ad + self.remote_dv[i] - self.system.b[i]
    }

    /// Stage 1: writes `A` and `b` for a step of `scheme` from `state`
    /// (eq. [20] in the scheme's variables), with the constraints'
    /// corrections `y`, impulses and couplings. An impulse `J` over the
    /// step is a force `J / h`, which the scheme weighs by `h'`: it enters
    /// as `γ J`.
    pub fn assemble(
        &mut self,
        physics: &Physics<'_>,
        state: &ClothState,
        constraints: &Constraints,
        scheme: &Scheme<'_>,
    ) {
        let predicted = scheme.is_two_step();
        if predicted {
            let h = scheme.h_eff();
            let (x, v) = (&state.x, &state.v);
            crate::parallel::for_chunks(&mut self.predicted, |start, out| {
                for (k, p) in out.iter_mut().enumerate() {
                    let i = start + k;
                    *p = x[i] + scheme.carry(i) + v[i] * h;
                }
            });
        }
        let x = if predicted { &self.predicted } else { &state.x };
        let system = &mut self.system;
        system.assemble(
            physics.model,
            &AssemblyInput {
                x,
                predicted,
                v: &state.v,
                y: &constraints.y,
                mass: physics.mass,
                gravity: physics.gravity,
                scheme: *scheme,
            },
        );
        let gamma = scheme.gamma;
        for (b, j) in system.b.iter_mut().zip(&constraints.impulse) {
            *b += j * gamma;
        }
        // The couplings, linearised where the forces were.
        self.remote.clear();
        self.boost.clear();
        coupling::add(
            &constraints.couplings,
            x,
            &system.w,
            scheme.h_eff(),
            &mut system.a,
            &mut system.b,
            (&mut self.remote, &mut self.boost),
        );
    }

    /// Stage 1 of a backward Euler step redone from the same start with
    /// the same couplings: `A` is the first solve's, and `b` is patched for
    /// the new corrections `y` and impulses from the first solve's
    /// `old_impulse` (`redo`). `false` when too many particles changed:
    /// then assemble. (Keeping the first solve's preconditioner too, built
    /// for the filters before the new contacts, took sphere-drape-100's
    /// first 0.5 s from 2,259 to 3,007 CG iterations.)
    pub fn patch_for_redo(
        &mut self,
        physics: &Physics<'_>,
        state: &ClothState,
        constraints: &Constraints,
        old_impulse: &[Vec3],
        scheme: &Scheme<'_>,
    ) -> bool {
        let input = AssemblyInput {
            x: &state.x,
            predicted: false,
            v: &state.v,
            y: &constraints.y,
            mass: physics.mass,
            gravity: physics.gravity,
            scheme: *scheme,
        };
        let pair = (old_impulse, &constraints.impulse[..]);
        !scheme.is_two_step()
            && (self.redo).apply(
                physics.model,
                &mut self.system,
                &input,
                pair,
                &constraints.couplings,
            )
    }

    /// Stage 2: starts the solve from the warm start `dv` (zeroed first
    /// when warm starts are off; its constrained components set to the
    /// targets). When that already meets the tolerance there is nothing to
    /// solve and the preconditioner is not rebuilt.
    ///
    /// `step_error` is the last step's local error estimate (metres, RMS
    /// over the free particles; 0 when unknown). Under
    /// [`StoppingRule::Error`] the solver's own error in this step's
    /// positions, `h' e`, may be [`SOLVER_SHARE`] of it: the mass-weighted
    /// RMS of `e` at most `κ err / h'`, which `|e|_A ≥ |e|_M` turns into
    /// the energy-norm bound `κ err / h' · √M_free`. Under backward Euler
    /// `err` is at least `error_floor` of the step's start velocities
    /// `v`.
    pub fn precondition(
        &mut self,
        physics: &Physics<'_>,
        constraints: &Constraints,
        scheme: &Scheme<'_>,
        step_error: Real,
        v: &[Vec3],
        dv: &mut [Vec3],
    ) {
        let h = scheme.h_eff();
        if !self.warm_start {
            dv.fill(Vec3::zeros());
        }
        // NOTE: at rest b -> 0, and a tolerance relative to |S b| alone
        // would demand ever more digits of nothing; the gravity impulse
        // h' M g sets the scale of a step's velocity change instead.
        let sb = mpcg::filtered_norm(&self.system.b, &constraints.filter);
        let gravity_impulse = crate::parallel::sum(physics.mass.len(), |r| {
            physics.mass[r.clone()]
                .iter()
                .zip(&constraints.filter[r])
                .map(|(m, f)| f.apply(&(physics.gravity * (h * m))).norm_squared())
                .sum()
        })
        .sqrt();
        self.options.reference = Some(sb.max(gravity_impulse));
        self.error_scale = (self.stopping == StoppingRule::Error && step_error > 0.0).then(|| {
            let free_mass: Real = crate::parallel::sum(physics.mass.len(), |r| {
                physics.mass[r.clone()]
                    .iter()
                    .zip(&constraints.filter[r])
                    .filter(|(_, f)| **f == Filter::Free)
                    .map(|(m, _)| m)
                    .sum()
            });
            let floor = error_floor(scheme, physics.gravity, v, &constraints.filter);
            step_error.max(floor) / h * free_mass.sqrt()
        });
        let share = if scheme.is_two_step() {
            PREDICTOR_SHARE
        } else {
            SOLVER_SHARE
        };
        self.options.error_bound = self.error_scale.map(|e| e * share);
        let problem = problem(&self.system, &self.remote, constraints);
        let start = mpcg::start(&problem, dv, &mut self.ws);
        if start > self.options.threshold(&problem) {
            self.update_preconditioner(&constraints.filter);
        }
    }

    /// Stage 3: solves for `dv` from the started solve (no iteration when
    /// the warm start met the tolerance).
    pub fn solve(&mut self, constraints: &Constraints, dv: &mut [Vec3]) -> SolveReport {
        let report = mpcg::iterate(
            &problem(&self.system, &self.remote, constraints),
            self.precond.as_mut(),
            dv,
            &self.options,
            &mut self.ws,
        );
        self.remote_dv.fill(Vec3::zeros());
        coupling::mul_add(&self.remote, dv, &mut self.remote_dv);
        report
    }
}

impl Integrator {
    /// The preconditioner rebuilt from `A` with the couplings' boost
    /// (`coupling::Boost`) under `filter`.
    fn update_preconditioner(&mut self, filter: &[Filter]) {
        let precond = &mut self.precond;
        coupling::boosted(&mut self.system.a, &self.boost, &mut self.unboosted, |a| {
            precond.update(a, filter);
        });
    }

    /// Stage 3b (BDF2): one Newton correction. The solve found `dv` for
    /// the system linearised about the prediction; `end` is where it took
    /// the cloth (`x1 = x0 + p + h' v1 + y`, `v1 = v0 + dv`). Linearising
    /// again there, with the unknown `dv'` the change of `v1`
    /// (`x = x1 + h' dv'`):
    ///
    /// ```text
    /// A1 dv' = M (q - dv) + h' f(x1, v1) + γ J,   A1 = M - h' D1 - h'² K1
    /// ```
    ///
    /// whose right-hand side is the residual the first linearisation left
    /// in the scheme's nonlinear velocity law. The solve runs on the total
    /// change `dv + dv'`: `A1 (dv + dv') = b1 + A1 dv`, warm-started at
    /// `dv`, so constrained components keep their targets; this stage sets
    /// it up (assembly at the end, the preconditioner rebuilt from `A1`)
    /// and [`Self::solve`] runs it. A simplified Newton step reusing the
    /// first `A` does not work: a spring that turned in the step has its
    /// stiff residual along its new direction, which the old `A` partly
    /// takes for a soft one (on hanging-corners most steps overstretched
    /// and were redone as halves).
    ///
    /// Why: `A` holds the solver's positive semi-definite stiffness, which
    /// drops the buckling term of every compressed spring
    /// (`cloth::stretch`), and springs turn within a step where the cloth
    /// swings fast. At a frame-sized step both move BDF2's step by about
    /// twice its own local error; one correction removes most of that
    /// (docs/benchmarks.md, 1c). Backward Euler's first-order error hides
    /// it and is left alone.
    pub fn correct(
        &mut self,
        physics: &Physics<'_>,
        end: &ClothState,
        constraints: &Constraints,
        scheme: &Scheme<'_>,
        dv: &mut [Vec3],
    ) {
        self.system.assemble(
            physics.model,
            &AssemblyInput {
                x: &end.x,
                predicted: true,
                v: &end.v,
                y: &self.zero,
                mass: physics.mass,
                gravity: physics.gravity,
                scheme: *scheme,
            },
        );
        let system = &mut self.system;
        self.remote.clear();
        self.boost.clear();
        coupling::add(
            &constraints.couplings,
            &end.x,
            &system.w,
            scheme.h_eff(),
            &mut system.a,
            &mut system.b,
            (&mut self.remote, &mut self.boost),
        );
        problem(&self.system, &self.remote, constraints).apply(dv, &mut self.product);
        let gamma = scheme.gamma;
        let (product, mass, impulse) = (&self.product, physics.mass, &constraints.impulse);
        crate::parallel::for_chunks(&mut self.system.b, |start, b| {
            for (k, b) in b.iter_mut().enumerate() {
                let i = start + k;
                *b += impulse[i] * gamma - dv[i] * mass[i] + product[i];
            }
        });
        // NOTE: the first solve's preconditioner, lagged (valid, since MPCG
        // filters its output), doubled the correction's iterations on
        // hanging-corners; rebuilt, the correction costs less.
        self.update_preconditioner(&constraints.filter);
        self.options.error_bound = self.error_scale.map(|e| e * CORRECTION_SHARE);
        mpcg::start(
            &problem(&self.system, &self.remote, constraints),
            dv,
            &mut self.ws,
        );
    }
}

/// The system of `system` and the couplings' `remote` blocks under
/// `constraints`.
fn problem<'a>(
    system: &'a System,
    remote: &'a [coupling::Remote],
    constraints: &'a Constraints,
) -> Problem<'a> {
    Problem {
        a: &system.a,
        remote,
        b: &system.b,
        filter: &constraints.filter,
        z: &constraints.z,
    }
}

/// Stage 4: `v += dv`, `x += p + h' v + y`, `t += h` for a step of
/// `scheme`, leaving each particle's displacement in `moved` (the next
/// BDF2 step's memory); the first non-finite velocity change or position
/// is an error (the state is then partly updated and must be discarded).
pub fn update(
    state: &mut ClothState,
    dv: &[Vec3],
    constraints: &Constraints,
    scheme: &Scheme<'_>,
    moved: &mut [Vec3],
) -> Result<(), StepError> {
    if let Some(particle) = dv.iter().position(|d| !is_finite(d)) {
        return Err(StepError {
            particle,
            quantity: "velocity change",
        });
    }
    let y = &constraints.y;
    let h = scheme.h_eff();
    crate::parallel::for_chunks2(&mut state.v, moved, |start, v, m| {
        for k in 0..v.len() {
            let i = start + k;
            v[k] += dv[i];
            m[k] = scheme.carry(i) + v[k] * h + y[i];
        }
    });
    crate::parallel::for_chunks(&mut state.x, |start, x| {
        for (k, x) in x.iter_mut().enumerate() {
            *x += moved[start + k];
        }
    });
    state.time += scheme.h;
    if let Some(particle) = state.x.iter().position(|x| !is_finite(x)) {
        return Err(StepError {
            particle,
            quantity: "position",
        });
    }
    Ok(())
}

/// The preconditioner `kind` for a cloth on `grid` with forces `model`,
/// stepped by at most `h`.
fn preconditioner(
    kind: PreconditionerKind,
    grid: &Grid,
    model: &ForceModel,
    h: Real,
) -> Box<dyn Preconditioner> {
    match kind {
        PreconditionerKind::Jacobi => Box::<Jacobi>::default(),
        PreconditionerKind::BlockJacobi => Box::<BlockJacobi>::default(),
        PreconditionerKind::Lines => Box::new(AlternatingLines::for_cloth(grid, &model.bend, h)),
        PreconditionerKind::Multigrid => Box::new(Multigrid::new(grid.nu, grid.nv)),
    }
}
