//! The job spec's per-field rules, written into its JSON Schema: array
//! lengths (`grid` has 2 numbers, a point 3), ranges (`size` in (0, 1000]
//! m, coordinates within ±10⁶ m, material parameters), enums (the material
//! presets). These are the bounds `Spec::validate` checks one field at a
//! time (`sim/src/spec/validate/`), so a value outside them is refused and
//! a value inside passes that field's check.
//!
//! What JSON Schema cannot say stays with validation and its `422`: rules
//! across fields (a pin inside the grid, `nu * nv` within
//! `--max-particles`, `duration * fps` frames, steps within the limit, one
//! shape per obstacle, `u` perpendicular to `v`, a unit quaternion, a mesh
//! whose indices exist), and the per-job budgets.
//!
//! NOTE: the rules are set by JSON pointer into the schemas the core's
//! derive produces; a test checks every pointer still names a property, so
//! a renamed field fails here rather than silently losing its rule.

use serde_json::{Map, Value, json};

/// Largest coordinate magnitude (`MAX_COORD` of the core's validation).
const MAX_COORD: f64 = 1.0e6;
/// Largest cloth side, metres.
const MAX_CLOTH_SIDE: f64 = 1.0e3;
/// Largest frame rate.
const MAX_FPS: f64 = 1.0e4;
/// Largest integer a `u32` field holds.
const U32_MAX: f64 = 4_294_967_295.0;

/// `n` numbers, each within `[lo, hi]`.
fn numbers(n: usize, lo: f64, hi: f64) -> Value {
    json!({"minItems": n, "maxItems": n,
           "items": {"type": "number", "format": "double", "minimum": lo, "maximum": hi}})
}

/// A point (or vector) in metres.
fn point() -> Value {
    numbers(3, -MAX_COORD, MAX_COORD)
}

/// `n` indices (`u32`).
fn indices(n: usize) -> Value {
    json!({"minItems": n, "maxItems": n,
           "items": {"type": "integer", "format": "int64", "minimum": 0, "maximum": U32_MAX}})
}

/// `(0, hi]`.
fn positive(hi: f64) -> Value {
    json!({"exclusiveMinimum": 0.0, "maximum": hi})
}

/// `[0, hi]`.
fn non_negative(hi: f64) -> Value {
    json!({"minimum": 0.0, "maximum": hi})
}

/// `(schema, property, rules)`: each rule is merged into the property.
fn rules(max_duration: f64) -> Vec<(&'static str, &'static str, Value)> {
    vec![
        ("Spec", "name", json!({"maxLength": 200})),
        ("Spec", "gravity", numbers(3, -1000.0, 1000.0)),
        ("Spec", "duration", positive(max_duration)),
        ("Spec", "fps", positive(MAX_FPS)),
        (
            "ClothSpec",
            "grid",
            json!({"minItems": 2, "maxItems": 2,
                   "items": {"type": "integer", "format": "int64", "minimum": 2, "maximum": U32_MAX}}),
        ),
        ("ClothSpec", "size", {
            let mut v = numbers(2, 0.0, MAX_CLOTH_SIDE);
            v["items"] = json!({"type": "number", "format": "double",
                                "exclusiveMinimum": 0.0, "maximum": MAX_CLOTH_SIDE});
            v
        }),
        ("ClothSpec", "origin", point()),
        ("ClothSpec", "u", point()),
        ("ClothSpec", "v", point()),
        ("PinGroup", "particles", json!({"items": indices(2)})),
        ("MaterialParams", "density", positive(100.0)),
        ("MaterialParams", "stretch", positive(1.0e9)),
        ("MaterialParams", "shear", non_negative(1.0e9)),
        ("MaterialParams", "bend", non_negative(1.0e3)),
        ("MaterialParams", "bend_threshold", non_negative(1.0e3)),
        ("MaterialParams", "shear_threshold", non_negative(1.0e9)),
        ("MaterialParams", "damping", non_negative(10.0)),
        ("MaterialParams", "air_drag", non_negative(1.0e4)),
        ("Obstacle", "friction", non_negative(10.0)),
        ("Obstacle", "offset", non_negative(1.0)),
        ("Sphere", "center", point()),
        ("Sphere", "radius", positive(MAX_COORD)),
        ("BoxShape", "center", point()),
        ("BoxShape", "size", {
            let mut v = numbers(3, 0.0, MAX_COORD);
            v["items"] = json!({"type": "number", "format": "double",
                                "exclusiveMinimum": 0.0, "maximum": MAX_COORD});
            v
        }),
        ("Plane", "point", point()),
        ("Plane", "normal", point()),
        ("Cylinder", "center", point()),
        ("Cylinder", "axis", point()),
        ("Cylinder", "radius", positive(MAX_COORD)),
        ("Cylinder", "height", positive(MAX_COORD)),
        ("MeshSource", "vertices", json!({"items": point()})),
        ("MeshSource", "triangles", json!({"items": indices(3)})),
        ("Motion", "velocity", point()),
        ("Motion", "angular_velocity", point()),
        ("Motion", "pivot", point()),
        ("Keyframe", "translation", point()),
        (
            "Keyframe",
            "rotation",
            json!({"minItems": 4, "maxItems": 4}),
        ),
        ("SolverSpec", "tolerance", positive(0.5)),
        ("SolverSpec", "error", positive(1.0)),
        (
            "SolverSpec",
            "max_iterations",
            json!({"minimum": 1, "maximum": 1_000_000}),
        ),
    ]
}

