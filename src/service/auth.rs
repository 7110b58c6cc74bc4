//! The `/v1` gate: with API keys configured, every call needs
//! `Authorization: Bearer SECRET` (or `?access_token=SECRET`), and carries
//! the key's [`Owner`] to the handlers. Another owner's job is answered
//! 404, exactly like a missing one, so ids cannot be probed.

use axum::extract::{Request, State};
use axum::http::{HeaderValue, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::error::ApiError;
use super::error_code::ErrorCode;
use super::keys::Owner;
use super::state::AppState;

/// Middleware on `/v1`: checks the bearer token and attaches the [`Owner`].
pub async fn require_key(State(state): State<AppState>, mut req: Request, next: Next) -> Response {
    let keys = &state.config.keys;
    if !keys.enabled() {
        req.extensions_mut().insert(Owner(None));
        return next.run(req).await;
    }
    // A browser cannot set headers on a WebSocket or a download link, so
    // the key may also come as `?access_token=` (RFC 6750 §2.3).
    let header_token = req
        .headers()
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
        .map(|t| t.trim().to_owned());
    let token = header_token.or_else(|| query_token(req.uri().query().unwrap_or("")));
    let token = token.as_deref();
    match token.and_then(|t| keys.owner_of(t)) {
        Some(owner) => {
            req.extensions_mut().insert(Owner(Some(owner.to_owned())));
            next.run(req).await
        }
        None => {
            let message = if token.is_some() {
                "the API key is not valid"
            } else {
                "this server needs an API key: Authorization: Bearer <key>"
            };
            let mut r = ApiError::new(ErrorCode::Unauthorized, message).into_response();
            r.headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
            r
        }
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
