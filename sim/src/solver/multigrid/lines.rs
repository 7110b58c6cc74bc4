//! Line relaxation: block Gauss–Seidel where a block is a whole grid line.
//!
//! Cloth is strongly anisotropic: stretch along a thread is 10²–10⁶ times
//! stiffer than shear and bending across it, and a warp spring couples
//! particles only along its own line. Point smoothers (Jacobi, Gauss–Seidel)
//! cannot reduce errors that are smooth along a stiff line and rough across
//! it; solving each line exactly can, so alternating warp and weft line
//! relaxation is the smoother that survives the anisotropy (the classic
//! remedy for anisotropic operators, with full coarsening).
//!
//! Each line's block (its nodes, coupled at distance one and two along the
//! line) is factored as a block-pentadiagonal `L Lᵀ` with 3x3 blocks, the
//! inverses of the diagonal factors stored so a solve is only 3x3 products.
//!
//! A sweep couples each line to the lines up to `reach` across (one or
//! two), so lines `reach + 1` apart are independent: the lines of one
//! family are relaxed in `reach + 1` colours (line index mod `reach + 1`),
//! the lines of a colour at once, and a forward sweep (colours in order)
//! followed later by the backward one (reversed) makes a symmetric
//! smoother. With `reach` 2 (bending's reach) that is block Gauss–Seidel
//! on `A` itself. With `reach` 1 it is Gauss–Seidel on
//!
//! ```text
//! Ã = A - C + E,   E = Σ over the couplings B left out: X(B) on both nodes' diagonals
//! ```
//!
//! where `C` holds the couplings two or more lines across: for each such
//! `B` between nodes `p` and `q`, `E - C` adds
//! `[[X, -B], [-Bᵀ, X]]`, positive semi-definite by the choice of `X`
//! (`lines/compensation.rs`), so `Ã ≥ A` is SPD and the smoother stays
//! an SPD preconditioner, whatever the stencil. The loose `X = |B|_F I`
//! costs one norm, but resists every motion of the two nodes, their
//! common translation too, which the couplings (bending) do not; where
//! that outweighs the particles' masses a falling cloth stiffens in the
//! preconditioner and CG stalls, so a family puts back the tight `X`,
//! `B`'s symmetric part and a multiple of `I` for the rest, there
//! (`solver::left_out`).
//!
//! Within a colour, the packs of lines are solved on the team and each
//! writes its own lines' nodes of `x` directly ([`Disjoint`]): a pack
//! reads `x` only on lines of other colours, and writes only its own.

use super::grid_matrix::{Block, GridMatrix, Vec3f};
use super::lanes::{BlockLanes, LANES, VecLanes, ZERO_BLOCK, ZERO_VEC, set_block};
use super::line_factor::{self, NodeBlocks, NodeFactor, ZERO_FACTOR};
use crate::parallel::{self, Disjoint};
use std::ops::Range;

mod compensation;
mod relax;

/// The lines' direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Lines of fixed `j` along `u` (warp).
    U,
    /// Lines of fixed `i` along `v` (weft).
    V,
}

/// One family of lines with its factors. Lines of one colour are solved
/// [`LANES`] at a time, as a *pack*: packs are numbered colour by colour,
/// and everything a sweep reads is stored per pack and node along the
/// line (`pack * len + t`), one lane per line, so a pack's data is
/// contiguous whichever way its lines run through the grid. Lanes past a
/// colour's last line are padding: zero blocks, never written back.
#[derive(Debug, Clone)]
pub struct LineFamily {
    direction: Direction,
    len: usize,
    /// Lines of the family, and how many lines across a sweep reaches.
    lines: usize,
    /// Nodes of the grid: every index in `nodes` and `off_index` is below
    /// it (checked when they are built), so a sweep checks its vectors'
    /// lengths against it once instead of each read.
    grid_nodes: usize,
    reach: usize,
    /// The first pack of each colour, and the end of the last.
    colour_start: Vec<usize>,
    /// The line in each lane of each pack ([`MISSING`]: padding).
    pack_lines: Vec<u32>,
    /// Grid index of each lane's node, per pack and node (padding: 0).
    nodes: Vec<[u32; LANES]>,
    /// Per pack and node, its couplings to other lines: `width` blocks
    /// and the grid indices they multiply; a missing neighbour has a zero
    /// block and the node's own index, so the gather has no branch.
    width: usize,
    off_blocks: Vec<BlockLanes>,
    off_index: Vec<[u32; LANES]>,
    /// Where each lane of `off_blocks` is read from in the grid matrix's
    /// values ([`MISSING`] for a neighbour off the grid or a padding
    /// lane): fixed by the grid, so a refactorisation is a gather.
    off_source: Vec<[u32; LANES]>,
    /// Per pack and node, its Cholesky factors.
    factors: Vec<NodeFactor>,
    /// The matrix's offsets reaching two or more lines across, left out
    /// of the sweep and made up for on the diagonal, tightly or loosely
    /// (module doc).
    dropped: Vec<usize>,
    tight: bool,
    /// The tight `X` of each coupling left out, per offset reaching
    /// forward, and their sums per node (`compensation::tight_sums`).
    tight_pairs: Vec<Vec<Block>>,
    tight_sum: Vec<Block>,
}

