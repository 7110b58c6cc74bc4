//! Strict input and one error envelope (issue 17), in process over a real
//! socket: trailing data, shape errors with their path, whole floats,
//! `415` for bodies that are not JSON, the envelope on every refusal,
//! cross-origin WebSockets.

mod support;

use serde_json::{Value, json};
use support::*;

/// Posts `body` as JSON text.
async fn post_text(s: &Service, body: String) -> reqwest::Response {
    client()
        .post(s.url("/v1/jobs"))
        .header("content-type", "application/json")
        .body(body)
        .send()
        .await
        .expect("request")
}

/// `{...}xx` was accepted (201): anything after the document is now a
/// malformed document.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn trailing_data_after_the_json_is_refused() {
    let s = Service::start(&data_dir("trailing"), &["--workers", "1"]).await;
    let r = post_text(&s, format!("{}xx", hanging(4, 0.1))).await;
    assert_eq!(r.status(), 400);
    let e = error_of(r).await;
    assert_eq!(e["code"], json!("malformed_json"));
    assert!(
        e["message"]
            .as_str()
            .is_some_and(|m| m.contains("trailing characters")),
        "{e}"
    );
    let r = post_text(&s, format!("{}\n", hanging(4, 0.1))).await;
    assert_eq!(r.status(), 201, "white space may follow");
    s.stop().await;
}

/// `grid: [20, 20, 20]` was a 400 "malformed JSON" without a path: it is
/// JSON, of the wrong shape, so 422 at `cloth.grid`; and `976.0` fills an
/// integer field.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shape_errors_are_422_at_their_path_and_whole_floats_are_integers() {
    let s = Service::start(&data_dir("shape"), &["--workers", "1"]).await;
    let mut spec = hanging(4, 0.1);
    spec["cloth"]["grid"] = json!([20, 20, 20]);
    let r = post_text(&s, spec.to_string()).await;
    assert_eq!(r.status(), 422);
    let e = error_of(r).await;
    assert_eq!(e["code"], json!("invalid_spec"));
    assert_eq!(e["path"], json!("cloth.grid"));

    let mut spec = hanging(4, 0.1);
    spec["cloth"]["grid"] = json!([4.0, 4.0]);
    spec["cloth"]["pinned"] = json!([[0.0, 0], [3, 0.0]]);
    let r = post_text(&s, spec.to_string()).await;
    assert_eq!(r.status(), 201, "{}", r.text().await.unwrap_or_default());

    let mut spec = hanging(4, 0.1);
    spec["cloth"]["grid"] = json!([4.5, 4]);
    let r = post_text(&s, spec.to_string()).await;
    assert_eq!(r.status(), 422);
    assert_eq!(error_of(r).await["path"], json!("cloth.grid[0]"));
    s.stop().await;
}

/// A body that is not `application/json` (none, `text/plain`, a form) was
/// accepted: a web page could post jobs cross-origin without a preflight.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_body_that_is_not_json_gets_415() {
    let s = Service::start(&data_dir("media"), &["--workers", "1"]).await;
    let spec = hanging(4, 0.1).to_string();
    for content_type in [
        None,
        Some("text/plain"),
        Some("application/x-www-form-urlencoded"),
        Some("multipart/form-data; boundary=x"),
    ] {
        let mut req = client().post(s.url("/v1/jobs")).body(spec.clone());
        if let Some(t) = content_type {
            req = req.header("content-type", t);
        }
        let r = req.send().await.expect("request");
        assert_eq!(r.status(), 415, "{content_type:?}");
        assert_eq!(error_code(r).await, "unsupported_media_type");
    }
    let r = client()
        .post(s.url("/v1/jobs"))
        .header("content-type", "application/json; charset=utf-8")
        .body(spec)
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 201);
    s.stop().await;
}

/// Every refusal the issue found in plain text, and the router's own
/// `404` and `405`, answer `{"error": {...}}`, naming the parameter.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_error_is_in_the_envelope() {
    let s = Service::start(&data_dir("envelope"), &["--workers", "1"]).await;
    let id = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let http = client();
    let cases = [
        ("/v1/jobs?limit=-1".to_owned(), 400, Some("limit")),
        ("/v1/jobs?limit=501".to_owned(), 400, Some("limit")),
        (format!("/v1/jobs/{id}/frames/abc"), 404, Some("n")),
        (format!("/v1/jobs/{id}/frames/-1"), 404, Some("n")),
        (format!("/v1/jobs/{id}/stream?from=-1"), 400, Some("from")),
        (
            format!("/v1/jobs/{id}/result?format=obj&format=glb"),
            400,
            Some("format"),
        ),
        (format!("/v1/jobs/{id}/stream"), 400, None),
        ("/v1/nothing".to_owned(), 404, None),
        ("/no/such/page".to_owned(), 404, None),
    ];
    for (path, status, param) in cases {
        let r = http.get(s.url(&path)).send().await.expect("request");
        assert_eq!(r.status(), status, "{path}");
        assert!(
            r.headers()
                .get("content-type")
                .and_then(|v| v.to_str().ok())
                .is_some_and(|t| t.starts_with("application/json")),
            "{path}"
        );
        let e = error_of(r).await;
        assert!(
            e["code"].is_string() && e["message"].is_string(),
            "{path}: {e}"
        );
        if let Some(p) = param {
            assert_eq!(e["path"], json!(p), "{path}: {e}");
        }
    }
    let r = http.put(s.url("/v1/jobs")).send().await.expect("request");
    assert_eq!(r.status(), 405);
    let allow = r
        .headers()
        .get("allow")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("")
        .to_owned();
    assert!(allow.contains("GET") && allow.contains("POST"), "{allow}");
    assert_eq!(error_code(r).await, "method_not_allowed");
    s.stop().await;
}

