//! A redone solve's right-hand side patched, not assembled again.
//!
//! A step is redone (`sim::step`) from its own start with more contacts.
//! Its positions, velocities and (under backward Euler) couplings are the
//! first solve's, so `A` is the same matrix bit for bit; only the
//! contacts' position corrections `y` and friction impulses `J` change,
//! and with them
//!
//! ```text
//! b = h' (f0 + K w) + γ J,   w = h' v0 + p + y       (eq. [20])
//! ```
//!
//! by `h' K Δw + γ ΔJ`. `Δw` is zero but at the particles whose contact
//! changed, so [`RedoPatch`] evaluates the stiffness of only the elements
//! holding one of them (and of the couplings), and adds their `h' K Δw`
//! to `b`. The sums run in another order than the assembly's, so `b`
//! agrees with a second assembly to round-off, not bit for bit.

use std::ops::Range;

use super::assemble::{AssemblyInput, System, displacement};
use super::coupling::Coupling;
use crate::cloth::{Force, ForceModel, Sink};
use crate::math::{Mat3, Real, Vec3};
use crate::spec::JacobianMode;

/// Largest share of the particles whose `w` may change for a patch: past
/// it the patch evaluates most elements anyway, and the caller assembles.
const MOST: usize = 8;

/// Each particle's elements of one force, as compressed rows.
#[derive(Debug, Clone, Default)]
struct Incidence {
    start: Vec<u32>,
    elements: Vec<u32>,
}

impl Incidence {
    fn new<F: Force>(force: &F, n: usize) -> Self {
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        let mut e = 0;
        force.for_each_element(&mut |idx| {
            pairs.extend(idx.iter().map(|&p| (p as u32, e)));
            e += 1;
        });
        pairs.sort_unstable();
        let mut start = vec![0u32; n + 1];
        for &(p, _) in &pairs {
            start[p as usize + 1] += 1;
        }
        for k in 0..n {
            start[k + 1] += start[k];
        }
        let elements = pairs.into_iter().map(|(_, e)| e).collect();
        Self { start, elements }
    }

    fn of(&self, p: u32) -> &[u32] {
        let Range { start, end } =
            self.start[p as usize] as usize..self.start[p as usize + 1] as usize;
        &self.elements[start..end]
    }
}

/// The patch's tables and scratch.
#[derive(Debug, Clone, Default)]
pub struct RedoPatch {
    /// Per force term (stretch, damping, bend, shear, drag).
    incidence: [Incidence; 5],
    /// The particles whose `w` changed, and their `Δw` (zero elsewhere).
    changed: Vec<u32>,
    dw: Vec<Vec3>,
    /// One term's elements holding a changed particle.
    picked: Vec<u32>,
}

impl RedoPatch {
    /// The tables of `model` on `n` particles.
    pub fn new(n: usize, model: &ForceModel) -> Self {
        Self {
            incidence: [
                Incidence::new(&model.stretch, n),
                Incidence::new(&model.damping, n),
                Incidence::new(&model.bend, n),
                Incidence::new(&model.shear, n),
                Incidence::new(&model.drag, n),
            ],
            dw: vec![Vec3::zeros(); n],
            ..Self::default()
        }
    }

