//! The OpenAPI document, generated from the handlers' annotations and the
//! API types (`utoipa`), and the job spec's JSON Schema, generated from the
//! core's serde types with the same derive, both with the spec's per-field
//! rules (`spec_schema`); and the two routes that serve them.
//!
//! The document describes the server that serves it ([`Profile`]): with API
//! keys, the `/v1` operations and `/metrics` require the bearer scheme and
//! may answer `401`; without, they name no security and never do; the
//! spec's `duration` is bounded by `--max-duration`. `api/openapi.yaml` and
//! `api/job.schema.json` are the documents of a server with the default
//! flags, checked in; a test fails when they drift (regenerate with
//! `drapery openapi --write api`).

use axum::extract::State;
use axum::http::header;
use axum::response::{IntoResponse, Response};
use clap::Parser;
use serde_json::Value;
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi, ToSchema};

use super::spec_schema::constrain;
use crate::cli::{Cli, Command};
use crate::service::api;
use crate::service::config::Config;
use crate::service::error;
use crate::service::ops;
use crate::service::protocol;
use crate::service::state::AppState;
use crate::service::stream;
use crate::service::view;

/// What the document depends on in the server's configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    /// The server has API keys.
    pub keys: bool,
    /// `--max-duration`, seconds.
    pub max_duration: f64,
}

impl Profile {
    /// The profile of a server with `config`.
    pub fn of(config: &Config) -> Self {
        Self {
            keys: config.keys.enabled(),
            max_duration: config.limits.max_duration,
        }
    }
}

impl Default for Profile {
    /// `drapery serve` with no flags (the checked-in documents).
    fn default() -> Self {
        let max_duration = match Cli::try_parse_from(["drapery", "serve"]).map(|c| c.command) {
            Ok(Command::Serve(args)) => args.max_duration,
            Ok(_) | Err(_) => 600.0,
        };
        Self {
            keys: false,
            max_duration,
        }
    }
}

#[derive(OpenApi)]
#[openapi(
    info(
        title = "drapery",
        description = "Cloth simulation service: submit a job spec, watch its frames stream over WebSocket, download the animation.",
        license(name = "MIT OR Apache-2.0"),
    ),
    paths(
        api::submit, api::list, api::get, api::cancel, api::frame, api::result,
        stream::stream, ops::healthz, ops::readyz, ops::metrics,
    ),
    components(schemas(
        view::Job, view::JobList, error::ErrorResponse, api::FrameJson,
        protocol::StreamMessage,
    )),
    modifiers(&Security),
    tags(
        (name = "jobs", description = "Submit, list, inspect and cancel jobs"),
        (name = "frames", description = "Frames: one at a time, streamed, or the whole animation"),
        (name = "operations", description = "Health and metrics"),
    )
)]
struct ApiDoc;

struct Security;

impl Modify for Security {
    fn modify(&self, doc: &mut utoipa::openapi::OpenApi) {
        if let Some(c) = doc.components.as_mut() {
            c.add_security_scheme(
                "api_key",
                SecurityScheme::Http(
                    HttpBuilder::new()
                        .scheme(HttpAuthScheme::Bearer)
                        .description(Some(
                            "Required when the server has API keys (--api-key); a key sees only its own jobs. Where a client cannot set headers (browser WebSocket, download links), `?access_token=KEY` is accepted instead.",
                        ))
                        .build(),
                ),
            );
        }
    }
}

/// The document as the annotations make it, before the profile.
pub(super) fn base() -> utoipa::openapi::OpenApi {
    let mut doc = ApiDoc::openapi();
    doc.info.version = env!("CARGO_PKG_VERSION").to_owned();
    doc
}

/// An example job for `POST /v1/jobs` (a schema-driven client's first
/// valid spec): the sphere drape of `examples/scenes/`.
const EXAMPLE_JOB: &str = include_str!("../../../examples/scenes/sphere-drape-30.json");

/// The OpenAPI document of a server with `profile`.
pub fn document(profile: Profile) -> utoipa::openapi::OpenApi {
    let mut doc = serde_json::to_value(base()).unwrap_or_default();
    if let Some(schemas) = doc
        .pointer_mut("/components/schemas")
        .and_then(Value::as_object_mut)
    {
        constrain(schemas, profile.max_duration);
    }
    if let (Some(body), Ok(example)) = (
        doc.pointer_mut("/paths/~1v1~1jobs/post/requestBody/content/application~1json"),
        serde_json::from_str::<Value>(EXAMPLE_JOB),
    ) && let Some(o) = body.as_object_mut()
    {
        o.insert("example".into(), example);
    }
    if !profile.keys {
        without_security(&mut doc);
    }
    serde_json::from_value(doc).unwrap_or_else(|_| base())
}

/// A server without keys: no operation names security or answers `401`.
fn without_security(doc: &mut Value) {
    if let Some(paths) = doc.get_mut("paths").and_then(Value::as_object_mut) {
        for item in paths.values_mut().filter_map(Value::as_object_mut) {
            for op in item.values_mut().filter_map(Value::as_object_mut) {
                op.remove("security");
                if let Some(r) = op.get_mut("responses").and_then(Value::as_object_mut) {
                    r.remove("401");
                }
            }
        }
    }
    if let Some(c) = doc.get_mut("components").and_then(Value::as_object_mut) {
        c.remove("securitySchemes");
    }
}

/// The OpenAPI document of a default server as JSON text.
pub fn json() -> String {
    document(Profile::default())
        .to_pretty_json()
        .unwrap_or_default()
}

/// The OpenAPI document of a default server as YAML (`api/openapi.yaml`).
pub fn yaml() -> String {
    document(Profile::default()).to_yaml().unwrap_or_default()
}