/// What a sweep may assume about `x` on entry, to skip work whose result
/// it already knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Entry {
    /// Nothing.
    Any,
    /// `x` is zero: the first colour's couplings to other lines vanish.
    Zero,
    /// The last thing done to `x` was this family's sweep in the opposite
    /// order: it ended with the colour this one starts with, which is
    /// therefore already relaxed against the values it would see.
    AfterReverse,
}

/// Fewest pack nodes of one colour worth spreading over threads: a pack
/// node is ~0.1 µs, and sharing a loop costs ~0.3 µs with the team
/// spinning (`parallel::Team`). A 30² cloth's colours (~90 pack nodes)
/// are spread; one of a handful of lines is not.
const SWEEP_PARALLEL_MIN: usize = 64;

/// An off-line neighbour outside the grid, or a padding lane.
const MISSING: u32 = u32::MAX;

/// The offsets of `a`'s stencil whose distance across `direction`'s lines
/// passes `keep`.
fn offsets_across(
    direction: Direction,
    a: &GridMatrix,
    keep: &dyn Fn(usize) -> bool,
) -> Vec<usize> {
    (0..a.offsets().len())
        .filter(|&k| {
            let (di, dj) = a.offsets()[k];
            keep(match direction {
                Direction::U => dj.unsigned_abs() as usize,
                Direction::V => di.unsigned_abs() as usize,
            })
        })
        .collect()
}

/// Scratch of a sweep: one buffer per pack, so the packs of a colour can
/// be solved at once.
#[derive(Debug, Clone, Default)]
pub struct LineScratch {
    pub(super) packs: Vec<VecLanes>,
    /// The stages of a sweep run as one flow (`super::symmetric`).
    pub(super) flow: parallel::Flow,
}

impl LineFamily {
    /// Factors for the lines of `direction` on `a`'s grid, each line
    /// coupled to the lines up to `reach` across (1 or 2: module doc).
    pub fn new(direction: Direction, a: &GridMatrix, reach: usize) -> Self {
        assert!((1..=2).contains(&reach), "reach {reach}");
        let colours = reach + 1;
        let (lines, len) = match direction {
            Direction::U => (a.nv, a.nu),
            Direction::V => (a.nu, a.nv),
        };
        let node = |l: usize, t: usize| match direction {
            Direction::U => t + l * a.nu,
            Direction::V => l + t * a.nu,
        };
        let mut colour_start = vec![0; colours + 1];
        let mut pack_lines = Vec::new();
        for c in 0..colours {
            colour_start[c] = pack_lines.len() / LANES;
            let of_colour: Vec<u32> = (c..lines).step_by(colours).map(|l| l as u32).collect();
            for pack in of_colour.chunks(LANES) {
                pack_lines.extend(pack);
                pack_lines.resize(pack_lines.len() + LANES - pack.len(), MISSING);
            }
        }
        let packs = pack_lines.len() / LANES;
        colour_start[colours] = packs;
        let off = offsets_across(direction, a, &|d| d >= 1 && d <= reach);
        let dropped = offsets_across(direction, a, &|d| d > reach);
        let width = off.len();
        let stride = a.offsets().len();
        let mut nodes = vec![[0; LANES]; packs * len];
        let mut off_index = vec![[0; LANES]; packs * len * width];
        let mut off_source = vec![[MISSING; LANES]; packs * len * width];
        for (lane_at, &line) in pack_lines.iter().enumerate() {
            let (pack, lane) = (lane_at / LANES, lane_at % LANES);
            if line == MISSING {
                // A padding lane reads what its pack's first lane reads:
                // nothing another pack of its colour writes (`sweep`).
                for t in 0..len {
                    let s = pack * len + t;
                    for k in 0..width {
                        off_index[s * width + k][lane] = off_index[s * width + k][0];
                    }
                }
                continue;
            }
            for t in 0..len {
                let p = node(line as usize, t);
                let s = pack * len + t;
                nodes[s][lane] = p as u32;
                let (i, j) = (p % a.nu, p / a.nu);
                for (k, &slot) in off.iter().enumerate() {
                    off_index[s * width + k][lane] = p as u32;
                    if let Some(q) = a.neighbour(i, j, slot) {
                        off_index[s * width + k][lane] = q as u32;
                        off_source[s * width + k][lane] = (p * stride + slot) as u32;
                    }
                }
            }
        }
        let grid_nodes = a.nu * a.nv;
        let inside = |v: &[[u32; LANES]]| v.iter().flatten().all(|&p| (p as usize) < grid_nodes);
        assert!(
            inside(&nodes) && inside(&off_index),
            "a line node off the grid"
        );
        let mut f = Self {
            direction,
            len,
            lines,
            grid_nodes,
            reach,
            colour_start,
            pack_lines,
            nodes,
            width,
            off_blocks: vec![ZERO_BLOCK; packs * len * width],
            off_index,
            off_source,
            factors: vec![ZERO_FACTOR; packs * len],
            dropped,
            tight: false,
            tight_pairs: Vec::new(),
            tight_sum: Vec::new(),
        };
        f.factor(a);
        f
    }