    /// `system`'s `b`, assembled with the same `x`, `v`, scheme and
    /// `couplings` but the impulses `old_impulse`, moved to `input`'s
    /// corrections and `impulse` (module doc); `w` follows. `false`, and
    /// nothing changed, when more than a [`MOST`]th of the particles moved.
    pub fn apply(
        &mut self,
        model: &ForceModel,
        system: &mut System,
        input: &AssemblyInput<'_>,
        (old_impulse, impulse): (&[Vec3], &[Vec3]),
        couplings: &[Coupling],
    ) -> bool {
        self.changed.clear();
        for (i, w) in system.w.iter().enumerate() {
            if displacement(input, i) != *w {
                self.changed.push(i as u32);
            }
        }
        if self.changed.len() * MOST > system.w.len() {
            return false;
        }
        for &i in &self.changed {
            let i = i as usize;
            let w = displacement(input, i);
            self.dw[i] = w - system.w[i];
            system.w[i] = w;
        }
        let h = input.scheme.h_eff();
        let mut sink = DeltaSink {
            dw: &self.dw,
            b: &mut system.b,
            h,
        };
        let (x, v) = (input.x, input.v);
        let (changed, picked) = (&self.changed, &mut self.picked);
        let [stretch, damping, bend, shear, drag] = &self.incidence;
        add_term(&model.stretch, stretch, changed, picked, (x, v), &mut sink);
        add_term(&model.damping, damping, changed, picked, (x, v), &mut sink);
        add_term(&model.bend, bend, changed, picked, (x, v), &mut sink);
        add_term(&model.shear, shear, changed, picked, (x, v), &mut sink);
        add_term(&model.drag, drag, changed, picked, (x, v), &mut sink);
        add_couplings(couplings, x, &self.dw, h, &mut system.b);
        let gamma = input.scheme.gamma;
        for ((b, j), j0) in system.b.iter_mut().zip(impulse).zip(old_impulse) {
            if j != j0 {
                *b += (j - j0) * gamma;
            }
        }
        for &i in &self.changed {
            self.dw[i as usize] = Vec3::zeros();
        }
        true
    }
}

/// `h' K Δw` of the elements of `force` holding a particle of `changed`,
/// each once, into the sink's `b`.
fn add_term<F: Force>(
    force: &F,
    incidence: &Incidence,
    changed: &[u32],
    picked: &mut Vec<u32>,
    (x, v): (&[Vec3], &[Vec3]),
    sink: &mut DeltaSink<'_>,
) {
    picked.clear();
    for &p in changed {
        picked.extend_from_slice(incidence.of(p));
    }
    picked.sort_unstable();
    picked.dedup();
    for &e in picked.iter() {
        force.add_element(e as usize, x, v, JacobianMode::Solver, sink);
    }
}

/// The couplings' share of `h' K Δw`: a coupling whose cloth is short of
/// its target where the system is linearised adds `h' s c_k (short - n ·
/// Σ c_l w_l) n` to `b_k` (`coupling::add`), which `Δw` changes by
/// `-h' s c_k (n · Σ c_l Δw_l) n`.
fn add_couplings(couplings: &[Coupling], x: &[Vec3], dw: &[Vec3], h: Real, b: &mut [Vec3]) {
    for c in couplings {
        let along = c.normal.dot(&c.point(dw));
        if along == 0.0 || c.target - c.normal.dot(&c.point(x)) <= 0.0 {
            continue;
        }
        for k in c.live() {
            b[c.particles[k] as usize] -= c.normal * (h * c.stiffness * c.weights[k] * along);
        }
    }
}

/// Takes elements' stiffness blocks `K = ∂f/∂x` and adds `h' K Δw` to
/// `b`; forces, damping and `A` are left alone.
struct DeltaSink<'a> {
    dw: &'a [Vec3],
    b: &'a mut [Vec3],
    h: Real,
}

