//! Assembly of the linear system of one step with position corrections,
//! method.md §2 eq. [20], in the variables of the step's scheme
//! (`solver::Scheme`: `h' = γ h`, the carried motion `p` and velocity
//! change `q`; backward Euler has `h' = h`, `p = q = 0`):
//!
//! ```text
//! A = M - h' D - h'² K,      b = M q + h' (f0 + K (h' v0 + p + y))
//! ```
//!
//! with `K = ∂f/∂x`, `D = ∂f/∂v` in their solver (symmetric, `-K` and `-D`
//! PSD) forms. The pattern and, for every element of every force, the slots
//! its blocks go to are computed once in [`System::new`]; assembly is then
//! a pass over elements with indexed adds and no allocation.
//!
//! PERF: rows are split into one band per thread, and each band's task
//! evaluates every element that touches its rows and writes only its own
//! rows (an element on a band's edge is evaluated by both). Each row then
//! receives its contributions in the one global order ([`TILE`]: tile by
//! tile, term by term, element by element) whatever the number of bands,
//! so `A` and `b` are bit for bit those of a serial pass.

use std::ops::Range;

use super::bsr::BlockCsr;
use super::scheme::Scheme;
use super::sink::AssemblySink;
use crate::cloth::{AngleForce, AngleGeom, AngleLaw, ArmRef, ArmTable, Force, ForceModel};
use crate::math::{Mat3, Real, Vec3};
use crate::spec::JacobianMode;

/// The system matrix, right-hand side, and the element-to-slot tables.
#[derive(Debug, Clone)]
pub struct System {
    /// `A`.
    pub a: BlockCsr,
    /// `b`.
    pub b: Vec<Vec3>,
    /// The displacement `K` multiplies in `b` (`h' v0 + p + y`, or `y`
    /// after a prediction), per particle: computed once per assembly
    /// rather than once per element it is in.
    pub(super) w: Vec<Vec3>,
    /// Per force term, per element, the `N x N` slots of its blocks.
    slots: [Vec<u32>; TERMS],
    /// The bands of rows assembled in parallel.
    bands: Vec<Band>,
    /// The damping is on the stretch springs, one for one: each spring
    /// and its damping are added as one pair (the damping term is empty).
    springs_damped: bool,
    /// The bend and shear elements' arms, measured once per assembly...
    arms: ArmTable,
    /// ...and each element's two, for bend and shear.
    arm_refs: [Vec<[ArmRef; 2]>; 2],
}

const TERMS: usize = 5;

/// The force terms, in the order of the slot tables and of each tile's runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Term {
    Stretch,
    Damping,
    Bend,
    Shear,
    Drag,
}

impl Term {
    const ALL: [Term; TERMS] = [
        Term::Stretch,
        Term::Damping,
        Term::Bend,
        Term::Shear,
        Term::Drag,
    ];
}

/// Fewest rows worth a band of their own: a particle's elements cost about
/// a microsecond, so a few hundred rows outweigh handing the band to
/// another thread.
const BAND_MIN: usize = 256;

/// Particles per tile of the assembly's order: an element belongs to the
/// tile of its lowest particle, and the elements are added tile by tile,
/// every term's within a tile before the next tile's. The blocks a tile
/// writes (its rows and the two grid lines after them, where a hinge
/// across the lines ends) then stay in the core's cache, where one term's
/// pass over the whole matrix after another's streamed it through memory
/// each time, and the weft hinges, numbered line by line, crossed the
/// matrix at every element.
const TILE: usize = 128;

/// Rows assembled by one task, and the elements touching them in the
/// assembly's order: runs of one term's elements, tile by tile.
#[derive(Debug, Clone)]
struct Band {
    rows: Range<usize>,
    /// The positions of its rows' blocks in `A.values`.
    slots: Range<usize>,
    /// Each row's diagonal slot.
    diag: Vec<usize>,
    /// The elements, each run's contiguous.
    elements: Vec<u32>,
    /// Each run's term and its range of `elements`.
    runs: Vec<(Term, Range<usize>)>,
}

