//! The scales of the error stopping rule (`solver.stopping: "error"`,
//! ARCHITECTURE.md "When CG stops"): the share of a step's local error
//! each solve may leave, and the least error it is measured against under
//! backward Euler.

use super::constraints::Filter;
use super::scheme::Scheme;
use crate::math::{Real, Vec3};
#[cfg(doc)]
use crate::spec::StoppingRule;

/// The share of a step's own local time error the linear solver may add
/// under [`StoppingRule::Error`]: a tenth, so the solver's error stays
/// invisible next to the integrator's (docs/benchmarks.md, section 1:
/// tolerances past that point buy nothing).
pub const SOLVER_SHARE: Real = 0.1;

/// Under [`StoppingRule::Error`], BDF2's first solve only predicts the
/// point its Newton correction (`Integrator::correct`) linearises about:
/// it may leave ten times the step's local error. Measured on
/// hanging-corners at 1/120 s: 2,653 CG iterations and 2.06 % error (RMS
/// of the diagonal over 1.5 s), against 3,458 and 2.16 % with a share of 1.
pub const PREDICTOR_SHARE: Real = 10.0;

/// Under [`StoppingRule::Error`], the share of the local error BDF2's
/// corrected solve may leave. Measured on hanging-corners at 1/120 s
/// (error RMS of the diagonal over 1.5 s against BDF2 at 1/1920 s, CG
/// iterations; docs/benchmarks.md, sections 1d and 1o): a share of 0.3
/// gives 2.96 % for 2,341, 0.1 gave 2.59 % for 2,930 (a tight solve:
/// 2.28 %), but the stress suite's crumpled cloth over a sphere, run
/// under BDF2, then stretched 11.8 % (0.2: 11.0 %, 0.15: 14.5 %) where
/// 0.3 keeps it at 8.6 %, inside the suite's 10 %. On the swinging cloth
/// of `sim/tests/stopping.rs` 0.3 leaves a sixth of BDF2's time error.
/// (The whip of the free edge makes hanging-corners' error jump by
/// tenths of a percent with any perturbation.)
pub const CORRECTION_SHARE: Real = 0.3;

/// The least step error [`StoppingRule::Error`] measures a backward Euler
/// solve against: a quarter of how far the cloth moves in the step, `h`
/// times the RMS speed `v` of its free particles, with that speed taken
/// no larger than what gravity gives in one step, `h |g|`.
///
/// Euler's local error is `h dv / 2` (`solver::local_error`): it is
/// small wherever the velocity changes slowly, though the cloth still
/// moves, and the rule measured against it alone asked ever more digits
/// of a drape creeping at a centimetre a second (sphere-drape-30's last
/// second took 2,403 CG iterations against its first second's 1,803).
/// With the floor the solver may leave 2.5 % of a step's motion, and at
/// most 2.5 % of a one-step fall from rest (`h² |g|`, 4.3 µm at 1/240 s):
/// invisible, and it fades with the motion, so a cloth at rest is still
/// solved to rest. Measured (docs/benchmarks.md, section 1y): a floor
/// of free fall's local error alone left a resting cantilever stirring
/// at 10⁻¹⁰ J and the settled drape making three contacts a frame, and
/// twice the cap raised the stress suite's tight twist from 2.63 % to
/// 3.70 % stretch. BDF2 is exact in free fall and keeps the rule as it
/// was.
/// `v` are the velocities at the step's start, `filter` the step's
/// filters (the free particles are those the local error is taken over).
pub fn error_floor(scheme: &Scheme<'_>, gravity: Vec3, v: &[Vec3], filter: &[Filter]) -> Real {
    if scheme.is_two_step() {
        return 0.0;
    }
    let speed = rms_free(v, filter);
    MOTION_SHARE * scheme.h * speed.min(scheme.h * gravity.norm())
}

/// The share of a step's motion [`error_floor`] takes as its floor.
const MOTION_SHARE: Real = 0.25;

/// The RMS of `v` over the free particles (0 if none is free).
fn rms_free(v: &[Vec3], filter: &[Filter]) -> Real {
    let free = |f: &Filter| *f == Filter::Free;
    let count = filter.iter().filter(|f| free(f)).count();
    if count == 0 {
        return 0.0;
    }
    let sum = crate::parallel::sum(v.len(), |r| {
        v[r.clone()]
            .iter()
            .zip(&filter[r])
            .filter(|(_, f)| free(f))
            .map(|(v, _)| v.norm_squared())
            .sum()
    });
    (sum / count as Real).sqrt()
}