    /// Puts the couplings left out back tightly (`true`) or loosely
    /// (module doc) from the next [`LineFamily::factor`] on.
    pub fn set_tight(&mut self, tight: bool) {
        self.tight = tight;
    }

    /// Copies `a`'s couplings between lines and factors every line. A
    /// pivot that is not positive (the line block is not SPD to single
    /// precision) is replaced by the diagonal's magnitude, which keeps the
    /// smoother SPD at some cost in accuracy.
    pub fn factor(&mut self, a: &GridMatrix) {
        let (dir, len) = (self.direction, self.len);
        let (sx, sy) = match dir {
            Direction::U => (1, 0),
            Direction::V => (0, 1),
        };
        let k1 = a.offset_index(-sx, -sy);
        let k2 = a.offset_index(-2 * sx, -2 * sy);
        let k0 = a.offset_index(0, 0);
        // Couplings to other lines, node by node.
        let values = a.values();
        let source = &self.off_source;
        parallel::for_chunks_min(&mut self.off_blocks, parallel::ROWS_MIN, |start, blocks| {
            for (b, src) in blocks.iter_mut().zip(&source[start..]) {
                for (lane, &at) in src.iter().enumerate() {
                    let m = if at == MISSING {
                        Block::zeros()
                    } else {
                        values[at as usize]
                    };
                    set_block(b, lane, &m);
                }
            }
        });
        // Each line's Cholesky factors, the lines of a pack side by side
        // in the lanes (padding lanes factor an identity), packs in
        // parallel.
        let (nodes, pack_lines) = (&self.nodes, &self.pack_lines);
        let get = |p: usize, k: Option<usize>| k.map_or(Block::zeros(), |k| a.row(p)[k]);
        // The couplings the smoother leaves out, each `B` put back on both
        // its nodes' diagonals as `X(B)` (module doc).
        let dropped = &self.dropped;
        if self.tight {
            compensation::tight_sums(a, dropped, &mut self.tight_pairs, &mut self.tight_sum);
        }
        let (tight, tight_sum) = (self.tight, &self.tight_sum);
        let compensation = |p: usize| -> Block {
            if tight {
                tight_sum[p]
            } else {
                let row = a.row(p);
                let loose: f32 = dropped.iter().map(|&k| compensation::loose(&row[k])).sum();
                Block::from_diagonal_element(loose)
            }
        };
        parallel::for_rows(
            &mut self.factors,
            len,
            parallel::HEAVY_MIN,
            |pack, factors| {
                let lanes = |t: usize, of: &dyn Fn(usize) -> Block, padding: Block| {
                    let mut out = ZERO_BLOCK;
                    for lane in 0..LANES {
                        let m = if pack_lines[pack * LANES + lane] == MISSING {
                            padding
                        } else {
                            of(nodes[pack * len + t][lane] as usize)
                        };
                        set_block(&mut out, lane, &m);
                    }
                    out
                };
                line_factor::factor(factors, |t| {
                    let diag = lanes(t, &|p| get(p, k0), Block::identity());
                    let mut shift = ZERO_BLOCK;
                    if !dropped.is_empty() {
                        for lane in 0..LANES {
                            if pack_lines[pack * LANES + lane] != MISSING {
                                let p = nodes[pack * len + t][lane] as usize;
                                set_block(&mut shift, lane, &compensation(p));
                            }
                        }
                    }
                    NodeBlocks {
                        diag,
                        shift,
                        prev1: lanes(t, &|p| get(p, k1), Block::zeros()),
                        prev2: lanes(t, &|p| get(p, k2), Block::zeros()),
                    }
                });
            },
        );
    }