/// A WebSocket from a page of another origin is refused (`403`) unless
/// `--cors-origin` lists it; the server's own origin (the viewer) and
/// clients that send no `Origin` are served.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cross_origin_websocket_is_refused_unless_listed() {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;

    async fn open(url: &str, origin: Option<&str>) -> Result<(), u16> {
        let mut req = url.into_client_request().expect("a request");
        if let Some(o) = origin {
            req.headers_mut()
                .insert("origin", o.parse().expect("a header value"));
        }
        match tokio_tungstenite::connect_async(req).await {
            Ok(_) => Ok(()),
            Err(tokio_tungstenite::tungstenite::Error::Http(r)) => Err(r.status().as_u16()),
            Err(e) => panic!("{e}"),
        }
    }

    let s = Service::start(&data_dir("origin"), &["--workers", "1"]).await;
    let id = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let url = s.ws_url(&format!("/v1/jobs/{id}/stream"));
    assert_eq!(open(&url, Some("http://evil.example")).await, Err(403));
    assert_eq!(open(&url, Some(&s.base)).await, Ok(()));
    assert_eq!(open(&url, None).await, Ok(()));
    s.stop().await;

    let s = Service::start(
        &data_dir("origin-listed"),
        &["--workers", "1", "--cors-origin", "http://viewer.example"],
    )
    .await;
    let id = submit(&s, &hanging(4, 0.1)).await["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let url = s.ws_url(&format!("/v1/jobs/{id}/stream"));
    assert_eq!(open(&url, Some("http://viewer.example")).await, Ok(()));
    assert_eq!(open(&url, Some("http://evil.example")).await, Err(403));
    s.stop().await;
}

/// With keys: the scheme is case-insensitive; `?access_token=` opens only
/// the stream and the download; `/metrics` needs a key while `/healthz`
/// and `/readyz` (probes) do not.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn auth_takes_any_scheme_case_and_query_tokens_only_where_browsers_need_them() {
    let s = Service::start(
        &data_dir("auth"),
        &["--workers", "1", "--api-key", "alice:alice-secret-1"],
    )
    .await;
    let http = client();
    let r = http
        .post(s.url("/v1/jobs"))
        .header("authorization", "bearer alice-secret-1")
        .json(&hanging(4, 0.1))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 201, "a lower-case scheme");
    let id = r.json::<Value>().await.expect("JSON")["id"]
        .as_str()
        .expect("id")
        .to_owned();
    let r = http
        .get(s.url(&format!("/v1/jobs/{id}?access_token=alice-secret-1")))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 401, "not on a plain API call");
    assert!(
        error_of(r).await["message"]
            .as_str()
            .is_some_and(|m| m.contains("Authorization"))
    );
    wait_for_key(&s, &id).await;
    let r = http
        .get(s.url(&format!(
            "/v1/jobs/{id}/result?format=pc2&access_token=alice-secret-1"
        )))
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 200, "the download link");
    let got =
        read_stream(&s.ws_url(&format!("/v1/jobs/{id}/stream?access_token=alice-secret-1"))).await;
    assert_eq!(got.end["type"], json!("done"), "the WebSocket");

    let r = http.get(s.url("/metrics")).send().await.expect("request");
    assert_eq!(r.status(), 401);
    let r = http
        .get(s.url("/metrics"))
        .header("authorization", "Bearer alice-secret-1")
        .send()
        .await
        .expect("request");
    assert_eq!(r.status(), 200);
    for probe in ["/healthz", "/readyz"] {
        let r = http.get(s.url(probe)).send().await.expect("request");
        assert_eq!(r.status(), 200, "{probe}");
    }
    s.stop().await;
}

/// Waits for a keyed job to succeed.
async fn wait_for_key(s: &Service, id: &str) {
    let start = std::time::Instant::now();
    loop {
        let j: Value = client()
            .get(s.url(&format!("/v1/jobs/{id}")))
            .bearer_auth("alice-secret-1")
            .send()
            .await
            .expect("request")
            .json()
            .await
            .expect("JSON");
        if status(&j) == "succeeded" {
            return;
        }
        assert!(start.elapsed().as_secs() < 120, "{j}");
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
}
