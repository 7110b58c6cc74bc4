//! The force interface shared by every energy and dissipative term.

use crate::math::{Mat3, Real, Vec3, outer};
use crate::spec::JacobianMode;

/// Receives one element's contribution at a time.
///
/// `element` numbers the elements of one force in a fixed order (the order
/// of [`Force::for_each_element`]), so a sink can precompute where each
/// element's blocks go in a sparse matrix.
pub trait Sink {
    /// Adds element `element` acting on particles `idx`: forces `f`, and the
    /// Jacobian blocks `dfdx[a][b] = ∂f_a/∂x_b`, `dfdv[a][b] = ∂f_a/∂v_b`
    /// when the force has them.
    fn add<const N: usize>(
        &mut self,
        element: usize,
        idx: &[usize; N],
        f: &[Vec3; N],
        dfdx: Option<&[[Mat3; N]; N]>,
        dfdv: Option<&[[Mat3; N]; N]>,
    );

    /// Adds a two-particle element written in terms of `d = x_a - x_b`:
    /// `g = ∂E/∂d` (or the dissipative force's `-f_a`), and the `d`-blocks
    /// `k = ∂²E/∂d²` and `c = -∂f_a/∂v_a` ([`pair_blocks`] gives the
    /// particle blocks). A sink may override it to use the structure.
    #[inline]
    fn add_pair(
        &mut self,
        element: usize,
        idx: [usize; 2],
        g: Vec3,
        k: Option<&Mat3>,
        c: Option<&Mat3>,
    ) {
        let (f, dfdx) = pair_blocks(g, k.copied().unwrap_or_else(Mat3::zeros));
        let dfdv = c.map(|c| pair_blocks(Vec3::zeros(), *c).1);
        self.add(element, &idx, &f, k.map(|_| &dfdx), dfdv.as_ref());
    }

    /// Adds a three-particle element `[a, b, c]` written in terms of its
    /// arms `e1 = x_a - x_b`, `e2 = x_c - x_b`: `g = ∂E/∂e` and the arm
    /// blocks `h = ∂²E/∂e_i∂e_j` ([`arm_blocks`] gives the particle
    /// blocks). A sink may override it to use the structure.
    #[inline]
    fn add_arms(&mut self, element: usize, idx: [usize; 3], g: [Vec3; 2], h: &[[Mat3; 2]; 2]) {
        let (f, dfdx) = arm_blocks(g, h);
        self.add(element, &idx, &f, Some(&dfdx), None);
    }

    /// [`Sink::add_arms`] with the rank-one arm Hessian `s j jᵀ`
    /// (`j = (j1, j2)`), and a rank-one damping `c j jᵀ` on the arms'
    /// velocities (`-∂f/∂ė`; its force is already in `g`; `c = 0`: none).
    /// A sink may override it to use the structure.
    #[inline]
    fn add_arms_rank1(
        &mut self,
        element: usize,
        idx: [usize; 3],
        g: [Vec3; 2],
        s: Real,
        c: Real,
        j: [Vec3; 2],
    ) {
        if c == 0.0 {
            self.add_arms(element, idx, g, &rank1_blocks(s, j));
        } else {
            add_damped_arms(self, element, idx, g, &rank1_blocks(s, j), c, j);
        }
    }
}

/// A three-particle element in terms of its arms (as [`Sink::add_arms`]:
/// `g`, the arm blocks `h`), with a rank-one damping `c j jᵀ` on the
/// arms' velocities (`-∂f/∂ė`; its force already in `g`), through the
/// generic [`Sink::add`].
pub fn add_damped_arms<S: Sink + ?Sized>(
    sink: &mut S,
    element: usize,
    idx: [usize; 3],
    g: [Vec3; 2],
    h: &[[Mat3; 2]; 2],
    c: Real,
    j: [Vec3; 2],
) {
    let (f, dfdx) = arm_blocks(g, h);
    let dfdv = arm_blocks([Vec3::zeros(); 2], &rank1_blocks(c, j)).1;
    sink.add(element, &idx, &f, Some(&dfdx), Some(&dfdv));
}

/// A force term of the cloth (method.md §1, eq. [4]).
pub trait Force {
    /// A short name for diagnostics and tests.
    fn name(&self) -> &'static str;

    /// The potential energy at positions `x`; `None` for dissipative forces.
    fn energy(&self, x: &[Vec3]) -> Option<Real>;

    /// Visits each element's particle indices, in element order.
    fn for_each_element(&self, visit: &mut dyn FnMut(&[usize]));

    /// Number of elements.
    fn element_count(&self) -> usize;

    /// Adds element `e`'s forces and Jacobian blocks to `sink`.
    fn add_element<S: Sink>(
        &self,
        e: usize,
        x: &[Vec3],
        v: &[Vec3],
        mode: JacobianMode,
        sink: &mut S,
    );

    /// Adds every element's forces and Jacobian blocks to `sink`, in
    /// element order.
    fn accumulate<S: Sink>(&self, x: &[Vec3], v: &[Vec3], mode: JacobianMode, sink: &mut S) {
        for e in 0..self.element_count() {
            self.add_element(e, x, v, mode, sink);
        }
    }
}

/// The arm blocks `s j_a j_bᵀ` of a rank-one term.
#[inline]
pub fn rank1_blocks(s: Real, j: [Vec3; 2]) -> [[Mat3; 2]; 2] {
    let (a, b) = (j[0] * s, j[1] * s);
    [
        [outer(&a, &j[0]), outer(&a, &j[1])],
        [outer(&b, &j[0]), outer(&b, &j[1])],
    ]
}

/// Maps `-∇E` and `-∇²E` of a three-particle element written in terms of
/// its arms `e1 = x_a - x_b`, `e2 = x_c - x_b` to the particles: `b` sees
/// both arms, negated.
#[inline]
pub fn arm_blocks(g: [Vec3; 2], h: &[[Mat3; 2]; 2]) -> ([Vec3; 3], [[Mat3; 3]; 3]) {
    let [g1, g2] = g;
    let [[h11, h12], [h21, h22]] = *h;
    let (s1, s2) = (h11 + h12, h21 + h22);
    (
        [-g1, g1 + g2, -g2],
        [
            [-h11, s1, -h12],
            [h11 + h21, -(s1 + s2), h12 + h22],
            [-h21, s2, -h22],
        ],
    )
}

/// Maps `-∇E` and `-∇²E` of a two-particle element written in terms of
/// `d = x_a - x_b` to the particles: `f_a = -g`, `f_b = g`,
/// `∂f_a/∂x_a = -H`, `∂f_a/∂x_b = H`, and so on.
#[inline]
pub fn pair_blocks(g: Vec3, h: Mat3) -> ([Vec3; 2], [[Mat3; 2]; 2]) {
    ([-g, g], [[-h, h], [h, -h]])
}
