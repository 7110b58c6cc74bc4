//! Extractors whose every rejection is an [`ApiError`], so a request the
//! handlers cannot read still gets the one error envelope, with the
//! parameter at fault as `path`:
//!
//! - [`Query`]: the query string into a serde type, each parameter at most
//!   once (`?format=obj&format=glb` is refused, naming `format`);
//! - [`JsonBody`]: the body of a request whose `Content-Type` is
//!   `application/json` (anything else is `415`: with no keys, a web page
//!   could otherwise post a job as a "simple" cross-origin request, which
//!   needs no preflight).

use std::collections::HashSet;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{FromRequest, FromRequestParts, Request};
use axum::http::request::Parts;
use axum::http::{HeaderMap, StatusCode, header};
use serde::de::DeserializeOwned;

use super::error::ApiError;
use super::error_code::ErrorCode;

/// The query string as `T`; a parameter that does not parse, or comes
/// twice, is a `400` naming it.
#[derive(Debug, Clone)]
pub struct Query<T>(pub T);

impl<T: DeserializeOwned, S: Send + Sync> FromRequestParts<S> for Query<T> {
    type Rejection = ApiError;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Self, ApiError> {
        parse_query(parts.uri.query().unwrap_or("")).map(Query)
    }
}

/// `query` as `T`, each parameter at most once.
pub fn parse_query<T: DeserializeOwned>(query: &str) -> Result<T, ApiError> {
    let pairs = || form_urlencoded::parse(query.as_bytes());
    let mut seen = HashSet::new();
    for (name, _) in pairs() {
        if !seen.insert(name.clone()) {
            return Err(
                ApiError::bad_request(format!("{name}: given more than once")).with_path(name),
            );
        }
    }
    serde_path_to_error::deserialize(serde_urlencoded::Deserializer::new(pairs())).map_err(|e| {
        let path = e.path().to_string();
        let message = format!("{path}: {}", e.inner());
        ApiError::bad_request(message).with_path(path)
    })
}

/// The body of a JSON request.
#[derive(Debug, Clone)]
pub struct JsonBody(pub Bytes);

impl<S: Send + Sync> FromRequest<S> for JsonBody {
    type Rejection = ApiError;

    async fn from_request(req: Request, state: &S) -> Result<Self, ApiError> {
        if !is_json(req.headers()) {
            return Err(ApiError::new(
                ErrorCode::UnsupportedMediaType,
                "the body must be a job spec sent as Content-Type: application/json",
            ));
        }
        Bytes::from_request(req, state)
            .await
            .map(JsonBody)
            .map_err(|e| body_error(&e))
    }
}

/// `Content-Type: application/json`, with or without parameters
/// (`; charset=utf-8`), in any case.
fn is_json(headers: &HeaderMap) -> bool {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
        .is_some_and(|mime| mime.trim().eq_ignore_ascii_case("application/json"))
}

/// A body that could not be read: too large, or broken.
fn body_error(e: &BytesRejection) -> ApiError {
    if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
        ApiError::new(
            ErrorCode::PayloadTooLarge,
            "the body is larger than this server's limit (--max-body-bytes)",
        )
    } else {
        ApiError::bad_request(e.body_text())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, serde::Deserialize)]
    struct Q {
        limit: Option<u32>,
        format: Option<String>,
    }

    #[test]
    fn query_errors_name_the_parameter() {
        let q: Q = parse_query("limit=5&format=glb&other=1").expect("valid");
        assert_eq!((q.limit, q.format.as_deref()), (Some(5), Some("glb")));
        let e = parse_query::<Q>("limit=-1").expect_err("negative");
        assert_eq!(e.body.path.as_deref(), Some("limit"));
        assert_eq!(e.status(), StatusCode::BAD_REQUEST);
        let e = parse_query::<Q>("format=obj&format=glb").expect_err("twice");
        assert_eq!(e.body.path.as_deref(), Some("format"));
        assert_eq!(e.body.message, "format: given more than once");
    }

    #[test]
    fn only_application_json_is_json() {
        let with = |v: &'static str| {
            let mut h = HeaderMap::new();
            h.insert(header::CONTENT_TYPE, header::HeaderValue::from_static(v));
            is_json(&h)
        };
        assert!(with("application/json"));
        assert!(with("Application/JSON; charset=utf-8"));
        assert!(!with("text/plain"));
        assert!(!with("application/x-www-form-urlencoded"));
        assert!(!with("multipart/form-data; boundary=x"));
        assert!(!is_json(&HeaderMap::new()));
    }
}