impl Sink for DeltaSink<'_> {
    fn add<const N: usize>(
        &mut self,
        _element: usize,
        idx: &[usize; N],
        _f: &[Vec3; N],
        dfdx: Option<&[[Mat3; N]; N]>,
        _dfdv: Option<&[[Mat3; N]; N]>,
    ) {
        let Some(k) = dfdx else { return };
        for (a, row) in k.iter().enumerate() {
            let kw: Vec3 = row
                .iter()
                .zip(idx)
                .map(|(block, &q)| block * self.dw[q])
                .sum();
            self.b[idx[a]] += kw * self.h;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::fdcheck::random_configuration;
    use crate::solver::Scheme;

    fn euler_input<'a>(
        x: &'a [Vec3],
        v: &'a [Vec3],
        y: &'a [Vec3],
        mass: &'a [Real],
        h: Real,
    ) -> AssemblyInput<'a> {
        AssemblyInput {
            x,
            predicted: false,
            v,
            y,
            mass,
            gravity: Vec3::new(0.0, 0.0, -9.81),
            scheme: Scheme::euler(h),
        }
    }

    /// On a crumpled cloth with couplings, a patch from one set of
    /// corrections and impulses to another gives the `b` (and `w`) a
    /// second assembly gives, to round-off, and leaves `A` as it was; a
    /// change at too many particles is left to the assembly.
    #[test]
    fn a_patched_b_is_the_one_assembled_again() {
        let (grid, x, v) = random_configuration(19, 17, 0.3, 5);
        let n = grid.len();
        let h = 1.0 / 240.0;
        let model = ForceModel::new(&grid, &crate::spec::preset("cotton").expect("preset"));
        let couplings: Vec<Coupling> = (0..40)
            .map(|k| Coupling {
                particles: [k, k + 60, k + 120, k + 180].map(|p| p as u32),
                weights: [1.0, -0.2, -0.5, -0.3],
                normal: Vec3::new(0.3, -0.4, 0.866).normalize(),
                target: 10.0,
                stiffness: 1e4,
            })
            .collect();
        let y0: Vec<Vec3> = (0..n).map(|i| x[(i * 7) % n] * 1e-3).collect();
        let j0: Vec<Vec3> = (0..n).map(|i| v[(i * 3) % n] * 1e-4).collect();
        // New corrections and impulses at every 11th particle.
        let (mut y1, mut j1) = (y0.clone(), j0.clone());
        for i in (0..n).step_by(11) {
            y1[i] += Vec3::new(1e-3, -2e-3, 3e-3);
            j1[i] = Vec3::new(0.0, 1e-3, 2e-3);
        }
        let assembled = |y: &[Vec3], j: &[Vec3]| {
            let mut sys = System::new(n, &model);
            sys.assemble(&model, &euler_input(&x, &v, y, &grid.mass, h));
            for (b, j) in sys.b.iter_mut().zip(j) {
                *b += j;
            }
            let w = sys.w.clone();
            let (mut remote, mut boost) = (Vec::new(), Vec::new());
            let pieces = (&mut remote, &mut boost);
            super::super::coupling::add(&couplings, &x, &w, h, &mut sys.a, &mut sys.b, pieces);
            sys
        };
        let want = assembled(&y1, &j1);
        let mut sys = assembled(&y0, &j0);
        let a = sys.a.values.clone();
        let mut patch = RedoPatch::new(n, &model);
        assert!(patch.apply(
            &model,
            &mut sys,
            &euler_input(&x, &v, &y1, &grid.mass, h),
            (&j0, &j1),
            &couplings
        ));
        assert_eq!(sys.a.values, a, "A untouched");
        assert_eq!(sys.w, want.w);
        let scale = want.b.iter().map(|b| b.amax()).fold(0.0, Real::max);
        for (i, (got, b)) in sys.b.iter().zip(&want.b).enumerate() {
            assert!(
                (got - b).amax() <= 1e-12 * scale,
                "b[{i}]: {got} against {b}"
            );
        }
        // The patch moved `b` by far more than round-off.
        let before = assembled(&y0, &j0);
        let change = sys
            .b
            .iter()
            .zip(&before.b)
            .map(|(p, q)| (p - q).amax())
            .fold(0.0, Real::max);
        assert!(change > 1e-6 * scale, "change {change:e} of {scale:e}");
        // Corrections changed at every other particle: assemble instead.
        let y2: Vec<Vec3> = (0..n)
            .map(|i| y1[i] * if i % 2 == 0 { 2.0 } else { 1.0 })
            .collect();
        let b = sys.b.clone();
        assert!(!patch.apply(
            &model,
            &mut sys,
            &euler_input(&x, &v, &y2, &grid.mass, h),
            (&j1, &j1),
            &couplings
        ));
        assert_eq!(sys.b, b, "b untouched");
    }
}
