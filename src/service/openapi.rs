//! The OpenAPI document, generated from the handlers' annotations and the
//! API types (`utoipa`), and the job spec's JSON Schema, generated from the
//! core's serde types with the same derive; and the two routes that serve
//! them. `api/openapi.yaml` and `api/job.schema.json` are these, checked
//! in; a test fails when they drift (regenerate with
//! `drapery openapi --write api`).

use axum::http::header;
use axum::response::{IntoResponse, Response};
use utoipa::openapi::security::{HttpAuthScheme, HttpBuilder, SecurityScheme};
use utoipa::{Modify, OpenApi, ToSchema};

use super::{api, error, ops, protocol, stream, view};

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

/// The OpenAPI document.
pub fn document() -> utoipa::openapi::OpenApi {
    let mut doc = ApiDoc::openapi();
    doc.info.version = env!("CARGO_PKG_VERSION").to_owned();
    doc
}

/// The OpenAPI document as JSON text (what `/openapi.json` serves).
pub fn json() -> String {
    document().to_pretty_json().unwrap_or_default()
}

/// The OpenAPI document as YAML (`api/openapi.yaml`).
pub fn yaml() -> String {
    document().to_yaml().unwrap_or_default()
}

/// `GET /openapi.json`: the OpenAPI document.
pub async fn serve_document() -> Response {
    ([(header::CONTENT_TYPE, "application/json")], json()).into_response()
}

/// `GET /job.schema.json`: the job spec's JSON Schema.
pub async fn serve_job_schema() -> Response {
    (
        [(header::CONTENT_TYPE, "application/schema+json")],
        job_schema(),
    )
        .into_response()
}

/// The job spec's JSON Schema (draft 2020-12), `api/job.schema.json`:
/// the `Spec` schema with every schema it uses under `$defs`.
pub fn job_schema() -> String {
    use drapery_sim::spec::Spec;
    let mut defs = Vec::new();
    <Spec as ToSchema>::schemas(&mut defs);
    let mut root =
        serde_json::to_value(<Spec as utoipa::PartialSchema>::schema()).unwrap_or_default();
    let mut def_map = serde_json::Map::new();
    for (name, schema) in defs {
        def_map.insert(name, serde_json::to_value(schema).unwrap_or_default());
    }
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