/// Inputs of one assembly.
#[derive(Debug, Clone, Copy)]
pub struct AssemblyInput<'a> {
    /// Where the forces are linearised: the positions at the start of the
    /// step, or (with `predicted`) the scheme's prediction of its end.
    pub x: &'a [Vec3],
    /// `x` is the prediction `x0 + p + h' v0` (BDF2): the displacement to
    /// the step's end is then `h' dv + y` alone.
    pub predicted: bool,
    /// Velocities at the start of the step.
    pub v: &'a [Vec3],
    /// Position corrections `y`.
    pub y: &'a [Vec3],
    /// Lumped masses.
    pub mass: &'a [Real],
    /// Gravitational acceleration.
    pub gravity: Vec3,
    /// The step's scheme.
    pub scheme: Scheme<'a>,
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

/// The elements of `force` with a particle in `rows`, each with its tile,
/// in element order.
fn touching<F: Force>(force: &F, rows: &Range<usize>) -> Vec<(usize, u32)> {
    let mut out = Vec::new();
    let mut e = 0u32;
    force.for_each_element(&mut |idx| {
        if idx.iter().any(|p| rows.contains(p)) {
            let lowest = idx.iter().copied().min().unwrap_or(0);
            out.push((lowest / TILE, e));
        }
        e += 1;
    });
    out
}

/// The elements of `model` touching `rows` in the assembly's order (tile,
/// then term, then element), as [`Band::elements`] and [`Band::runs`]:
/// one order for every band, so each row receives its contributions in
/// the same sequence whatever the bands.
fn band_order(
    model: &ForceModel,
    rows: &Range<usize>,
    springs_damped: bool,
) -> (Vec<u32>, Vec<(Term, Range<usize>)>) {
    let mut order: Vec<(usize, Term, u32)> = Vec::new();
    for term in Term::ALL {
        let elements = match term {
            Term::Stretch => touching(&model.stretch, rows),
            Term::Damping if springs_damped => Vec::new(),
            Term::Damping => touching(&model.damping, rows),
            Term::Bend => touching(&model.bend, rows),
            Term::Shear => touching(&model.shear, rows),
            Term::Drag => touching(&model.drag, rows),
        };
        order.extend(elements.into_iter().map(|(tile, e)| (tile, term, e)));
    }
    // Stable: within a tile, the terms in order, each in element order.
    order.sort_by_key(|&(tile, term, _)| (tile, term as usize));
    let mut runs: Vec<(Term, Range<usize>)> = Vec::new();
    let mut last_tile = usize::MAX;
    for (k, &(tile, term, _)) in order.iter().enumerate() {
        match runs.last_mut() {
            Some((t, run)) if *t == term && last_tile == tile => run.end = k + 1,
            _ => runs.push((term, k..k + 1)),
        }
        last_tile = tile;
    }
    (order.into_iter().map(|(_, _, e)| e).collect(), runs)
}

impl System {
    /// The pattern and slot tables for `model` on `n` particles, with one
    /// band of rows per thread of the current pool.
    pub fn new(n: usize, model: &ForceModel) -> Self {
        let mut pairs = Vec::new();
        couplings(&model.stretch, &mut pairs);
        couplings(&model.damping, &mut pairs);
        couplings(&model.bend, &mut pairs);
        couplings(&model.shear, &mut pairs);
        let a = BlockCsr::with_pattern(n, pairs);
        // PERF: a spring and its damping share their length, direction and
        // four blocks: one pass over the springs, not two (sphere-drape-30,
        // one thread, 3 pairs: assembly 0.35–0.40 → 0.31–0.35 s). The
        // damping term then has no slots and no elements of its own.
        let springs_damped = model.damping.damps(&model.stretch);
        let slots = [
            slot_table(&model.stretch, &a),
            if springs_damped {
                Vec::new()
            } else {
                slot_table(&model.damping, &a)
            },
            slot_table(&model.bend, &a),
            slot_table(&model.shear, &a),
            slot_table(&model.drag, &a),
        ];
        let (arms, arm_refs) = ArmTable::new([&model.bend.elements, &model.shear.elements]);
        let count = crate::parallel::threads().min(n / BAND_MIN).max(1);
        let bands = (0..count)
            .map(|k| {
                let rows = k * n / count..(k + 1) * n / count;
                let (elements, runs) = band_order(model, &rows, springs_damped);
                Band {
                    slots: a.slots_of_rows(rows.clone()),
                    diag: rows.clone().map(|r| a.diag_slot(r)).collect(),
                    elements,
                    runs,
                    rows,
                }
            })
            .collect();
        Self {
            a,
            b: vec![Vec3::zeros(); n],
            w: vec![Vec3::zeros(); n],
            slots,
            bands,
            springs_damped,
            arms,
            arm_refs,
        }
    }

