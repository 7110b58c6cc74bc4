//! Fabric materials: physical, resolution-independent parameters and presets.
//!
//! The parameters are continuum quantities so that the same material on a
//! finer grid gives the same drape (DESIGN.md): `stretch` is the membrane's
//! tensile stiffness per unit width (N/m), `shear` its in-plane shear
//! stiffness (N/m), `bend` its bending rigidity per unit width (N·m). The
//! cloth module turns them into per-element coefficients (method.md §1).
//!
//! Preset numbers come from Kawabata KES-F measurements as tabulated in
//! Kawabata & Niwa, "Fabric performance in clothing and clothing
//! manufacture", J. Textile Inst. 80 (1989), and the ranges quoted in
//! Volino & Magnenat-Thalmann, "Virtual Clothing" (2000), ch. 4, converted to
//! SI with
//! - bending rigidity B: 1 gf·cm²/cm = 9.807e-5 N·m;
//! - shear rigidity G: 1 gf/(cm·deg) = 56.2 N/m (per radian);
//! - tensile stiffness: the KES extensibility EM at 500 gf/cm (490 N/m),
//!   stiffness ≈ 490 N/m / EM (secant modulus);
//! - weight W: 1 mg/cm² = 0.01 kg/m².
//!
//! Each preset also states its bending length `c = (B / (W g))^(1/3)`, the
//! quantity Peirce's cantilever test (ASTM D1388, the Shirley stiffness
//! tester) measures: a strip overhanging by `2c` droops to a 41.5° chord.
//! `sim/tests/elastica.rs` runs that test on every preset and reads `c`
//! back through the exact elastica.

use serde::{Deserialize, Deserializer, Serialize};

/// A material as written in a spec: a preset name or explicit parameters.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum MaterialSpec {
    /// One of [`PRESETS`].
    Preset(String),
    /// Explicit physical parameters.
    Params(MaterialParams),
}

/// Physical, resolution-independent material parameters (SI units).
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialParams {
    /// Areal density, kg/m².
    pub density: f64,
    /// Tensile stiffness per unit width, N/m (force per width per unit strain).
    pub stretch: f64,
    /// In-plane shear stiffness, N/m (per radian of shear angle).
    pub shear: f64,
    /// Bending rigidity per unit width, N·m (moment per width per curvature).
    pub bend: f64,
    /// The paper's linear bending term `C_b0` (a threshold moment), N·m;
    /// smoothed at zero angle (see `cloth::angle`).
    #[serde(default)]
    pub bend_threshold: f64,
    /// The paper's linear shear term `C_s0`, N/m; smoothed at zero angle.
    #[serde(default)]
    pub shear_threshold: f64,
    /// Stiffness-proportional (Rayleigh) damping of the membrane, in
    /// seconds: a stretch spring of stiffness `k` gets damping
    /// `damping * k` along it, and a shear angle of stiffness `C_s1`
    /// resists its rate with `damping * C_s1`.
    #[serde(default)]
    pub damping: f64,
    /// Linear air drag per unit area, kg/(m²·s): `f = -air_drag * area * v`.
    #[serde(default)]
    pub air_drag: f64,
}

const fn fabric(density: f64, stretch: f64, shear: f64, bend: f64) -> MaterialParams {
    MaterialParams {
        density,
        stretch,
        shear,
        bend,
        bend_threshold: 0.0,
        shear_threshold: 0.0,
        // NOTE: 2 ms of stiffness-proportional damping critically damps
        // stretch and shear modes above ~1000 rad/s, far above any drape
        // motion: a stretch or shear mode at 10 rad/s keeps 94 % of its
        // amplitude a cycle, and a drape's swing, held by gravity, hardly
        // strains either.
        damping: 0.002,
        // NOTE: time constant density/air_drag of a few seconds: settles a
        // drape without visibly slowing its fall.
        air_drag: 0.05,
    }
}

/// Preset names with their parameters.
pub const PRESETS: [(&str, MaterialParams); 5] = [
    // Cotton broadcloth: W 15 mg/cm², EM 2.5 % -> 2.0e4 N/m,
    // G 0.9 gf/(cm·deg) -> 50 N/m, B 0.10 gf·cm²/cm -> 1.0e-5 N·m.
    // Bending length c = 1.89 cm.
    ("cotton", fabric(0.15, 2.0e4, 50.0, 1.0e-5)),
    // Silk crepe de chine: W 6 mg/cm², EM 5 % -> 1.0e4 N/m,
    // G 0.3 gf/(cm·deg) -> 17 N/m, B 0.02 gf·cm²/cm -> 2.0e-6 N·m.
    // Bending length c = 1.50 cm.
    ("silk", fabric(0.06, 1.0e4, 17.0, 2.0e-6)),
    // Denim: W 40 mg/cm², EM 1.5 % -> 3.3e4 N/m,
    // G 3.0 gf/(cm·deg) -> 170 N/m, B 0.8 gf·cm²/cm -> 8.0e-5 N·m.
    // Bending length c = 2.73 cm.
    ("denim", fabric(0.40, 3.3e4, 170.0, 8.0e-5)),
    // Wool gabardine: W 25 mg/cm², EM 8 % -> 6.0e3 N/m,
    // G 0.8 gf/(cm·deg) -> 45 N/m, B 0.12 gf·cm²/cm -> 1.2e-5 N·m.
    // Bending length c = 1.70 cm.
    ("wool", fabric(0.25, 6.0e3, 45.0, 1.2e-5)),
    // Polyester plain weave: W 10 mg/cm², EM 2 % -> 2.5e4 N/m,
    // G 0.6 gf/(cm·deg) -> 34 N/m, B 0.06 gf·cm²/cm -> 6.0e-6 N·m.
    // Bending length c = 1.83 cm.
    ("polyester", fabric(0.10, 2.5e4, 34.0, 6.0e-6)),
];

/// Looks up a preset by name.
pub fn preset(name: &str) -> Option<MaterialParams> {
    PRESETS.iter().find(|(n, _)| *n == name).map(|(_, p)| *p)
}

impl<'de> Deserialize<'de> for MaterialSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = MaterialSpec;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a preset name or an object of material parameters")
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<MaterialSpec, E> {
                Ok(MaterialSpec::Preset(s.to_owned()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<MaterialSpec, A::Error> {
                MaterialParams::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(MaterialSpec::Params)
            }
        }
        d.deserialize_any(V)
    }
}
