//! A crumpled start: the flat grid gathered in and folded, for the stress
//! case that releases a crumpled cloth over an obstacle.
//!
//! The cloth is drawn towards its centre to 60 % in its plane and lifted
//! along `up` by a random field (a few plane waves of 15..50 % of the
//! cloth's diagonal plus per-particle noise), scaled down until no spring
//! is longer than 99 % of its rest length: a crumpled cloth is compressed,
//! never stretched, so the stretch check measures the solver, not the start.

use drapery_sim::cloth::{Grid, Stretch};
use drapery_sim::math::{Real, Vec3};

/// In-plane gathering factor.
const GATHER: Real = 0.6;
/// Longest spring of the crumpled cloth over its rest length.
const MAX_RATIO: Real = 0.99;

/// Crumpled positions of `grid`, lifted towards `up` (the lowest particle
/// stays in the flat cloth's plane), reproducible from `seed`.
pub fn crumple(grid: &Grid, stretch: &Stretch, up: Vec3, seed: u64) -> Vec<Vec3> {
    let rest = &grid.rest;
    let centre = rest.iter().sum::<Vec3>() / rest.len() as Real;
    let eu = (rest[grid.index(grid.nu - 1, 0)] - rest[0]).normalize();
    let ev = (rest[grid.index(0, grid.nv - 1)] - rest[0]).normalize();
    let mut normal = eu.cross(&ev).normalize();
    if normal.dot(&up) < 0.0 {
        normal = -normal;
    }
    let diagonal = (rest[rest.len() - 1] - rest[0]).norm();
    let mut rng = SplitMix64(seed);
    let waves: Vec<(Real, Real, Real, Real)> = (0..6)
        .map(|_| {
            let angle = rng.unit() * std::f64::consts::TAU;
            let wavelength = diagonal * (0.15 + 0.35 * rng.unit());
            let k = std::f64::consts::TAU / wavelength;
            (
                k * angle.cos(),
                k * angle.sin(),
                rng.unit() * 6.3,
                0.25 * wavelength,
            )
        })
        .collect();
    let noise = 0.3 * grid.du.min(grid.dv);
    let height: Vec<Real> = rest
        .iter()
        .map(|p| {
            let d = p - centre;
            let (a, b) = (d.dot(&eu), d.dot(&ev));
            let waves: Real = waves
                .iter()
                .map(|(ku, kv, phase, amp)| amp * (ku * a + kv * b + phase).sin())
                .sum();
            waves + noise * (2.0 * rng.unit() - 1.0)
        })
        .collect();
    let lowest = height.iter().copied().fold(Real::INFINITY, Real::min);
    let place = |s: Real| -> Vec<Vec3> {
        rest.iter()
            .zip(&height)
            .map(|(p, h)| {
                let d = p - centre;
                let in_plane = d - normal * d.dot(&normal);
                centre + in_plane * GATHER + normal * (s * (h - lowest))
            })
            .collect()
    };
    // The largest scale of the field that stretches nothing: the ratio
    // grows with the scale, and at 0 it is GATHER.
    let (mut lo, mut hi) = (0.0, 1.0);
    if stretch.max_ratio(&place(hi)) <= MAX_RATIO {
        lo = hi;
    }
    for _ in 0..40 {
        if lo == hi {
            break;
        }
        let mid = 0.5 * (lo + hi);
        if stretch.max_ratio(&place(mid)) <= MAX_RATIO {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    place(lo)
}

/// SplitMix64: a stated, version-proof generator, so a seed names the same
/// crumple on every machine and release.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> Real {
        (self.next() >> 11) as Real / (1u64 << 53) as Real
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use drapery_sim::cloth::ForceModel;
    use drapery_sim::spec::{Limits, Scene, Spec};

    fn scene_from_json(json: &str) -> Scene {
        let spec: Spec = serde_json::from_str(json).expect("spec parses");
        spec.validate(&Limits::default()).expect("spec validates")
    }

    #[test]
    fn a_crumpled_cloth_is_folded_compressed_and_reproducible() {
        let scene = scene_from_json(
            r#"{"cloth": {"grid": [20, 20], "size": [1, 1], "origin": [-0.5, -0.5, 0.3]},
                "material": "cotton", "duration": 0.1, "fps": 30}"#,
        );
        let grid = Grid::new(&scene.cloth, scene.material.density);
        let model = ForceModel::new(&grid, &scene.material);
        let up = Vec3::z();
        let x = crumple(&grid, &model.stretch, up, 7);
        assert_eq!(x, crumple(&grid, &model.stretch, up, 7));
        assert_ne!(x, crumple(&grid, &model.stretch, up, 8));
        let ratio = model.stretch.max_ratio(&x);
        assert!(ratio <= MAX_RATIO + 1e-12 && ratio > 0.9, "ratio {ratio}");
        // Gathered in: the footprint shrinks to GATHER of its width.
        let width = |x: &[Vec3]| {
            let xs = x.iter().map(|p| p.x);
            xs.clone().fold(f64::MIN, f64::max) - xs.fold(f64::MAX, f64::min)
        };
        assert!((width(&x) - GATHER * width(&grid.rest)).abs() < 1e-12);
        // Folded: heights span several centimetres, all on the `up` side.
        let zs: Vec<f64> = x.iter().map(|p| p.z).collect();
        let lo = zs.iter().copied().fold(f64::MAX, f64::min);
        let hi = zs.iter().copied().fold(f64::MIN, f64::max);
        assert!((lo - 0.3).abs() < 1e-12, "lowest {lo}");
        assert!(hi - lo > 0.03, "relief {}", hi - lo);
    }
}