/// The presets a `material` name may be.
fn presets() -> Vec<&'static str> {
    drapery_sim::spec::PRESETS.iter().map(|(n, _)| *n).collect()
}

/// Writes the rules into `schemas` (the spec's schemas by name, as
/// `components.schemas` or `$defs` hold them); returns the pointers that
/// named nothing.
pub fn constrain(schemas: &mut Map<String, Value>, max_duration: f64) -> Vec<String> {
    let mut missing = Vec::new();
    for (schema, property, rule) in rules(max_duration) {
        match schemas
            .get_mut(schema)
            .and_then(|s| s.pointer_mut(&format!("/properties/{property}")))
        {
            Some(target) => merge(target, rule),
            None => missing.push(format!("{schema}.{property}")),
        }
    }
    match schemas
        .get_mut("MaterialSpec")
        .and_then(|s| s.pointer_mut("/oneOf/0"))
    {
        Some(name) => merge(name, json!({"enum": presets()})),
        None => missing.push("MaterialSpec.oneOf[0]".into()),
    }
    match schemas
        .get_mut("TimeStep")
        .and_then(|s| s.pointer_mut("/oneOf/0"))
    {
        Some(dt) => {
            if let Some(o) = dt.as_object_mut() {
                o.remove("exclusiveMinimum");
            }
            merge(dt, json!({"minimum": 1e-7, "maximum": 1.0}));
        }
        None => missing.push("TimeStep.oneOf[0]".into()),
    }
    missing
}

/// Merges `rule` into `target`. An optional field's schema (`oneOf` of
/// null and the value, or a `type` list with `null`) gets the rule on the
/// value's side, so `null` stays allowed.
fn merge(target: &mut Value, rule: Value) {
    if let Some(alternatives) = target.get_mut("oneOf").and_then(Value::as_array_mut) {
        for alt in alternatives {
            if alt.get("type") != Some(&json!("null")) {
                merge(alt, rule.clone());
            }
        }
        return;
    }
    if let (Some(t), Some(r)) = (target.as_object_mut(), rule.as_object()) {
        for (k, v) in r {
            match (t.get_mut(k), v) {
                (Some(existing @ Value::Object(_)), Value::Object(_)) => merge(existing, v.clone()),
                _ => {
                    t.insert(k.clone(), v.clone());
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rule_names_a_property_of_the_spec_schemas() {
        let doc = serde_json::to_value(super::super::document::base()).expect("JSON");
        let mut schemas = doc["components"]["schemas"]
            .as_object()
            .cloned()
            .expect("schemas");
        assert_eq!(constrain(&mut schemas, 600.0), Vec::<String>::new());
        assert_eq!(schemas["ClothSpec"]["properties"]["grid"]["maxItems"], 2);
        assert_eq!(
            schemas["MaterialSpec"]["oneOf"][0]["enum"]
                .as_array()
                .map(Vec::len),
            Some(drapery_sim::spec::PRESETS.len())
        );
    }
}
