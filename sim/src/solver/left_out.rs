//! How the line sweep (`lines`) treats the couplings it leaves out, the
//! bending couplings two lines across, chosen once for a cloth: put back
//! on the diagonal loosely (`|B|_F I`, cheapest), tightly (`B`'s
//! symmetric part and a multiple of `I`, which resists no common motion
//! of the two particles), or not left out at all (the sweep reaches two
//! lines across: three colours, dearer sweeps). See
//! `multigrid/lines/compensation.rs` for the two bounds.
//!
//! The choice weighs the loose bound against the particles' masses: the
//! bending across a family's lines at the scene's largest step, `h² a /
//! (r1 r2)` per hinge end (`a = 2 E'(0)`, `cloth::bend`'s Gauss–Newton
//! coupling of a straight hinge's ends is `a P / (r1 r2)`, of Frobenius
//! norm `√2 a / (r1 r2)`), over each particle's mass: `2√2 h² B / (ρ s⁴)`
//! on a square grid of spacing `s`. It is made from the rest state and the
//! scene alone, so a resumed run chooses as the run it resumes did.

use crate::cloth::{AngleForce, Bend, Grid, energy_of_square};
use crate::math::Real;

/// Largest share a family puts back loosely; beyond it, tightly. The
/// loose `X` is cheaper, and where it weighs little against the masses
/// CG does not notice the difference (sphere-drape-200, share 5: 1,465
/// against 1,454 iterations in 0.3 s). A free-falling ribbon of cotton
/// 20 × 20, its spacing across an `r`-th of its spacing along, CG
/// iterations over its first 72 steps, loose against tight
/// (docs/benchmarks.md 1z): 74 against 72 at `r` = 4 (share 0.11), 225
/// against 73 at 8 (1.75), 1,213 against 75 at 16 (28: the first step
/// stopped at the cap of 1,000 with the ribbon hardly moved).
/// Sphere-drape-100's share is 0.31.
const SHARE_MAX: Real = 0.5;

/// The share beyond which a family reaches two lines across and leaves
/// nothing out: with the tight `X`, the first step of a 3 × 40 ribbon
/// 1 m × 1 cm (cells 2,000 : 1, share 2.7·10⁵) still stopped at the cap
/// of 1,000 CG iterations, and the solves of 20 × 20 ribbons at 48 : 1
/// (share 2·10³) needed up to 19; reaching two lines across, no solve of
/// either needed more than 4.
const REACH_TWO_SHARE: Real = 1e3;

/// How one family of lines treats what it leaves out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeftOut {
    /// Lines across a sweep reaches: 1, or 2 (nothing left out).
    pub reach: usize,
    /// Put back tightly (with `reach` 1).
    pub tight: bool,
}

impl LeftOut {
    /// Loosely, reaching one line across: the default without a cloth to
    /// weigh (tests of the preconditioner alone).
    pub const LOOSE: LeftOut = LeftOut {
        reach: 1,
        tight: false,
    };

    /// The treatment for a family whose share is `share` (module doc).
    fn of_share(share: Real) -> Self {
        if share > REACH_TWO_SHARE {
            LeftOut {
                reach: 2,
                tight: false,
            }
        } else {
            LeftOut {
                reach: 1,
                tight: share > SHARE_MAX,
            }
        }
    }

    /// The warp's (lines of fixed `j`) and the weft's treatments for a
    /// cloth on `grid` bending as `bend`, at steps up to `h`.
    pub fn for_cloth(grid: &Grid, bend: &AngleForce<Bend>, h: Real) -> [LeftOut; 2] {
        let shares = shares(grid, bend, h);
        tracing::debug!(warp = shares[0], weft = shares[1], "line sweep shares");
        shares.map(Self::of_share)
    }
}

/// The warp's and the weft's shares (module doc): the largest, over the
/// particles, of the loose bound of the couplings two lines across at the
/// rest state, over the particle's mass.
fn shares(grid: &Grid, bend: &AngleForce<Bend>, h: Real) -> [Real; 2] {
    let mut put = [vec![0.0; grid.len()], vec![0.0; grid.len()]];
    for el in &bend.elements {
        let [a, b, c] = el.idx;
        let r1 = (grid.rest[a] - grid.rest[b]).norm();
        let r2 = (grid.rest[c] - grid.rest[b]).norm();
        let (_, e_q, _) = energy_of_square(0.0, el.c1, el.c0);
        let norm = std::f64::consts::SQRT_2 * h * h * 2.0 * e_q / (r1 * r2);
        // A hinge across the warp's lines (its ends in one column) couples
        // warp lines two apart; one along them, weft lines.
        let family = usize::from(a % grid.nu != c % grid.nu);
        put[family][a] += norm;
        put[family][c] += norm;
    }
    put.map(|p| {
        p.iter()
            .zip(&grid.mass)
            .map(|(p, m)| p / m)
            .fold(0.0, Real::max)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::Limits;

    fn treatments(grid: [usize; 2], size: [Real; 2]) -> [LeftOut; 2] {
        let spec: crate::spec::Spec = serde_json::from_str(&format!(
            r#"{{"cloth": {{"grid": [{}, {}], "size": [{}, {}]}}, "material": "cotton",
                "duration": 1, "fps": 30}}"#,
            grid[0], grid[1], size[0], size[1]
        ))
        .expect("parses");
        let scene = spec.validate(&Limits::default()).expect("valid");
        let g = Grid::new(&scene.cloth, scene.material.density);
        let bend = Bend::on_grid(&g, scene.material.bend, scene.material.bend_threshold, &[]);
        LeftOut::for_cloth(&g, &bend, 1.0 / 240.0)
    }

    /// The shares of module doc's formula, and the treatments they give:
    /// square grids loosely to about 110 particles a metre, then tightly;
    /// a ribbon tightly across its fine spacing only; a ribbon of cells
    /// 48 : 1 reaching two lines across.
    #[test]
    fn treatments_follow_the_bending_across_against_the_mass() {
        let loose = LeftOut::LOOSE;
        let tight = LeftOut {
            reach: 1,
            tight: true,
        };
        let two = LeftOut {
            reach: 2,
            tight: false,
        };
        // Interior particles of a square grid: 2√2 h² B / (m s²), the
        // mass `m = ρ s²`.
        let g = crate::testing::flat_grid(30, 30, [1.0, 1.0]);
        let (s, m) = (1.0 / 29.0, g.mass[g.index(15, 15)]);
        let bend = Bend::on_grid(&g, 1e-5, 0.0, &[]);
        let h = 1.0 / 240.0;
        let want = 2.0 * std::f64::consts::SQRT_2 * h * h * 1e-5 / (m * s * s);
        let got = shares(&g, &bend, h);
        // Border particles, of half or a quarter of the mass, share more.
        assert!(got[0] >= want && got[0] <= 4.0 * want, "{got:?} {want}");
        assert_eq!(treatments([30, 30], [1.0, 1.0]), [loose, loose]);
        assert_eq!(treatments([100, 100], [1.0, 1.0]), [loose, loose]);
        assert_eq!(treatments([200, 200], [1.0, 1.0]), [tight, tight]);
        assert_eq!(treatments([20, 20], [1.0, 1.0 / 16.0]), [tight, loose]);
        assert_eq!(treatments([20, 20], [1.0 / 16.0, 1.0]), [loose, tight]);
        assert_eq!(treatments([20, 20], [1.0, 1.0 / 48.0]), [two, loose]);
    }
}
