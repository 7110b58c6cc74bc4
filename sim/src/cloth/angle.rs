//! The angle kernel shared by bending (eq. [2]) and shear (eq. [3]).
//!
//! Both energies depend on the angle at a centre particle `b` between the
//! arms `e1 = a - b` and `e2 = c - b`. Everything is written in terms of
//! `f = û1 · û2` (the cosine of that angle), which is smooth wherever the
//! arms have length, so the exact gradient and Hessian follow by the chain
//! rule from `∂f/∂e` and `∂²f/∂e²` below; each law ([`super::Bend`],
//! [`super::Shear`]) supplies `E(f)` and its derivatives, plus its own
//! positive semi-definite Hessian for the solver.
//!
//! The threshold terms `C_0 |angle|` of the paper are not smooth at zero;
//! they use `|a| ≈ sqrt(a² + ε²) - ε` with ε = [`THRESHOLD_SMOOTHING`].

use super::force::{Force, Sink};
use crate::math::{Mat3, Real, Vec3, outer};
use crate::spec::JacobianMode;

/// ε of the smoothed absolute value in the threshold terms, radians.
pub const THRESHOLD_SMOOTHING: Real = 1e-2;

/// An arm's length and unit vector; `None` for a collapsed arm (its
/// length at most `√MIN_POSITIVE`, where no direction is defined).
pub type Arm = Option<(Real, Vec3)>;

/// Local geometry of one angle: arms, their unit vectors, `f` and `∂f/∂e`.
#[derive(Debug, Clone, Copy)]
pub struct AngleGeom {
    /// Arm lengths.
    pub r1: Real,
    /// Arm lengths.
    pub r2: Real,
    /// Unit arms.
    pub u: Vec3,
    /// Unit arms.
    pub w: Vec3,
    /// `û1 · û2`.
    pub f: Real,
    /// `∂f/∂e1 = (I - û1 û1ᵀ) û2 / r1`.
    pub g1: Vec3,
    /// `∂f/∂e2 = (I - û2 û2ᵀ) û1 / r2`.
    pub g2: Vec3,
    /// `|û1 × û2|`: the sine of the angle between the arms. PERF: kept,
    /// as shear's law and its damping both need it (one square root an
    /// element, not two).
    pub sin: Real,
}

impl AngleGeom {
    /// The geometry at `b` with arms to `a` and `c`; `None` if an arm has
    /// (numerically) zero length. PERF: always inlined, so the `Option`
    /// is taken apart in registers; called out of line (it was, once it
    /// held `sin`), the assembly took 13 % longer.
    #[inline(always)]
    pub fn new(a: &Vec3, b: &Vec3, c: &Vec3) -> Option<Self> {
        let (e1, e2) = (a - b, c - b);
        let (r1, r2) = (e1.norm(), e2.norm());
        if r1 <= Real::MIN_POSITIVE.sqrt() || r2 <= Real::MIN_POSITIVE.sqrt() {
            return None;
        }
        Some(Self::of_arms((r1, e1 / r1), (r2, e2 / r2)))
    }

    /// The geometry of two arms measured beforehand (`cloth::ArmTable`): bit
    /// for bit [`Self::new`]'s when they were measured as it measures them.
    #[inline(always)]
    pub fn from_arms(arm1: Arm, arm2: Arm) -> Option<Self> {
        Some(Self::of_arms(arm1?, arm2?))
    }

    #[inline(always)]
    fn of_arms((r1, u): (Real, Vec3), (r2, w): (Real, Vec3)) -> Self {
        let f = u.dot(&w).clamp(-1.0, 1.0);
        Self {
            r1,
            r2,
            u,
            w,
            f,
            g1: (w - u * f) / r1,
            g2: (u - w * f) / r2,
            sin: u.cross(&w).norm(),
        }
    }

    /// `∂²f/∂e_i ∂e_j` as `[[H11, H12], [H21, H22]]`.
    pub fn hessian_f(&self) -> [[Mat3; 2]; 2] {
        let (u, w, f) = (self.u, self.w, self.f);
        let p1 = Mat3::identity() - outer(&u, &u);
        let p2 = Mat3::identity() - outer(&w, &w);
        let h11 =
            -(outer(&u, &self.g1) + outer(&self.g1, &u)) / self.r1 - p1 * (f / (self.r1 * self.r1));
        let h22 =
            -(outer(&w, &self.g2) + outer(&self.g2, &w)) / self.r2 - p2 * (f / (self.r2 * self.r2));
        let h12 = p1 * p2 / (self.r1 * self.r2);
        [[h11, h12], [h12.transpose(), h22]]
    }
}

