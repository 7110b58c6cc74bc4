//! One step of the simulation, as a table of stages (method.md §2-§4):
//!
//! | stage | does |
//! | --- | --- |
//! | constrain | pins -> filters `S`, targets `z`, corrections `y` |
//! | collision prepare | contacts and predicted crossings -> `S`, `z`, `y`, friction impulses |
//! | couplings | pairs near obstacles' sharp features, and layers of cloth within the thickness -> springs |
//! | assemble | forces and Jacobians -> `A dv = b` (eq. [20]), then the springs into `A`, `b`; a redo keeps `A` and patches `b` |
//! | precondition | the warm start's residual; the preconditioner from `A` unless that already converged |
//! | solve | the modified PCG (filtered residual) |
//! | update | `v += dv`, `x += p + h' v + y`, finiteness |
//! | collision resolve | the path taken: accept (release, friction) or redo with new contacts |
//! | self-collision | the accepted motion kept from passing the cloth through itself |
//! | sharp features | cloth edges and triangles kept off obstacles' corners and edges |
//!
//! A redo (at most [`MAX_REDOS`] per step) starts again from the
//! constrain stage with the step's start state and the grown contact set;
//! crossings left after the last redo take effect from the next step.
//! Every stage is timed and traced by [`StageClock`].

use super::apart::ApartStage;
use super::error::SimError;
use super::sharp::SharpStage;
use super::stage::{Stage, StageClock, StageTimes};
use super::state::RunState;
use super::workspace::Workspace;
use super::world::World;
use crate::collision::{CollisionStage, StepFrame, Verdict};
use crate::math::{Real, Vec3};
use crate::selfcollision::{SelfCollision, SelfReport};
use crate::solver::{self, ClothState, Coupling, Scheme, SolveReport};
use crate::spec::IntegratorKind;

/// Redos of one step's solve when particles cross a surface mid-step;
/// crossings left after the last are handled by the next step.
pub const MAX_REDOS: usize = 2;

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// The linear solve (iterations summed over redos).
    pub solve: SolveReport,
    /// Wall time of each stage.
    pub times: StageTimes,
    /// The embedded estimate of the step's local position error, RMS
    /// over the unconstrained particles, metres (`solver::local_error`).
    pub error: Real,
    /// What self-collision did.
    pub self_collision: SelfReport,
    /// Whether the sharp-feature stage's corrections passed the cloth
    /// through itself (`selfcollision::recheck`): the driver redoes the
    /// step in halves.
    pub crossed_after_sharp: bool,
    /// Whether the sharp-feature stage's pairs passed their budget
    /// (`SharpReport::over_budget`): the driver redoes the step in halves.
    pub sharp_over_budget: bool,
}