    /// One relaxation of every line, colours in order (`forward`) or
    /// reversed: each line's nodes become the exact solution of its block
    /// given the others' current values. The packs of a colour are solved
    /// in parallel (each substituting in its own buffer) and each writes
    /// its lines' nodes of `x` itself (module doc). `entry`
    /// lets the sweep skip what it knows the result of (bit for bit the
    /// same `x`).
    pub fn sweep(
        &self,
        b: &[Vec3f],
        x: &mut [Vec3f],
        forward: bool,
        entry: Entry,
        scratch: &mut LineScratch,
    ) {
        let len = self.len;
        scratch.packs.resize(self.factors.len(), ZERO_VEC);
        for (colour, coupled) in self.order(forward, entry) {
            let packs = self.packs(colour);
            let out = &mut scratch.packs[packs.start * len..packs.end * len];
            let shared = Disjoint::new(&mut *x);
            parallel::for_rows(out, len, SWEEP_PARALLEL_MIN, |k, out| {
                self.relax_pack(packs.start + k, b, &shared, coupled, out);
            });
        }
    }

    /// The colours a sweep relaxes, in order, each with whether its packs
    /// read the other lines (not the first colour from [`Entry::Zero`];
    /// not at all the first colour after [`Entry::AfterReverse`]).
    pub fn order(&self, forward: bool, entry: Entry) -> impl Iterator<Item = (usize, bool)> {
        let colours = self.colour_start.len() - 1;
        let first = usize::from(entry == Entry::AfterReverse);
        (first..colours).map(move |c| {
            let colour = if forward { c } else { colours - 1 - c };
            (colour, !(c == 0 && entry == Entry::Zero))
        })
    }

    /// The packs of colour `colour`.
    pub fn packs(&self, colour: usize) -> Range<usize> {
        self.colour_start[colour]..self.colour_start[colour + 1]
    }

    /// A pack's buffer in a sweep (its lines' length), and all packs'.
    pub fn buffers(&self) -> (usize, usize) {
        (self.len, self.factors.len())
    }

    /// Whether relaxing colour `colour` is worth spreading over threads.
    pub fn spread(&self, colour: usize) -> bool {
        self.packs(colour).len() * self.len >= SWEEP_PARALLEL_MIN
    }

    /// Lines across that a sweep reaches, and the family's lines.
    pub fn reach(&self) -> (usize, usize) {
        (self.reach, self.lines)
    }

    /// The lines of pack `pack` (padding left out).
    pub fn lines_in(&self, pack: usize) -> impl Iterator<Item = usize> + '_ {
        let lanes = &self.pack_lines[pack * LANES..(pack + 1) * LANES];
        lanes.iter().filter(|&&l| l != MISSING).map(|&l| l as usize)
    }

    /// The pack holding line `line`, and its colour.
    pub fn pack_of(&self, line: usize) -> (usize, usize) {
        let colours = self.colour_start.len() - 1;
        let colour = line % colours;
        (self.colour_start[colour] + line / colours / LANES, colour)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line family on a grid whose only couplings are along its lines is
    /// an exact solver: one sweep solves `A x = b`.
    #[test]
    fn a_sweep_solves_a_matrix_of_independent_lines() {
        for dir in [Direction::U, Direction::V] {
            let (nu, nv) = (7, 5);
            let offsets: Vec<(i32, i32)> = (-2..=2)
                .map(|d| if dir == Direction::U { (d, 0) } else { (0, d) })
                .collect();
            let mut a = GridMatrix::new(nu, nv, offsets);
            let near = Block::new(-1.0, 0.2, 0.0, 0.2, -0.5, 0.1, 0.0, 0.1, -0.3);
            let far = Block::new(0.1, 0.0, 0.05, 0.0, 0.1, 0.0, 0.05, 0.0, 0.1);
            for j in 0..nv {
                for i in 0..nu {
                    let p = i + j * nu;
                    for k in 0..a.offsets().len() {
                        if a.neighbour(i, j, k).is_none() {
                            continue;
                        }
                        let (di, dj) = a.offsets()[k];
                        a.row_mut(p)[k] = match (di + dj).abs() {
                            0 => Block::from_diagonal(&Vec3f::new(6.0, 5.0, 4.0)),
                            1 => near,
                            _ => far,
                        };
                    }
                }
            }
            let family = LineFamily::new(dir, &a, 2);
            let b: Vec<Vec3f> = (0..nu * nv)
                .map(|k| Vec3f::new(1.0, (k as f32).sin(), -0.5))
                .collect();
            let mut x = vec![Vec3f::zeros(); nu * nv];
            family.sweep(&b, &mut x, true, Entry::Zero, &mut LineScratch::default());
            let mut r = vec![Vec3f::zeros(); nu * nv];
            a.residual(&b, &x, &mut r);
            let worst = r.iter().map(|v| v.amax()).fold(0.0, f32::max);
            assert!(worst < 1e-5, "{dir:?}: residual {worst}");
        }
    }
}
