//! The spec as users write it (DESIGN.md "Job spec (version 1)").
//!
//! Every struct rejects unknown fields so a misspelt key is an error, not a
//! silently ignored setting.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::material::MaterialSpec;
use super::obstacle::Obstacle;

/// A whole job: one cloth, its material, the obstacles, and how to solve.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// Free-form name, echoed in outputs.
    #[serde(default)]
    pub name: Option<String>,
    /// The particle grid.
    pub cloth: ClothSpec,
    /// A preset name or explicit physical parameters.
    pub material: MaterialSpec,
    /// Rigid obstacles; empty means no collision stage at all.
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
    /// Gravitational acceleration in m/s²; Z is up by default.
    #[serde(default = "default_gravity")]
    pub gravity: [f64; 3],
    /// Simulated time in seconds.
    pub duration: f64,
    /// Output frames per simulated second.
    pub fps: f64,
    /// Time stepping and linear solver settings.
    #[serde(default)]
    pub solver: SolverSpec,
}

fn default_gravity() -> [f64; 3] {
    [0.0, 0.0, -9.81]
}

/// A grid particle `[i, j]` held in place.
pub type Pin = [u32; 2];

/// One entry of `cloth.pinned`: a particle `[i, j]` held where it starts,
/// or a group of particles that follow a rigid motion together (a hand
/// pulling a table cloth, a moving hanger), with `motion` exactly as an
/// obstacle's: the group moves as if glued to a rigid body.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum PinEntry {
    /// Held in place.
    Particle(Pin),
    /// Held to a moving frame.
    Group(PinGroup),
}

impl From<Pin> for PinEntry {
    fn from(p: Pin) -> Self {
        PinEntry::Particle(p)
    }
}

/// Particles pinned to one rigid motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[serde(deny_unknown_fields)]
pub struct PinGroup {
    /// The particles, `[i, j]` each.
    #[cfg_attr(feature = "schema", schema(value_type = Vec<[u32; 2]>))]
    pub particles: Vec<Pin>,
    /// Their motion from where they start; none: held in place.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<super::obstacle::Motion>,
}

