//! Obstacles as written in a spec: one shape, friction, offset, rigid motion.
//!
//! Shapes are optional fields of one struct rather than an enum so that a
//! spec reads `{"sphere": {...}, "friction": 0.4}` as DESIGN.md shows, and
//! so validation can say "exactly one shape" with the path of the obstacle.

use serde::{Deserialize, Serialize};

/// A rigid obstacle.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Obstacle {
    /// A sphere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sphere: Option<Sphere>,
    /// An axis-aligned box (in the obstacle's own frame).
    #[serde(default, rename = "box", skip_serializing_if = "Option::is_none")]
    pub box_: Option<BoxShape>,
    /// An infinite plane; the cloth stays on the side the normal points to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plane: Option<Plane>,
    /// A closed cylinder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cylinder: Option<Cylinder>,
    /// A triangle mesh.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mesh: Option<MeshSource>,
    /// Coulomb friction coefficient.
    #[serde(default)]
    pub friction: f64,
    /// Collision surface offset in metres (method.md §3); default derived
    /// from the particle spacing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset: Option<f64>,
    /// Rigid motion; absent means static.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<Motion>,
}

/// A sphere.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sphere {
    /// Centre in metres.
    pub center: [f64; 3],
    /// Radius in metres.
    pub radius: f64,
}

/// An axis-aligned box.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxShape {
    /// Centre in metres.
    pub center: [f64; 3],
    /// Edge lengths along x, y, z.
    pub size: [f64; 3],
}

/// An infinite plane.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plane {
    /// A point on the plane.
    pub point: [f64; 3],
    /// The outward normal (need not be unit length).
    pub normal: [f64; 3],
}

/// A closed cylinder.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cylinder {
    /// Centre of the axis segment.
    pub center: [f64; 3],
    /// Axis direction (need not be unit length).
    pub axis: [f64; 3],
    /// Radius in metres.
    pub radius: f64,
    /// Length along the axis in metres.
    pub height: f64,
}

/// A triangle mesh, given one of three ways.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshSource {
    /// Inline Wavefront OBJ text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obj: Option<String>,
    /// Base64 STL, binary or ASCII.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stl: Option<String>,
    /// Inline vertex positions (with `triangles`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertices: Option<Vec<[f64; 3]>>,
    /// Inline triangles as zero-based vertex indices (with `vertices`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triangles: Option<Vec<[u32; 3]>>,
}

/// Rigid motion: constant velocities, or keyframes.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// Constant linear velocity, m/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<[f64; 3]>,
    /// Constant angular velocity, rad/s, about `pivot`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<[f64; 3]>,
    /// The point the rotation is about; default the origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pivot: Option<[f64; 3]>,
    /// Poses over time; linear/slerp between keys, held after the last.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keyframes: Option<Vec<Keyframe>>,
}

/// A pose at a time.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// Time in seconds.
    pub time: f64,
    /// Translation in metres.
    #[serde(default)]
    pub translation: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`.
    #[serde(default = "identity_rotation")]
    pub rotation: [f64; 4],
}

fn identity_rotation() -> [f64; 4] {
    [0.0, 0.0, 0.0, 1.0]
}