/// `GET /openapi.json`: this server's OpenAPI document.
pub async fn serve_document(State(state): State<AppState>) -> Response {
    let doc = document(Profile::of(&state.config));
    (
        [(header::CONTENT_TYPE, "application/json")],
        doc.to_pretty_json().unwrap_or_default(),
    )
        .into_response()
}

/// `GET /job.schema.json`: this server's job spec JSON Schema.
pub async fn serve_job_schema(State(state): State<AppState>) -> Response {
    (
        [(header::CONTENT_TYPE, "application/schema+json")],
        job_schema_for(Profile::of(&state.config)),
    )
        .into_response()
}

/// The job spec's JSON Schema of a default server, `api/job.schema.json`.
pub fn job_schema() -> String {
    job_schema_for(Profile::default())
}

/// The job spec's JSON Schema (draft 2020-12): the `Spec` schema with every
/// schema it uses under `$defs`, with the per-field rules.
fn job_schema_for(profile: Profile) -> String {
    use drapery_sim::spec::Spec;
    let mut defs = Vec::new();
    <Spec as ToSchema>::schemas(&mut defs);
    let mut def_map = serde_json::Map::new();
    def_map.insert(
        "Spec".into(),
        serde_json::to_value(<Spec as utoipa::PartialSchema>::schema()).unwrap_or_default(),
    );
    for (name, schema) in defs {
        def_map.insert(name, serde_json::to_value(schema).unwrap_or_default());
    }
    constrain(&mut def_map, profile.max_duration);
    let mut root = def_map.remove("Spec").unwrap_or_default();
    if let Some(o) = root.as_object_mut() {
        o.insert(
            "$schema".into(),
            "https://json-schema.org/draft/2020-12/schema".into(),
        );
        o.insert(
            "$id".into(),
            "https://drapery.dev/schemas/job.schema.json".into(),
        );
        o.insert("title".into(), "drapery job spec (version 1)".into());
        o.insert("$defs".into(), serde_json::Value::Object(def_map));
    }
    let text = serde_json::to_string_pretty(&root).unwrap_or_default();
    text.replace("#/components/schemas/", "#/$defs/") + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checked_in(name: &str) -> String {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("api")
            .join(name);
        std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()))
    }

    #[test]
    fn checked_in_openapi_matches_the_code() {
        assert!(
            checked_in("openapi.yaml") == yaml(),
            "api/openapi.yaml is stale: run `cargo run -- openapi --write api`"
        );
    }

    #[test]
    fn checked_in_job_schema_matches_the_code() {
        assert!(
            checked_in("job.schema.json") == job_schema(),
            "api/job.schema.json is stale: run `cargo run -- openapi --write api`"
        );
    }

    /// The drift the issue found, each now stated by the document: both
    /// encodings of a frame, the downloads' real types, `limit` 1..=500,
    /// `format` an enum, fixed array lengths, `415`/`503` on submission, and
    /// security only on a server with keys.
    #[test]
    fn the_openapi_document_matches_the_server() {
        let doc = |keys| {
            serde_json::to_value(document(Profile {
                keys,
                max_duration: 600.0,
            }))
            .expect("JSON")
        };
        let open = doc(false);
        let paths = &open["paths"];
        let frame = &paths["/v1/jobs/{id}/frames/{n}"]["get"]["responses"]["200"]["content"];
        assert!(
            frame.get("application/json").is_some()
                && frame.get("application/octet-stream").is_some()
        );
        let result = &paths["/v1/jobs/{id}/result"]["get"];
        for t in [
            "application/zip",
            "application/octet-stream",
            "model/gltf-binary",
        ] {
            assert!(
                result["responses"]["200"]["content"].get(t).is_some(),
                "{t}"
            );
        }
        let params = |op: &serde_json::Value, name: &str| {
            op["parameters"]
                .as_array()
                .and_then(|ps| ps.iter().find(|p| p["name"] == name).cloned())
                .unwrap_or_default()
        };
        let limit = params(&paths["/v1/jobs"]["get"], "limit");
        assert_eq!(
            (
                limit["schema"]["minimum"].as_f64(),
                limit["schema"]["maximum"].as_f64()
            ),
            (Some(1.0), Some(500.0))
        );
        let format = params(result, "format");
        assert!(format.to_string().contains("\"glb\""), "{format}");
        let submit = &paths["/v1/jobs"]["post"]["responses"];
        for status in ["201", "400", "408", "413", "415", "422", "429", "503"] {
            assert!(submit.get(status).is_some(), "{status}");
        }
        assert!(
            open.to_string().find("\"security\"").is_none(),
            "no keys: no security"
        );
        let grid = &open["components"]["schemas"]["ClothSpec"]["properties"]["grid"];
        assert_eq!(
            (grid["minItems"].as_u64(), grid["maxItems"].as_u64()),
            (Some(2), Some(2))
        );
        let keyed = doc(true);
        assert_eq!(
            keyed["paths"]["/v1/jobs"]["get"]["security"],
            serde_json::json!([{"api_key": []}])
        );
        assert!(keyed["paths"]["/healthz"]["get"].get("security").is_none());
    }

    /// The schema accepts what the spec parser accepts: every canonical
    /// scene and the project's examples validate against it.
    #[test]
    fn job_schema_is_a_schema_that_names_the_spec_fields() {
        let v: serde_json::Value = serde_json::from_str(&job_schema()).expect("JSON");
        let props = &v["properties"];
        for field in [
            "cloth",
            "material",
            "obstacles",
            "duration",
            "fps",
            "solver",
        ] {
            assert!(props.get(field).is_some(), "missing {field}: {v}");
        }
        assert_eq!(v["additionalProperties"], serde_json::json!(false));
        assert!(!job_schema().contains("#/components/"));
    }
}
