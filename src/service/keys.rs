//! API keys and who may see what. With no key configured the service is
//! open (a local tool): there is no owner and everyone sees every job.
//! With keys, each call is made by the owner of its key, and an owner sees
//! only the jobs it submitted.

use std::fmt::Write;

use sha2::{Digest, Sha256};
use subtle::ConstantTimeEq;

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

/// A `--api-key` entry that cannot be a key.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("API key for {owner:?}: needs a name and a secret of at least 8 characters")]
pub struct KeyError {
    owner: String,
}

/// The configured keys.
#[derive(Debug, Clone, Default)]
pub struct Keys(Vec<ApiKey>);

impl Keys {
    /// Parses `NAME:SECRET` entries; a bare secret's owner is a stable
    /// fingerprint of it (`key-` and 16 hex digits of its SHA-256), so its
    /// jobs stay its own across restarts and the owner name does not
    /// reveal the secret.
    pub fn parse(entries: &[String]) -> Result<Self, KeyError> {
        let mut keys = Vec::new();
        for e in entries.iter().map(|e| e.trim()).filter(|e| !e.is_empty()) {
            let (owner, secret) = match e.split_once(':') {
                Some((o, s)) => (o.to_owned(), s.to_owned()),
                None => (fingerprint(e), e.to_owned()),
            };
            if owner.is_empty() || secret.len() < 8 {
                return Err(KeyError { owner });
            }
            keys.push(ApiKey { owner, secret });
        }
        Ok(Self(keys))
    }

    /// Keys are required.
    pub fn enabled(&self) -> bool {
        !self.0.is_empty()
    }

    /// The owner of `token`. Every key is compared, each in constant time
    /// (`subtle`), so the time taken does not say which key came close.
    pub fn owner_of(&self, token: &str) -> Option<&str> {
        let mut found = None;
        for k in &self.0 {
            if bool::from(k.secret.as_bytes().ct_eq(token.as_bytes())) {
                found = Some(k.owner.as_str());
            }
        }
        found
    }
}

/// `key-` and the first 8 bytes of the secret's SHA-256 in hex.
fn fingerprint(secret: &str) -> String {
    Sha256::digest(secret.as_bytes())[..8]
        .iter()
        .fold(String::from("key-"), |mut name, b| {
            // Writing to a String cannot fail.
            let _ = write!(name, "{b:02x}");
            name
        })
}

/// Who is calling: `None` when keys are off (everyone sees everything).
#[derive(Debug, Clone)]
pub struct Owner(pub Option<String>);

impl Owner {
    /// The owner recorded on a job this caller submits.
    pub fn name(&self) -> &str {
        self.0.as_deref().unwrap_or("")
    }

    /// The owner whose jobs a listing shows; `None`: every job.
    pub fn filter(&self) -> Option<&str> {
        self.0.as_deref()
    }

    /// May this caller see a job of `owner`?
    pub fn may_see(&self, owner: &str) -> bool {
        self.0.as_deref().is_none_or(|me| me == owner)
    }
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
        assert_eq!(bare.len(), 4 + 16, "key- and 16 hex digits: {bare}");
        assert_eq!(bare, fingerprint("bare-secret-b"), "stable across restarts");
        assert_ne!(bare, fingerprint("bare-secret-c"));
        assert_eq!(keys.owner_of("secret-a"), None);
        assert_eq!(keys.owner_of(""), None);
        assert!(Keys::parse(&["bob:short".into()]).is_err());
        assert_eq!(
            Keys::parse(&["bob:short".into()])
                .expect_err("too short")
                .to_string(),
            "API key for \"bob\": needs a name and a secret of at least 8 characters"
        );
        assert!(!Keys::parse(&[]).expect("empty is fine").enabled());
    }

    #[test]
    fn owners_see_only_their_jobs() {
        assert!(Owner(None).may_see("anyone"));
        assert!(Owner(Some("a".into())).may_see("a"));
        assert!(!Owner(Some("a".into())).may_see("b"));
    }
}
