//! Grid topology and lumped masses.
//!
//! Particle `(i, j)` has index `i + j * nu` (i runs fastest, DESIGN.md). Each
//! quad's area is shared equally by its four corners, so a particle's mass is
//! `density * (its share of the quads that touch it)` (method.md §1).

use crate::math::{Real, Vec3};
use crate::spec::ClothScene;

/// The particle grid: sizes, spacings, rest positions, masses and areas.
#[derive(Debug, Clone)]
pub struct Grid {
    /// Particles along `u`.
    pub nu: usize,
    /// Particles along `v`.
    pub nv: usize,
    /// Rest spacing along `u`.
    pub du: Real,
    /// Rest spacing along `v`.
    pub dv: Real,
    /// Initial (rest) positions.
    pub rest: Vec<Vec3>,
    /// Lumped area of each particle, m².
    pub area: Vec<Real>,
    /// Lumped mass of each particle, kg.
    pub mass: Vec<Real>,
}

impl Grid {
    /// Builds the grid of a validated cloth with areal density `density`.
    pub fn new(cloth: &ClothScene, density: Real) -> Self {
        let (nu, nv) = (cloth.nu, cloth.nv);
        let du = cloth.size[0] / (nu - 1) as Real;
        let dv = cloth.size[1] / (nv - 1) as Real;
        let mut rest = Vec::with_capacity(nu * nv);
        let mut area = Vec::with_capacity(nu * nv);
        for j in 0..nv {
            for i in 0..nu {
                rest.push(cloth.origin + cloth.u * (i as Real * du) + cloth.v * (j as Real * dv));
                area.push(Self::edge_share(i, nu) * du * Self::edge_share(j, nv) * dv);
            }
        }
        let mass = area.iter().map(|a| a * density).collect();
        Self {
            nu,
            nv,
            du,
            dv,
            rest,
            area,
            mass,
        }
    }

    /// Fraction of a spacing a particle owns along one axis: 1/2 on the
    /// border, 1 inside.
    pub fn edge_share(i: usize, n: usize) -> Real {
        if i == 0 || i + 1 == n { 0.5 } else { 1.0 }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.nu * self.nv
    }

    /// `true` for a grid with no particles (never, for a validated scene).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index of particle `(i, j)`.
    #[inline]
    pub fn index(&self, i: usize, j: usize) -> usize {
        i + j * self.nu
    }

    /// Two triangles per quad, counter-clockwise seen from `u × v`.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let mut t = Vec::with_capacity(2 * (self.nu - 1) * (self.nv - 1));
        for j in 0..self.nv - 1 {
            for i in 0..self.nu - 1 {
                let a = self.index(i, j) as u32;
                let b = self.index(i + 1, j) as u32;
                let c = self.index(i + 1, j + 1) as u32;
                let d = self.index(i, j + 1) as u32;
                t.push([a, b, c]);
                t.push([a, c, d]);
            }
        }
        t
    }

    /// Length of the grid diagonal: the cloth's size for normalising errors.
    pub fn diagonal(&self) -> Real {
        let lu = self.du * (self.nu - 1) as Real;
        let lv = self.dv * (self.nv - 1) as Real;
        (lu * lu + lv * lv).sqrt()
    }
}
