//! Optional API keys. With none configured the service is open (a local
//! tool); with keys, every `/v1` call needs `Authorization: Bearer SECRET`,
//! and a key's owner sees only the jobs it submitted: another owner's job
//! is answered 404, exactly like a missing one, so ids cannot be probed.

use std::sync::Arc;

use axum::extract::{Request, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::error::ApiError;
use super::state::Shared;

/// One key: who it belongs to and its secret.
#[derive(Clone)]
struct ApiKey {
    owner: String,
    secret: String,
}

impl std::fmt::Debug for ApiKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Never log a secret.
        f.debug_struct("ApiKey")
            .field("owner", &self.owner)
            .finish()
    }
}

/// The configured keys.
#[derive(Debug, Clone, Default)]
pub struct Keys(Vec<ApiKey>);

impl Keys {
    /// Parses `NAME:SECRET` entries; a bare secret's owner is a stable
    /// fingerprint of it, so its jobs stay its own across restarts.
    pub fn parse(entries: &[String]) -> Result<Self, String> {
        let mut keys = Vec::new();
        for e in entries.iter().map(|e| e.trim()).filter(|e| !e.is_empty()) {
            let (owner, secret) = match e.split_once(':') {
                Some((o, s)) => (o.to_owned(), s.to_owned()),
                None => (format!("key-{:016x}", fnv1a(e.as_bytes())), e.to_owned()),
            };
            if owner.is_empty() || secret.len() < 8 {
                return Err(format!(
                    "API key for {owner:?}: needs a name and a secret of at least 8 characters"
                ));
            }
            keys.push(ApiKey { owner, secret });
        }
        Ok(Self(keys))
    }

    /// Keys are required.
    pub fn enabled(&self) -> bool {
        !self.0.is_empty()
    }

    /// The owner of `token`, comparing every key in constant time.
    fn owner_of(&self, token: &str) -> Option<&str> {
        let mut found = None;
        for k in &self.0 {
            if constant_time_eq(k.secret.as_bytes(), token.as_bytes()) {
                found = Some(k.owner.as_str());
            }
        }
        found
    }
}

/// Who is calling: `None` when keys are off (everyone sees everything).
#[derive(Debug, Clone)]
pub struct Owner(pub Option<String>);

impl Owner {
    /// The owner recorded on a job this caller submits.
    pub fn name(&self) -> &str {
        self.0.as_deref().unwrap_or("")
    }

    /// May this caller see a job of `owner`?
    pub fn may_see(&self, owner: &str) -> bool {
        self.0.as_deref().is_none_or(|me| me == owner)
    }
}

/// Middleware on `/v1`: checks the bearer token and attaches the [`Owner`].
pub async fn require_key(
    State(shared): State<Arc<Shared>>,
    mut req: Request,
    next: Next,
) -> Response {
    let keys = &shared.config.keys;
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
            let mut r =
                ApiError::new(StatusCode::UNAUTHORIZED, "unauthorized", message).into_response();
            r.headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static("Bearer"));
            r
        }
    }
}

/// The `access_token` query parameter, percent-decoded.
fn query_token(query: &str) -> Option<String> {
    query.split('&').find_map(|pair| {
        let v = pair.strip_prefix("access_token=")?;
        let mut out = Vec::with_capacity(v.len());
        let mut bytes = v.bytes();
        while let Some(b) = bytes.next() {
            match b {
                b'%' => {
                    let hex = [bytes.next()?, bytes.next()?];
                    out.push(u8::from_str_radix(std::str::from_utf8(&hex).ok()?, 16).ok()?);
                }
                b'+' => out.push(b' '),
                b => out.push(b),
            }
        }
        String::from_utf8(out).ok()
    })
}

fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// FNV-1a, 64-bit: a stable, dependency-free fingerprint (not a secret).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_named_and_bare_keys() {
        let keys =
            Keys::parse(&["alice:secret-a1".into(), " bare-secret-b ".into()]).expect("valid");
        assert!(keys.enabled());
        assert_eq!(keys.owner_of("secret-a1"), Some("alice"));
        let bare = keys.owner_of("bare-secret-b").expect("bare key works");
        assert!(bare.starts_with("key-"));
        assert_eq!(keys.owner_of("secret-a"), None);
        assert_eq!(keys.owner_of(""), None);
        assert!(Keys::parse(&["bob:short".into()]).is_err());
        assert!(!Keys::parse(&[]).expect("empty is fine").enabled());
    }

    #[test]
    fn query_token_is_percent_decoded() {
        assert_eq!(
            query_token("from=3&access_token=a%3Ab+c"),
            Some("a:b c".into())
        );
        assert_eq!(query_token("from=3"), None);
        assert_eq!(query_token("access_token=%zz"), None);
    }

    #[test]
    fn owners_see_only_their_jobs() {
        assert!(Owner(None).may_see("anyone"));
        assert!(Owner(Some("a".into())).may_see("a"));
        assert!(!Owner(Some("a".into())).may_see("b"));
    }
}