/// `E(q) = 1/2 c1 q + 1/2 c0 (sqrt(q + ε²) - ε)` for `q` = angle², with
/// `dE/dq` and `d²E/dq²`: the quadratic term plus the smoothed threshold.
#[inline]
pub fn energy_of_square(q: Real, c1: Real, c0: Real) -> (Real, Real, Real) {
    let eps2 = THRESHOLD_SMOOTHING * THRESHOLD_SMOOTHING;
    let s = (q + eps2).sqrt();
    (
        0.5 * c1 * q + 0.5 * c0 * (s - THRESHOLD_SMOOTHING),
        0.5 * c1 + 0.25 * c0 / s,
        -0.125 * c0 / (s * s * s),
    )
}

/// What a law returns for one element: gradient and Hessian with respect
/// to the arms `(e1, e2)`.
#[derive(Debug, Clone, Copy)]
pub struct ArmDerivatives {
    /// `∂E/∂e1`, `∂E/∂e2`.
    pub grad: [Vec3; 2],
    /// `∂²E/∂e_i∂e_j` (the exact one, or the solver's PSD one).
    pub hess: ArmHessian,
}

/// An arm Hessian: four 3x3 blocks, or a Gauss–Newton term on one scalar,
/// `s j jᵀ` with `j = (j1, j2)` its gradient along the arms, which a sink
/// can assemble without any 3x3 product.
// Returned by value and taken apart at once, per element: boxing the full
// variant would allocate per element to save a copy of a few words.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy)]
pub enum ArmHessian {
    /// `[[H11, H12], [H21, H22]]`.
    Full([[Mat3; 2]; 2]),
    /// `s j jᵀ`.
    Rank1 {
        /// The scale `s`.
        s: Real,
        /// The arm gradient `(j1, j2)`.
        j: [Vec3; 2],
    },
}

/// Rayleigh damping of one element's angle: its force on the arms and
/// the derivatives the assembly needs.
#[derive(Debug, Clone, Copy)]
pub struct ArmDamping {
    /// `-f` on the arms (the sign of an energy gradient).
    pub grad: [Vec3; 2],
    /// `-∂f/∂ė = c j jᵀ`.
    pub c: Real,
    /// The arm gradient of that rank-one term: the law's own
    /// [`ArmHessian::Rank1`] `j`, so the solver assembles both as one.
    pub j: [Vec3; 2],
    /// `-∂f/∂e` in [`JacobianMode::Exact`] (the solver omits it, as it
    /// does for the springs' damping).
    pub dgde: Option<[[Mat3; 2]; 2]>,
}

/// An energy of the angle between two arms.
pub trait AngleLaw {
    /// A short name.
    const NAME: &'static str;
    /// Energy only.
    fn energy(g: &AngleGeom, c1: Real, c0: Real) -> Real;
    /// Gradient and the Hessian requested by `mode`; only the one asked
    /// for is computed (PERF: the solver's assembly never pays for the
    /// exact Hessian). PERF: implementations are `#[inline]`, so the
    /// returned [`ArmDerivatives`] is built in place and the variant the
    /// law never returns is dropped: called out of line, each element
    /// copied the whole enum back (sphere-drape-30's assembly took 0.37 s
    /// on one thread against 0.31 s inlined).
    fn eval(g: &AngleGeom, c1: Real, c0: Real, mode: JacobianMode) -> ArmDerivatives;
    /// Damping `k` (N·m·s per radian², or N·s/m per area) of the angle's
    /// rate when the arms move at `rate`; `None` for a law without it.
    fn damping(
        _g: &AngleGeom,
        _k: Real,
        _rate: [Vec3; 2],
        _mode: JacobianMode,
    ) -> Option<ArmDamping> {
        None
    }
}

/// Chain rule through `f`: the gradient `E_f ∂f`.
#[inline]
pub fn gradient_through_f(g: &AngleGeom, e_f: Real) -> [Vec3; 2] {
    [g.g1 * e_f, g.g2 * e_f]
}

/// Chain rule through `f`: the exact Hessian `E_ff ∂f ∂fᵀ + E_f ∂²f`.
pub fn exact_hessian_through_f(g: &AngleGeom, e_f: Real, e_ff: Real) -> [[Mat3; 2]; 2] {
    let hf = g.hessian_f();
    let gs = [g.g1, g.g2];
    let mut hess = [[Mat3::zeros(); 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            hess[i][j] = outer(&gs[i], &gs[j]) * e_ff + hf[i][j] * e_f;
        }
    }
    hess
}

