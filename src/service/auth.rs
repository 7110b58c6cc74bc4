//! The gates: with API keys configured, `/v1` and `/metrics` need
//! `Authorization: Bearer SECRET` (the scheme in any case, RFC 7235), and
//! carry the key's [`Owner`] to the handlers. `?access_token=SECRET` is
//! taken instead only where a browser cannot send a header — the
//! WebSocket stream and the download link ([`Gate::header_or_query`]).
//! Another owner's job is answered 404, exactly like a missing one, so ids
//! cannot be probed.
//!
//! And the WebSocket's origin check ([`check_origin`]): a browser page on
//! another site may open a WebSocket to this server (the same-origin
//! policy does not cover WebSockets), so a handshake whose `Origin` is
//! neither this server's own nor one of `--cors-origin` is refused.

use axum::extract::{Request, State};
use axum::http::{HeaderMap, HeaderValue, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::error::ApiError;
use super::error_code::ErrorCode;
use super::keys::Owner;
use super::state::AppState;

/// A key gate's settings: the service, and whether `?access_token=` is
/// accepted.
#[derive(Debug, Clone)]
pub struct Gate {
    state: AppState,
    query_token: bool,
}

impl Gate {
    /// The key must come in the `Authorization` header.
    pub fn header(state: &AppState) -> Self {
        Self {
            state: state.clone(),
            query_token: false,
        }
    }

    /// The header, or `?access_token=` (stream and download).
    pub fn header_or_query(state: &AppState) -> Self {
        Self {
            state: state.clone(),
            query_token: true,
        }
    }
}

/// Middleware: checks the key and attaches the [`Owner`].
pub async fn require_key(State(gate): State<Gate>, mut req: Request, next: Next) -> Response {
    let keys = &gate.state.config.keys;
    if !keys.enabled() {
        req.extensions_mut().insert(Owner(None));
        return next.run(req).await;
    }
    let query = query_token(req.uri().query().unwrap_or(""));
    let token = match bearer(req.headers()) {
        Some(t) => Some(t),
        None if gate.query_token => query,
        None if query.is_some() => {
            return refuse(
                "send the API key as Authorization: Bearer <key>; ?access_token= is accepted only by /stream and /result",
            );
        }
        None => None,
    };
    match token.as_deref().and_then(|t| keys.owner_of(t)) {
        Some(owner) => {
            req.extensions_mut().insert(Owner(Some(owner.to_owned())));
            next.run(req).await
        }
        None if token.is_some() => refuse("the API key is not valid"),
        None => refuse("this server needs an API key: Authorization: Bearer <key>"),
    }
}

fn refuse(message: &str) -> Response {
    let mut r = ApiError::new(ErrorCode::Unauthorized, message).into_response();
    r.headers_mut()
        .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
    r
}

/// The token of an `Authorization: Bearer TOKEN` header, the scheme in
/// any case.
fn bearer(headers: &HeaderMap) -> Option<String> {
    let value = headers.get(header::AUTHORIZATION)?.to_str().ok()?.trim();
    let (scheme, token) = value.split_once(' ')?;
    scheme
        .eq_ignore_ascii_case("bearer")
        .then(|| token.trim().to_owned())
}

/// Refuses a WebSocket handshake from a page of another origin: allowed
/// are no `Origin` (not a browser), this server's own origin (the
/// viewer), and with `--cors-origin` the origins listed (or any, `*`).
pub fn check_origin(headers: &HeaderMap, allowed: &[String]) -> Result<(), ApiError> {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return Ok(());
    };
    let origin = origin.to_str().unwrap_or("");
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .unwrap_or("");
    let same = origin
        .split_once("://")
        .is_some_and(|(_, authority)| !host.is_empty() && authority.eq_ignore_ascii_case(host));
    let listed = allowed
        .iter()
        .any(|a| a == "*" || a.trim_end_matches('/').eq_ignore_ascii_case(origin));
    if same || listed {
        Ok(())
    } else {
        Err(ApiError::new(
            ErrorCode::Forbidden,
            format!(
                "WebSocket from origin {origin:?} refused: only this server's own origin and --cors-origin may open streams"
            ),
        ))
    }
}

/// The `access_token` query parameter, decoded as a form
/// (`application/x-www-form-urlencoded`, as browsers encode it).
fn query_token(query: &str) -> Option<String> {
    form_urlencoded::parse(query.as_bytes())
        .find(|(k, _)| k == "access_token")
        .map(|(_, v)| v.into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bearer_scheme_is_case_insensitive() {
        let with = |v: &'static str| {
            let mut h = HeaderMap::new();
            h.insert(header::AUTHORIZATION, HeaderValue::from_static(v));
            bearer(&h)
        };
        assert_eq!(with("Bearer key-1"), Some("key-1".into()));
        assert_eq!(with("bearer key-1"), Some("key-1".into()));
        assert_eq!(with("BEARER  key-1 "), Some("key-1".into()));
        assert_eq!(with("Basic a2V5"), None);
        assert_eq!(with("Bearer"), None);
    }

    #[test]
    fn websocket_origins_are_this_server_or_listed() {
        let with = |origin: &'static str, allowed: &[&str]| {
            let mut h = HeaderMap::new();
            h.insert(header::HOST, HeaderValue::from_static("127.0.0.1:8080"));
            h.insert(header::ORIGIN, HeaderValue::from_static(origin));
            let allowed: Vec<String> = allowed.iter().map(|s| (*s).to_owned()).collect();
            check_origin(&h, &allowed).is_ok()
        };
        assert!(with("http://127.0.0.1:8080", &[]));
        assert!(!with("http://evil.example", &[]));
        assert!(!with("null", &[]));
        assert!(with("http://viewer.example", &["http://viewer.example"]));
        assert!(with("http://evil.example", &["*"]));
        assert!(
            check_origin(&HeaderMap::new(), &[]).is_ok(),
            "no Origin: not a browser"
        );
    }

    #[test]
    fn query_token_is_percent_decoded() {
        assert_eq!(
            query_token("from=3&access_token=a%3Ab+c"),
            Some("a:b c".into())
        );
        assert_eq!(query_token("from=3"), None);
        // A malformed escape is kept as it is (WHATWG form decoding): no
        // secret is written that way, so the request is still refused.
        assert_eq!(query_token("access_token=%zz"), Some("%zz".into()));
    }
}