/// Advances `run` by one step of `h`.
pub fn step(
    world: &World,
    run: &mut RunState,
    ws: &mut Workspace,
    h: Real,
) -> Result<StepReport, SimError> {
    let _span = tracing::trace_span!("step", step = run.steps).entered();
    let physics = world.physics();
    let scheme = match world.scene.solver.integrator {
        IntegratorKind::Euler => Scheme::euler(h),
        IntegratorKind::Bdf2 if run.last_dx.len() == run.state.x.len() => {
            Scheme::bdf2(h, run.last_h, &run.last_dx, &run.last_dv)
        }
        // No memory (the first step, or a checkpoint from before it was
        // kept): a restart.
        IntegratorKind::Bdf2 => Scheme::euler(h),
    };
    let frame = StepFrame {
        mass: &world.grid.mass,
        pinned: world.pins.mask(),
        time: run.state.time,
        h,
        scheme,
    };
    if world.obstacles.is_some() || ws.self_collision.is_some() || scheme.is_two_step() {
        ws.step_start.clone_from(&run.state);
    }
    let mut clock = StageClock::default();
    let mut iterations = 0;
    let mut redos = 0;
    loop {
        // A redo starts from the same state, so the couplings gathered for
        // the first solve are the ones a second gathering would find, bit
        // for bit: they are kept (BDF2's, re-gathered at its correction's
        // end, are not). Sphere-drape-100 redoes 68 of its first 120 steps.
        let kept = (redos > 0 && !scheme.is_two_step())
            .then(|| std::mem::take(&mut ws.constraints.couplings));
        let redone = kept.is_some();
        if redone {
            ws.redo_impulse.clone_from(&ws.constraints.impulse);
        }
        clock.run(Stage::Constrain, || {
            world
                .pins
                .constrain(&run.state, &run.anchors, &scheme, &mut ws.constraints)
        });
        if let Some(obstacles) = &world.obstacles {
            clock.run(Stage::CollisionPrepare, || {
                CollisionStage {
                    obstacles,
                    contacts: &mut run.contacts,
                    scratch: &mut ws.collision,
                }
                .prepare(
                    &frame,
                    &run.state.x,
                    &run.state.v,
                    &run.warm_start,
                    &mut ws.constraints,
                )
            });
        }
        // The couplings first, then the forces: each spreads its own loops
        // over the team (gathered beside the assembly instead, each stage
        // kept to one core and sphere-drape-100's assembly took 8.7 s
        // where its bands on both cores take 4.2 s).
        match kept {
            Some(couplings) => ws.constraints.couplings = couplings,
            None => couple(
                world,
                (&mut ws.sharp, &mut ws.self_collision),
                &mut ws.constraints.couplings,
                &mut clock,
                &frame,
                frame.time,
                (&run.state.x, Some(&run.last_moved)),
            ),
        }
        // A redo's `A` is the first solve's: its `b` is patched for the
        // new contacts (`Integrator::patch_for_redo`).
        let patched = redone
            && clock.run(Stage::Assemble, || {
                let (c, old) = (&ws.constraints, &ws.redo_impulse);
                ws.integrator
                    .patch_for_redo(&physics, &run.state, c, old, &scheme)
            });
        if !patched {
            clock.run(Stage::Assemble, || {
                ws.integrator
                    .assemble(&physics, &run.state, &ws.constraints, &scheme)
            });
        }
        clock.run(Stage::Precondition, || {
            ws.integrator.precondition(
                &physics,
                &ws.constraints,
                &scheme,
                run.last_error,
                &run.state.v,
                &mut run.warm_start,
            )
        });
        // BDF2 linearises twice: the Newton correction re-assembles at the
        // first solve's end and the step is redone from its start.
        let passes = if scheme.is_two_step() { 2 } else { 1 };
        let mut pass = 0;
        let mut solve = loop {
            if pass > 0 {
                // The couplings of the pairs as they are where the
                // correction linearises: a chord that slid over an edge
                // in the first solve has a new closest point and direction,
                // and layers that met in it are held.
                ws.constraints.couplings.clear();
                couple(
                    world,
                    (&mut ws.sharp, &mut ws.self_collision),
                    &mut ws.constraints.couplings,
                    &mut clock,
                    &frame,
                    frame.time + h,
                    (&run.state.x, None),
                );
                clock.run(Stage::Correct, || {
                    ws.integrator.correct(
                        &physics,
                        &run.state,
                        &ws.constraints,
                        &scheme,
                        &mut run.warm_start,
                    )
                });
                run.state.clone_from(&ws.step_start);
            }
            let solve = clock.run(Stage::Solve, || {
                ws.integrator.solve(&ws.constraints, &mut run.warm_start)
            });
            iterations += solve.iterations;
            clock.run(Stage::Update, || {
                update(
                    &mut run.state,
                    &run.warm_start,
                    ws,
                    &scheme,
                    run.steps,
                    frame.time,
                )
            })?;
            pass += 1;
            if pass == passes {
                break solve;
            }
        };
        solve.iterations = iterations;
        let verdict = match &world.obstacles {
            None => Verdict::Accept,
            Some(obstacles) => clock.run(Stage::CollisionResolve, || {
                let integrator = &ws.integrator;
                let dv = &run.warm_start;
                CollisionStage {
                    obstacles,
                    contacts: &mut run.contacts,
                    scratch: &mut ws.collision,
                }
                .resolve(
                    &frame,
                    &ws.step_start.x,
                    &run.state.x,
                    &run.state.v,
                    world.scene.gravity.norm(),
                    redos < MAX_REDOS,
                    |i| integrator.constraint_impulse(i, dv),
                )
            }),
        };
        match verdict {
            Verdict::Accept => {
                let error = solver::local_error(
                    &scheme,
                    &run.state.v,
                    &run.warm_start,
                    &ws.moved,
                    &ws.constraints,
                );
                // BDF2's memory of the displacement: the solve's, before the
                // stages below correct it (`RunState::last_dx`).
                let bdf2 = world.scene.solver.integrator == IntegratorKind::Bdf2;
                if bdf2 {
                    ws.solved.clone_from(&ws.moved);
                }
                let self_collision = clock.run(Stage::SelfCollision, || {
                    let Some(cloth) = &mut ws.self_collision else {
                        return SelfReport::default();
                    };
                    ApartStage {
                        cloth,
                        scratch: &mut ws.apart,
                        filter: &ws.constraints.filter,
                        collision: &mut ws.collision,
                        x0: &ws.step_start.x,
                        moved: &mut ws.moved,
                    }
                    .run(
                        &frame,
                        world.obstacles.as_ref(),
                        &mut run.state,
                        &mut run.contacts,
                    )
                });
                let (mut crossed_after_sharp, mut sharp_over_budget) = (false, false);
                if let (Some(sharp), Some(obstacles)) = (&mut ws.sharp, &world.obstacles) {
                    clock.run(Stage::SharpFeatures, || {
                        if ws.self_collision.is_some() {
                            ws.before_sharp.clone_from(&run.state.x);
                        }
                        let report = sharp.run(
                            &frame,
                            obstacles,
                            &ws.step_start.x,
                            &mut run.state,
                            &mut ws.moved,
                            &mut run.contacts,
                        );
                        sharp_over_budget = report.over_budget;
                        if let (Some(cloth), true) = (
                            &mut ws.self_collision,
                            report.corrections + report.frozen > 0,
                        ) {
                            crossed_after_sharp =
                                cloth.crosses_along(&ws.before_sharp, &run.state.x);
                        }
                    });
                }
                // The step's motion (the next step's plan), and BDF2's
                // memory of the velocity change, before the warm start is
                // corrected below.
                run.last_moved.clone_from(&ws.moved);
                run.last_dv.clone_from(&run.warm_start);
                if bdf2 {
                    std::mem::swap(&mut run.last_dx, &mut ws.solved);
                } else {
                    run.last_dx.clear();
                }
                run.last_h = h;
                run.last_error = error;
                for &(i, dv) in ws.collision.released() {
                    run.warm_start[i as usize] += dv;
                }
                run.steps += 1;
                return Ok(StepReport {
                    solve,
                    error,
                    self_collision,
                    crossed_after_sharp,
                    sharp_over_budget,
                    times: clock.times(),
                });
            }
            Verdict::Redo => {
                run.state.clone_from(&ws.step_start);
                redos += 1;
            }
        }
    }
}

