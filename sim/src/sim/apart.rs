//! The self-collision stage of a step: the accepted motion from
//! `ws.step_start` corrected so the cloth does not pass through itself
//! (`crate::selfcollision`), without pushing it into an obstacle.
//!
//! | part | does |
//! | --- | --- |
//! | holds | a pin does not yield; a particle on one obstacle yields only by leaving it (`Hold::Lift`), on two or more (a corner) not at all; a free particle within the thickness of an obstacle is lifted, never pushed in |
//! | resolve | the response; a particle it moved that ends inside an obstacle's offset surface is held as above (or fixed, if it already was) and the response runs again from the solve's motion, at most [`ROUNDS`] more times |
//! | release | a particle lifted off its obstacle by more than [`LIFT_OFF`] of the thickness loses its contact |
//!
//! Why the obstacles enter: the contact stage lands a particle predicted
//! to cross a surface exactly on it. A fold falling onto the floor had
//! its upper layer landed on top of the lower one; held there, neither
//! could yield, both lay in the floor's plane, and the layers passed
//! through each other within it (the curtain piling onto a floor, when
//! its pins ended 3 cm further back). And a response that may push free
//! cloth anywhere drove the lower layer of a pile up to 9 mm into the
//! floor: impulses and rigid zones know nothing of the obstacles, so the
//! stage tells them what each particle rests on.

use crate::collision::{CollisionScratch, CollisionStage, Contact, Obstacles, StepFrame};
use crate::math::{Real, Vec3};
use crate::selfcollision::{Hold, SelfCollision, SelfReport};
use crate::solver::{ClothState, Filter};

/// A particle on an obstacle that the response lifts off by more than
/// this share of the thickness loses its contact: held to the surface,
/// the next step would pull it back through the layer beneath.
const LIFT_OFF: Real = 0.01;

/// Reruns of the response after particles it pushed into an obstacle are
/// held; the last run's result stands (it pushes in no more than the
/// solve's motion allows the particles it holds).
const ROUNDS: usize = 3;

/// The stage's buffers, reused across steps.
#[derive(Debug, Clone, Default)]
pub struct ApartScratch {
    held: Vec<Hold>,
    /// Particles on an obstacle, with their displacement along its normal
    /// before the response.
    lifted: Vec<(u32, Real)>,
    near: Vec<(u32, Vec3)>,
    /// The solve's end state and motion, to run the response again from.
    x: Vec<Vec3>,
    v: Vec<Vec3>,
    moved: Vec<Vec3>,
}

impl ApartScratch {
    /// Pins fixed; a particle whose filter holds it on one obstacle
    /// (`kept`: contacts in particle order) lifts off that obstacle's
    /// normal, on more than one it is fixed; the rest free.
    fn holds(&mut self, pinned: &[bool], filter: &[Filter], kept: &[(u32, Vec3)]) {
        self.held.clear();
        self.held.extend(filter.iter().enumerate().map(|(i, f)| {
            if *f == Filter::Free {
                return Hold::Free;
            }
            if pinned[i] {
                return Hold::Fixed;
            }
            let start = kept.partition_point(|&(p, _)| (p as usize) < i);
            match kept[start..] {
                [(p, n), (q, _), ..] if p as usize == i && q as usize != i => Hold::Lift(n),
                [(p, n)] if p as usize == i => Hold::Lift(n),
                _ => Hold::Fixed,
            }
        }));
    }
}

/// The self-collision stage over one accepted step: the cloth's
/// self-collision, the stage's buffers and the step's pieces it reads.
pub struct ApartStage<'a> {
    /// The cloth's self-collision.
    pub cloth: &'a mut SelfCollision,
    /// The stage's buffers.
    pub scratch: &'a mut ApartScratch,
    /// The step's filters (which particles the solve held).
    pub filter: &'a [Filter],
    /// The collision stage's buffers (the contacts the step kept).
    pub collision: &'a mut CollisionScratch,
    /// Positions at the step's start.
    pub x0: &'a [Vec3],
    /// Each particle's displacement in the step: the solve's on entry,
    /// the corrected one on return.
    pub moved: &'a mut [Vec3],
}

impl ApartStage<'_> {
    /// Runs the stage (the module's table) on the accepted `state`;
    /// `contacts` loses the contacts of particles the response lifted off.
    pub fn run(
        self,
        frame: &StepFrame<'_>,
        obstacles: Option<&Obstacles>,
        state: &mut ClothState,
        contacts: &mut Vec<Contact>,
    ) -> SelfReport {
        let (sc, a, moved) = (self.cloth, self.scratch, self.moved);
        a.holds(frame.pinned, self.filter, self.collision.kept());
        let mut stage = obstacles.map(|obstacles| CollisionStage {
            obstacles,
            contacts: &mut *contacts,
            scratch: &mut *self.collision,
        });
        if let Some(stage) = &mut stage {
            let (held, near) = (&a.held, &mut a.near);
            near.clear();
            stage.near_surfaces(&state.x, sc.thickness(), |i| held[i] != Hold::Free, near);
            for &(i, n) in near.iter() {
                a.held[i as usize] = Hold::Lift(n);
            }
            a.x.clone_from(&state.x);
            a.v.clone_from(&state.v);
            a.moved.clear();
            a.moved.extend_from_slice(moved);
        }
        a.lifted.clear();
        a.lifted.extend(
            a.held
                .iter()
                .enumerate()
                .filter_map(|(i, held)| match held {
                    Hold::Lift(n) => Some((i as u32, n.dot(&moved[i]))),
                    _ => None,
                }),
        );
        let mut round = 0;
        let report = loop {
            let report = sc.resolve(self.x0, frame.mass, &a.held, frame.h, state, moved);
            let Some(stage) = &mut stage else {
                break report;
            };
            if round == ROUNDS {
                break report;
            }
            round += 1;
            let (near, solved) = (&mut a.near, &a.x);
            near.clear();
            stage.near_surfaces(&state.x, 0.0, |i| state.x[i] == solved[i], near);
            if near.is_empty() {
                break report;
            }
            for &(i, n) in near.iter() {
                let held = &mut a.held[i as usize];
                *held = match held {
                    Hold::Free => Hold::Lift(n),
                    _ => Hold::Fixed,
                };
            }
            state.x.clone_from(&a.x);
            state.v.clone_from(&a.v);
            moved.copy_from_slice(&a.moved);
        };
        let lift_off = LIFT_OFF * sc.thickness();
        let held = &a.held;
        a.lifted.retain(|&(i, before)| match held[i as usize] {
            Hold::Lift(n) => n.dot(&moved[i as usize]) - before > lift_off,
            _ => false,
        });
        if !a.lifted.is_empty() {
            let lifted = &a.lifted;
            contacts.retain(|c| {
                lifted
                    .binary_search_by_key(&c.particle, |&(i, _)| i)
                    .is_err()
            });
        }
        report
    }
}
