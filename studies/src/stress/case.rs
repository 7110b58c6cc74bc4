//! One stress case: a scene, how it starts, and its stretch bound.

use drapery_sim::spec::Spec;

/// One stress case.
#[derive(Debug, Clone)]
pub struct Case {
    /// Case family and parameter, e.g. `tablecloth-pull 8 m/s`.
    pub name: String,
    /// The scene.
    pub spec: Spec,
    /// Start from a crumpled cloth (this seed) instead of the flat grid.
    pub crumple_seed: Option<u64>,
    /// Largest edge length over rest length allowed at any frame.
    pub max_stretch: f64,
}
