//! Operations endpoints, in process: health, readiness, the served
//! OpenAPI document; and the router called directly, without a listener.

mod support;

use serde_json::json;
use support::*;

/// Health, readiness, and the OpenAPI document the server serves is the
/// one checked in as `api/openapi.yaml`.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn operations_endpoints_and_served_openapi_match_the_checked_in_file() {
    let s = Service::start(&data_dir("ops"), &[]).await;
    let http = client();
    assert_eq!(
        http.get(s.url("/healthz"))
            .send()
            .await
            .expect("request")
            .status(),
        200
    );
    let ready = get_json(&s, "/readyz").await;
    assert_eq!(ready["status"], json!("ready"));
    let served: utoipa::openapi::OpenApi = http
        .get(s.url("/openapi.json"))
        .send()
        .await
        .expect("request")
        .json()
        .await
        .expect("an OpenAPI document");
    let checked_in = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("api/openapi.yaml"),
    )
    .expect("api/openapi.yaml");
    assert!(
        served.to_yaml().expect("YAML") == checked_in,
        "the served document differs from api/openapi.yaml: run `cargo run -- openapi --write api`"
    );
    let schema = get_json(&s, "/job.schema.json").await;
    assert_eq!(
        schema["$schema"],
        json!("https://json-schema.org/draft/2020-12/schema")
    );
    s.stop().await;
}

/// `app(state)` is the whole HTTP surface without a listener or workers:
/// a request through the router alone gets the answer a client would.
#[tokio::test]
async fn the_router_answers_without_a_listener() {
    use axum::body::{Body, to_bytes};
    use axum::http::{Request, StatusCode, header};
    use clap::Parser;
    use drapery::cli::{Cli, Command};
    use drapery::service::{AppState, Config, app, open_store};
    use tower::ServiceExt;

    let data = data_dir("router");
    let state = |flags: &[&str]| {
        let store = store_flags(&data);
        let argv = ["drapery", "serve", "--data"]
            .into_iter()
            .chain([data.to_str().expect("UTF-8")])
            .chain(store.iter().map(String::as_str))
            .chain(flags.iter().copied());
        let Command::Serve(args) = Cli::try_parse_from(argv).expect("flags").command else {
            unreachable!("parsed as serve");
        };
        let config = Config::from_args(&args).expect("config");
        // A PostgreSQL store blocks as it connects: off the executor.
        let store = std::thread::spawn(move || open_store(&args).expect("store"))
            .join()
            .expect("joined");
        AppState::new(config, store)
    };
    let json_of = |body: Body| async move {
        let bytes = to_bytes(body, 1 << 20).await.expect("a body");
        serde_json::from_slice::<serde_json::Value>(&bytes).expect("JSON")
    };

    let open = app(state(&[]));
    let r = open
        .clone()
        .oneshot(
            Request::get("/healthz")
                .body(Body::empty())
                .expect("request"),
        )
        .await
        .expect("an answer");
    assert_eq!(r.status(), StatusCode::OK);
    assert_eq!(json_of(r.into_body()).await, json!({"status": "ok"}));
    let r = open
        .oneshot(
            Request::post("/v1/jobs")
                .header(header::CONTENT_TYPE, "application/json")
                .body(Body::from("{\"cloth\": "))
                .expect("request"),
        )
        .await
        .expect("an answer");
    assert_eq!(r.status(), StatusCode::BAD_REQUEST);
    assert_eq!(
        json_of(r.into_body()).await["error"]["code"],
        json!("malformed_json")
    );

    let gated = app(state(&["--api-key", "alice:alice-secret-1"]));
    let r = gated
        .oneshot(
            Request::get("/v1/jobs")
                .body(Body::empty())
                .expect("request"),
        )
        .await
        .expect("an answer");
    assert_eq!(r.status(), StatusCode::UNAUTHORIZED);
    assert_eq!(
        r.headers()
            .get(header::WWW_AUTHENTICATE)
            .and_then(|v| v.to_str().ok()),
        Some("Bearer")
    );
    assert_eq!(
        json_of(r.into_body()).await["error"]["code"],
        json!("unauthorized")
    );
}