/// The update stage: `state` advanced by the solved velocity change `dv`
/// (`solver::update`), a non-finite result named by the step's number and
/// start time.
fn update(
    state: &mut ClothState,
    dv: &[Vec3],
    ws: &mut Workspace,
    scheme: &Scheme<'_>,
    step: usize,
    time: Real,
) -> Result<(), SimError> {
    solver::update(state, dv, &ws.constraints, scheme, &mut ws.moved).map_err(|e| {
        SimError::NonFinite {
            step,
            time,
            particle: e.particle,
            quantity: e.quantity,
        }
    })
}

/// The couplings stage: springs for cloth near obstacles' sharp features
/// (their corners placed at `time`) and for layers of cloth closer than
/// the thickness, the cloth at `x`, appended to the step's constraints;
/// with the last step's motion, self-collision plans the step's pairs
/// at `x` first (`selfcollision::plan`).
fn couple(
    world: &World,
    (sharp, layers): (&mut Option<SharpStage>, &mut Option<SelfCollision>),
    couplings: &mut Vec<Coupling>,
    clock: &mut StageClock,
    frame: &StepFrame<'_>,
    time: Real,
    (x, last_moved): (&[Vec3], Option<&[Vec3]>),
) {
    if let (Some(sharp), Some(obstacles)) = (sharp, &world.obstacles) {
        clock.run(Stage::SharpFeatures, || {
            sharp.prepare(obstacles, time, x, couplings)
        });
    }
    if let Some(layers) = layers {
        clock.run(Stage::SelfCollision, || {
            layers.couple(x, frame.mass, frame.h, last_moved, couplings)
        });
    }
}