    /// Writes `A` and `b` for one step (eq. [20]).
    pub fn assemble(&mut self, model: &ForceModel, input: &AssemblyInput<'_>) {
        for (i, w) in self.w.iter_mut().enumerate() {
            *w = displacement(input, i);
        }
        let w = &self.w[..];
        // PERF: each arm measured once, not by each of the up to six
        // elements it belongs to (sphere-drape-30, one thread: the
        // assembly 0.287–0.294 → 0.255–0.261 s; docs/benchmarks.md 1ag).
        self.arms.measure(input.x);
        let tables = Tables {
            slots: &self.slots,
            springs_damped: self.springs_damped,
            arms: &self.arms,
            arm_refs: &self.arm_refs,
        };
        // Each band's rows, their slots and their part of `b`.
        let mut work = Vec::with_capacity(self.bands.len());
        let (mut values, mut b) = (&mut self.a.values[..], &mut self.b[..]);
        for band in &self.bands {
            let (vals, rest_v) = values.split_at_mut(band.slots.len());
            let (bs, rest_b) = b.split_at_mut(band.rows.len());
            work.push((band, vals, bs));
            (values, b) = (rest_v, rest_b);
        }
        crate::parallel::each(
            work,
            |(band, values, b): (&Band, &mut [Mat3], &mut [Vec3])| {
                assemble_band(model, input, w, &tables, band, values, b);
            },
        );
    }
}

/// The displacement `K` multiplies in `b` at particle `i` ([`System::w`]).
#[inline]
pub(super) fn displacement(input: &AssemblyInput<'_>, i: usize) -> Vec3 {
    if input.predicted {
        input.y[i]
    } else {
        input.v[i] * input.scheme.h_eff() + input.scheme.carry(i) + input.y[i]
    }
}

/// What every band reads besides the model and the input.
struct Tables<'a> {
    slots: &'a [Vec<u32>; TERMS],
    springs_damped: bool,
    arms: &'a ArmTable,
    arm_refs: &'a [Vec<[ArmRef; 2]>; 2],
}

/// One band: mass and gravity on its rows, then every force's elements
/// touching it, in element order.
fn assemble_band(
    model: &ForceModel,
    input: &AssemblyInput<'_>,
    w: &[Vec3],
    tables: &Tables<'_>,
    band: &Band,
    values: &mut [Mat3],
    b: &mut [Vec3],
) {
    let scheme = &input.scheme;
    let h = scheme.h_eff();
    let base = band.slots.start;
    values.fill(Mat3::zeros());
    for (k, row) in band.rows.clone().enumerate() {
        let m = input.mass[row];
        b[k] = (input.gravity * h + scheme.velocity_carry(row)) * m;
        values[band.diag[k] - base] = Mat3::identity() * m;
    }
    let mut sink = AssemblySink {
        values,
        b,
        rows: band.rows.clone(),
        base,
        w,
        h,
        slots: &[],
    };
    let (x, v) = (input.x, input.v);
    let (arms, arm_refs) = (tables.arms, tables.arm_refs);
    for (term, run) in &band.runs {
        sink.slots = &tables.slots[*term as usize];
        let elements = &band.elements[run.clone()];
        match term {
            Term::Stretch if tables.springs_damped => {
                for &e in elements {
                    model
                        .damping
                        .add_with_stretch(&model.stretch, e as usize, x, v, &mut sink);
                }
            }
            Term::Stretch => add_term(&model.stretch, elements, x, v, &mut sink),
            Term::Damping => add_term(&model.damping, elements, x, v, &mut sink),
            Term::Bend => add_angles(&model.bend, elements, (arms, &arm_refs[0]), v, &mut sink),
            Term::Shear => add_angles(&model.shear, elements, (arms, &arm_refs[1]), v, &mut sink),
            Term::Drag => add_term(&model.drag, elements, x, v, &mut sink),
        }
    }
}

/// Adds `elements` of `force`, in order.
fn add_term<F: Force>(
    force: &F,
    elements: &[u32],
    x: &[Vec3],
    v: &[Vec3],
    sink: &mut AssemblySink<'_>,
) {
    for &e in elements {
        force.add_element(e as usize, x, v, JacobianMode::Solver, sink);
    }
}