/// An array is a particle, an object a group: dispatching on the JSON type
/// keeps serde's own error messages (and paths) for each form, which an
/// untagged enum would replace with "did not match any variant".
impl<'de> Deserialize<'de> for PinEntry {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = PinEntry;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(
                    "a particle [i, j] or a group {\"particles\": [[i, j], ...], \"motion\": ...}",
                )
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<PinEntry, A::Error> {
                Pin::deserialize(serde::de::value::SeqAccessDeserializer::new(seq))
                    .map(PinEntry::Particle)
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<PinEntry, A::Error> {
                PinGroup::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(PinEntry::Group)
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(feature = "schema")]
impl utoipa::PartialSchema for PinEntry {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{ArrayBuilder, ObjectBuilder, OneOfBuilder, Type};
        OneOfBuilder::new()
            .item(
                ArrayBuilder::new()
                    .items(
                        ObjectBuilder::new()
                            .schema_type(Type::Integer)
                            .minimum(Some(0)),
                    )
                    .min_items(Some(2))
                    .max_items(Some(2))
                    .description(Some("A particle [i, j] held where it starts")),
            )
            .item(utoipa::openapi::Ref::from_schema_name("PinGroup"))
            .into()
    }
}

#[cfg(feature = "schema")]
impl utoipa::ToSchema for PinEntry {
    fn schemas(
        schemas: &mut Vec<(
            String,
            utoipa::openapi::RefOr<utoipa::openapi::schema::Schema>,
        )>,
    ) {
        use utoipa::PartialSchema;
        schemas.push(("PinGroup".into(), PinGroup::schema()));
        <PinGroup as utoipa::ToSchema>::schemas(schemas);
    }
}

/// The cloth as a rectangular grid of particles at thread crossings (§1).
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClothSpec {
    /// `[nu, nv]`: particles along `u` and along `v`.
    pub grid: [u32; 2],
    /// `[length along u, length along v]` in metres.
    pub size: [f64; 2],
    /// Position of particle `(0, 0)`.
    #[serde(default)]
    pub origin: [f64; 3],
    /// Warp direction; default `[1, 0, 0]`.
    #[serde(default)]
    pub u: Option<[f64; 3]>,
    /// Weft direction; default `[0, 1, 0]`.
    #[serde(default)]
    pub v: Option<[f64; 3]>,
    /// Particles held in place (`[i, j]`) or moving with a group.
    #[serde(default)]
    pub pinned: Vec<PinEntry>,
    /// The distance layers of cloth keep from each other, metres; default
    /// a tenth of the finer grid spacing, at most a quarter of it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thickness: Option<f64>,
    /// Whether the cloth is kept from passing through itself (default:
    /// on). Patches that cannot meet themselves cost a refit and no pair
    /// (ARCHITECTURE.md, "Self-collision").
    #[serde(default = "yes")]
    pub self_collision: bool,
}

/// Solver settings; every field has a default.
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverSpec {
    /// Fixed step in seconds, or `"adaptive"`.
    #[serde(default)]
    pub dt: TimeStep,
    /// Relative residual at which the modified PCG stops (with
    /// `stopping: "error"`, at the latest).
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// When the modified PCG stops: `"error"` (default) as soon as its
    /// error is a tenth of the step's own, or the residual meets
    /// `tolerance`; `"residual"` only the latter (reference solutions).
    #[serde(default)]
    pub stopping: StoppingRule,
    /// Iteration cap of the modified PCG.
    #[serde(default = "default_max_iterations")]
    pub max_iterations: u32,
    /// Which preconditioner the PCG uses.
    #[serde(default)]
    pub preconditioner: PreconditionerKind,
    /// The time integrator: `"euler"` (backward Euler) or `"bdf2"`.
    #[serde(default)]
    pub integrator: IntegratorKind,
    /// With `dt: "adaptive"`: the position error one frame may add,
    /// metres (RMS over the cloth's free particles; default 1 mm). Each
    /// step's embedded estimate must stay within its share of it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<f64>,
    /// Start each solve from the previous step's velocity change.
    #[serde(default = "yes")]
    pub warm_start: bool,
    /// Run the collision stage (a benchmark may turn it off).
    #[serde(default = "yes")]
    pub collision: bool,
}

impl Default for SolverSpec {
    fn default() -> Self {
        Self {
            dt: TimeStep::default(),
            tolerance: default_tolerance(),
            stopping: StoppingRule::default(),
            max_iterations: default_max_iterations(),
            preconditioner: PreconditionerKind::default(),
            integrator: IntegratorKind::default(),
            error: None,
            warm_start: true,
            collision: true,
        }
    }
}

fn default_tolerance() -> f64 {
    1e-5
}
fn default_max_iterations() -> u32 {
    1000
}
fn yes() -> bool {
    true
}

/// Preconditioners the PCG can use (method.md §2).
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PreconditionerKind {
    /// Inverse of the scalar diagonal.
    Jacobi,
    /// Inverse of each particle's 3x3 diagonal block.
    BlockJacobi,
    /// Exact solves along every warp and weft line, in a symmetric
    /// alternating Gauss–Seidel sweep.
    #[default]
    Lines,
    /// A multigrid V-cycle: Galerkin coarse levels of the prefiltered
    /// operator, line relaxation on every level, a direct coarsest solve.
    Multigrid,
}

impl PreconditionerKind {
    /// Every preconditioner.
    pub const ALL: [PreconditionerKind; 4] = [
        PreconditionerKind::Jacobi,
        PreconditionerKind::BlockJacobi,
        PreconditionerKind::Lines,
        PreconditionerKind::Multigrid,
    ];