/// One angle element: centre particle `b`, arms to `a` and `c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AngleElement {
    /// Particles `[a, b, c]`.
    pub idx: [usize; 3],
    /// Quadratic coefficient `C_1`.
    pub c1: Real,
    /// Threshold coefficient `C_0`.
    pub c0: Real,
}

/// A set of angle elements under one law.
#[derive(Debug, Clone)]
pub struct AngleForce<L> {
    /// The elements.
    pub elements: Vec<AngleElement>,
    /// Stiffness-proportional (Rayleigh) damping β, seconds: an element
    /// of stiffness `C_1` resists its angle's rate with `β C_1` (only for
    /// laws that define [`AngleLaw::damping`]).
    pub damping: Real,
    law: std::marker::PhantomData<L>,
}

impl<L> Default for AngleForce<L> {
    fn default() -> Self {
        Self::new(Vec::new())
    }
}

impl<L> AngleForce<L> {
    /// A force over `elements`.
    pub fn new(elements: Vec<AngleElement>) -> Self {
        Self {
            elements,
            damping: 0.0,
            law: std::marker::PhantomData,
        }
    }

    /// The same elements with Rayleigh damping `beta` (seconds).
    pub fn with_damping(self, beta: Real) -> Self {
        Self {
            damping: beta,
            ..self
        }
    }
}

impl<L: AngleLaw> Force for AngleForce<L> {
    fn name(&self) -> &'static str {
        L::NAME
    }

    fn energy(&self, x: &[Vec3]) -> Option<Real> {
        Some(
            self.elements
                .iter()
                .filter_map(|el| {
                    let [a, b, c] = el.idx;
                    AngleGeom::new(&x[a], &x[b], &x[c]).map(|g| L::energy(&g, el.c1, el.c0))
                })
                .sum(),
        )
    }

    fn for_each_element(&self, visit: &mut dyn FnMut(&[usize])) {
        for el in &self.elements {
            visit(&el.idx);
        }
    }

    fn element_count(&self) -> usize {
        self.elements.len()
    }

    fn add_element<S: Sink>(
        &self,
        e: usize,
        x: &[Vec3],
        v: &[Vec3],
        mode: JacobianMode,
        sink: &mut S,
    ) {
        let [a, b, c] = self.elements[e].idx;
        if let Some(g) = AngleGeom::new(&x[a], &x[b], &x[c]) {
            self.add_element_at(e, &g, v, mode, sink);
        }
        // A collapsed arm has no angle; its springs resist it.
    }
}

impl<L: AngleLaw> AngleForce<L> {
    /// [`Force::add_element`] with the element's geometry `g` already
    /// measured (`AngleGeom::new`, or `AngleGeom::from_arms`).
    #[inline]
    pub fn add_element_at<S: Sink>(
        &self,
        e: usize,
        g: &AngleGeom,
        v: &[Vec3],
        mode: JacobianMode,
        sink: &mut S,
    ) {
        let el = &self.elements[e];
        let [a, b, c] = el.idx;
        let d = L::eval(g, el.c1, el.c0, mode);
        let damping = if self.damping > 0.0 {
            L::damping(g, self.damping * el.c1, [v[a] - v[b], v[c] - v[b]], mode)
        } else {
            None
        };
        let grad = match &damping {
            Some(dm) => [d.grad[0] + dm.grad[0], d.grad[1] + dm.grad[1]],
            None => d.grad,
        };
        match (d.hess, damping) {
            (ArmHessian::Full(h), None) => sink.add_arms(e, el.idx, grad, &h),
            (ArmHessian::Rank1 { s, j }, dm) => {
                let c = dm.map_or(0.0, |dm| {
                    debug_assert_eq!(j, dm.j, "the damping's j is the law's");
                    dm.c
                });
                sink.add_arms_rank1(e, el.idx, grad, s, c, j);
            }
            (ArmHessian::Full(mut h), Some(dm)) => {
                // The exact path (tests): the damping's `∂f/∂x` joins the
                // stiffness blocks.
                for (row, drow) in h.iter_mut().zip(dm.dgde.unwrap_or_default()) {
                    for (block, dblock) in row.iter_mut().zip(drow) {
                        *block += dblock;
                    }
                }
                super::force::add_damped_arms(sink, e, el.idx, grad, &h, dm.c, dm.j);
            }
        }
    }
}