/// Adds `elements` of an angle force, in order, each from its arms as
/// `arms` measured them.
fn add_angles<L: AngleLaw>(
    force: &AngleForce<L>,
    elements: &[u32],
    (arms, refs): (&ArmTable, &[[ArmRef; 2]]),
    v: &[Vec3],
    sink: &mut AssemblySink<'_>,
) {
    for &e in elements {
        let [r1, r2] = refs[e as usize];
        // A collapsed arm has no angle; its springs resist it.
        if let Some(g) = AngleGeom::from_arms(arms.get(r1), arms.get(r2)) {
            force.add_element_at(e as usize, &g, v, JacobianMode::Solver, sink);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cloth::fdcheck::{DenseSink, random_configuration};

    /// The assembly's fast paths (the pair and arm sinks, the bands) give
    /// eq. [20]'s `A = M - h² K - h D` and `b = h (m g + f + K (h v + y))`
    /// as the plain element sums do, to round-off, on a crumpled cloth.
    #[test]
    fn assembly_matches_the_plain_element_sums() {
        // 552 particles: two bands of rows on a two-thread pool.
        let (grid, x, v) = random_configuration(24, 23, 0.3, 11);
        let n = grid.len();
        let h = 1.0 / 60.0;
        let gravity = Vec3::new(0.0, 0.0, -9.81);
        let y: Vec<Vec3> = (0..n).map(|i| x[(i * 7) % n] * 1e-3).collect();
        let (model, sys) = crate::testing::cotton_system(&grid, &x, &v, &y, h);
        // The generic `Sink::add` of every element, into dense blocks.
        let mut dense = DenseSink::new(n);
        let mode = JacobianMode::Solver;
        model.stretch.accumulate(&x, &v, mode, &mut dense);
        model.damping.accumulate(&x, &v, mode, &mut dense);
        model.bend.accumulate(&x, &v, mode, &mut dense);
        model.shear.accumulate(&x, &v, mode, &mut dense);
        model.drag.accumulate(&x, &v, mode, &mut dense);
        let scale = sys.a.values.iter().map(|m| m.amax()).fold(0.0, Real::max);
        for i in 0..n {
            let mut found = 0;
            for (j, block) in sys.a.row(i) {
                let mass = if i == j { grid.mass[i] } else { 0.0 };
                let want =
                    Mat3::identity() * mass - dense.dfdx[i][j] * (h * h) - dense.dfdv[i][j] * h;
                assert!((block - want).amax() <= 1e-13 * scale, "A[{i}][{j}]");
                found += 1;
            }
            // No coupling outside the pattern.
            let coupled = (0..n).filter(|&j| {
                i == j || dense.dfdx[i][j] != Mat3::zeros() || dense.dfdv[i][j] != Mat3::zeros()
            });
            assert_eq!(found, coupled.count(), "row {i}");
            let kw: Vec3 = (0..n).map(|j| dense.dfdx[i][j] * (v[j] * h + y[j])).sum();
            let want = (gravity * grid.mass[i] + dense.f[i] + kw) * h;
            assert!(
                (sys.b[i] - want).amax() <= 1e-12 * want.amax().max(1e-9),
                "b[{i}]"
            );
        }
    }

    /// Every row receives its elements in the one tiled order whatever the
    /// bands: `A` and `b` bit for bit the same from one band and from
    /// three, on a crumpled cloth of thirteen tiles.
    #[test]
    fn the_bands_do_not_change_a_bit_of_the_system() {
        let (grid, x, v) = random_configuration(41, 40, 0.3, 5);
        let y: Vec<Vec3> = (0..grid.len())
            .map(|i| x[(i * 5) % grid.len()] * 1e-3)
            .collect();
        let h = 1.0 / 240.0;
        let (_, one) = crate::parallel::with_threads(1, || {
            crate::testing::cotton_system(&grid, &x, &v, &y, h)
        });
        let (_, three) = crate::parallel::with_threads(3, || {
            crate::testing::cotton_system(&grid, &x, &v, &y, h)
        });
        assert_eq!((one.bands.len(), three.bands.len()), (1, 3));
        assert!(grid.len() / TILE >= 12);
        assert_eq!(one.a.values, three.a.values);
        assert_eq!(one.b, three.b);
    }
}
