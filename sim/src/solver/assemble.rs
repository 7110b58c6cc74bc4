//! Assembly of the linear system of one implicit Euler step with position
//! corrections, method.md §2 eq. [20]:
//!
//! ```text
//! A = M - h D - h² K,      b = h (f0 + K (h v0 + y))
//! ```
//!
//! with `K = ∂f/∂x`, `D = ∂f/∂v` in their solver (symmetric, `-K` and `-D`
//! PSD) forms. The pattern and, for every element of every force, the slots
//! its blocks go to are computed once in [`System::new`]; assembly is then
//! a pass over elements with indexed adds and no allocation.

use super::bsr::BlockCsr;
use crate::cloth::{Force, ForceModel, Sink};
use crate::math::{Mat3, Real, Vec3};
use crate::spec::JacobianMode;

/// The system matrix, right-hand side, and the element-to-slot tables.
#[derive(Debug, Clone)]
pub struct System {
    /// `A`.
    pub a: BlockCsr,
    /// `b`.
    pub b: Vec<Vec3>,
    /// Per force term, per element, the `N x N` slots of its blocks.
    slots: [Vec<u32>; TERMS],
}

const TERMS: usize = 5;

/// Inputs of one assembly.
#[derive(Debug, Clone, Copy)]
pub struct AssemblyInput<'a> {
    /// Positions at the start of the step.
    pub x: &'a [Vec3],
    /// Velocities at the start of the step.
    pub v: &'a [Vec3],
    /// Position corrections `y`.
    pub y: &'a [Vec3],
    /// Lumped masses.
    pub mass: &'a [Real],
    /// Gravitational acceleration.
    pub gravity: Vec3,
    /// Step size.
    pub h: Real,
}

fn slot_table<F: Force>(force: &F, a: &BlockCsr) -> Vec<u32> {
    let mut out = Vec::new();
    force.for_each_element(&mut |idx| {
        for &p in idx {
            for &q in idx {
                // The pattern was built from these very pairs.
                let slot = a.slot(p, q).unwrap_or(usize::MAX);
                out.push(slot as u32);
            }
        }
    });
    out
}

fn couplings<F: Force>(force: &F, pairs: &mut Vec<(usize, usize)>) {
    force.for_each_element(&mut |idx| {
        for (k, &p) in idx.iter().enumerate() {
            for &q in &idx[k + 1..] {
                pairs.push((p, q));
            }
        }
    });
}

impl System {
    /// The pattern and slot tables for `model` on `n` particles.
    pub fn new(n: usize, model: &ForceModel) -> Self {
        let mut pairs = Vec::new();
        couplings(&model.stretch, &mut pairs);
        couplings(&model.damping, &mut pairs);
        couplings(&model.bend, &mut pairs);
        couplings(&model.shear, &mut pairs);
        let a = BlockCsr::with_pattern(n, pairs);
        let slots = [
            slot_table(&model.stretch, &a),
            slot_table(&model.damping, &a),
            slot_table(&model.bend, &a),
            slot_table(&model.shear, &a),
            slot_table(&model.drag, &a),
        ];
        Self {
            a,
            b: vec![Vec3::zeros(); n],
            slots,
        }
    }

    /// Writes `A` and `b` for one step (eq. [20]).
    pub fn assemble(&mut self, model: &ForceModel, input: &AssemblyInput<'_>) {
        let h = input.h;
        self.a.clear_values();
        for (i, (bi, &m)) in self.b.iter_mut().zip(input.mass).enumerate() {
            *bi = input.gravity * (h * m);
            let d = self.a.diag_slot(i);
            self.a.values[d] = Mat3::identity() * m;
        }
        // w = h v0 + y: the displacement K multiplies in b.
        let mut sink = AssemblySink {
            values: &mut self.a.values,
            b: &mut self.b,
            v: input.v,
            y: input.y,
            h,
            slots: &[],
        };
        let mode = JacobianMode::Solver;
        sink.slots = &self.slots[0];
        model.stretch.accumulate(input.x, input.v, mode, &mut sink);
        sink.slots = &self.slots[1];
        model.damping.accumulate(input.x, input.v, mode, &mut sink);
        sink.slots = &self.slots[2];
        model.bend.accumulate(input.x, input.v, mode, &mut sink);
        sink.slots = &self.slots[3];
        model.shear.accumulate(input.x, input.v, mode, &mut sink);
        sink.slots = &self.slots[4];
        model.drag.accumulate(input.x, input.v, mode, &mut sink);
    }
}

/// Writes element blocks into `A` and `b` through precomputed slots.
struct AssemblySink<'a> {
    values: &'a mut [Mat3],
    b: &'a mut [Vec3],
    v: &'a [Vec3],
    y: &'a [Vec3],
    h: Real,
    slots: &'a [u32],
}

impl Sink for AssemblySink<'_> {
    #[inline]
    fn add<const N: usize>(
        &mut self,
        element: usize,
        idx: &[usize; N],
        f: &[Vec3; N],
        dfdx: Option<&[[Mat3; N]; N]>,
        dfdv: Option<&[[Mat3; N]; N]>,
    ) {
        let h = self.h;
        let slots = &self.slots[element * N * N..(element + 1) * N * N];
        for a in 0..N {
            let mut rhs = f[a];
            for q in 0..N {
                let slot = slots[a * N + q] as usize;
                if let Some(k) = dfdx {
                    let k = &k[a][q];
                    self.values[slot] -= k * (h * h);
                    rhs += k * (self.v[idx[q]] * h + self.y[idx[q]]);
                }
                if let Some(d) = dfdv {
                    self.values[slot] -= d[a][q] * h;
                }
            }
            self.b[idx[a]] += rhs * h;
        }
    }
}