    /// The name a spec uses.
    pub fn name(self) -> &'static str {
        match self {
            PreconditionerKind::Jacobi => "jacobi",
            PreconditionerKind::BlockJacobi => "block_jacobi",
            PreconditionerKind::Lines => "lines",
            PreconditionerKind::Multigrid => "multigrid",
        }
    }
}

impl std::str::FromStr for PreconditionerKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|k| k.name()).collect();
                format!(
                    "unknown preconditioner {s:?}; expected one of {}",
                    names.join(", ")
                )
            })
    }
}

/// Time integrators (method.md §2, §6).
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IntegratorKind {
    /// Backward (implicit) Euler: first order, damps slow motion; the
    /// default while BDF2 still overstretches in two stress cases
    /// (docs/benchmarks.md).
    #[default]
    Euler,
    /// The two-step backward differentiation formula (Choi & Ko 2002):
    /// second order, the same system to solve.
    Bdf2,
}

impl IntegratorKind {
    /// Every integrator.
    pub const ALL: [IntegratorKind; 2] = [IntegratorKind::Euler, IntegratorKind::Bdf2];

    /// The name in specs.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::Euler => "euler",
            IntegratorKind::Bdf2 => "bdf2",
        }
    }
}

impl std::str::FromStr for IntegratorKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown integrator {s:?}; expected euler or bdf2"))
    }
}

/// When the modified PCG stops (docs/benchmarks.md: a residual tolerance
/// far below the step's own error buys nothing).
#[cfg_attr(feature = "schema", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StoppingRule {
    /// As soon as the solver's error in the step's positions is a tenth of
    /// the last step's local time error, or the residual meets the
    /// tolerance, whichever comes first.
    #[default]
    Error,
    /// Only when the residual meets the tolerance.
    Residual,
}

/// Which Jacobian the force terms produce.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum JacobianMode {
    /// `-df/dx` made symmetric positive semi-definite (what the solver uses).
    #[default]
    Solver,
    /// The exact derivatives, indefinite and (for damping) unsymmetric; for
    /// finite-difference tests.
    Exact,
}

/// A fixed step or the adaptive controller.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeStep {
    /// Fixed step size in seconds (rounded so frames fall on steps).
    Fixed(f64),
    /// Steps halve on trouble and grow back when the solve is easy.
    Adaptive,
}

impl Default for TimeStep {
    fn default() -> Self {
        TimeStep::Fixed(1.0 / 240.0)
    }
}

impl Serialize for TimeStep {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            TimeStep::Fixed(dt) => s.serialize_f64(*dt),
            TimeStep::Adaptive => s.serialize_str("adaptive"),
        }
    }
}

impl<'de> Deserialize<'de> for TimeStep {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = TimeStep;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a step in seconds or \"adaptive\"")
            }
            fn visit_f64<E: serde::de::Error>(self, x: f64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(x))
            }
            fn visit_u64<E: serde::de::Error>(self, x: u64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(x as f64))
            }
            fn visit_i64<E: serde::de::Error>(self, x: i64) -> Result<TimeStep, E> {
                Ok(TimeStep::Fixed(x as f64))
            }
            fn visit_str<E: serde::de::Error>(self, s: &str) -> Result<TimeStep, E> {
                match s {
                    "adaptive" => Ok(TimeStep::Adaptive),
                    other => Err(E::invalid_value(serde::de::Unexpected::Str(other), &self)),
                }
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(feature = "schema")]
impl utoipa::PartialSchema for TimeStep {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{ObjectBuilder, OneOfBuilder, Type};
        OneOfBuilder::new()
            .item(
                ObjectBuilder::new()
                    .schema_type(Type::Number)
                    .exclusive_minimum(Some(0.0))
                    .description(Some("Fixed step in seconds")),
            )
            .item(
                ObjectBuilder::new()
                    .schema_type(Type::String)
                    .enum_values(Some(["adaptive"]))
                    .description(Some(
                        "Steps halve on trouble and grow back when the solve is easy",
                    )),
            )
            .into()
    }
}

#[cfg(feature = "schema")]
impl utoipa::ToSchema for TimeStep {}
