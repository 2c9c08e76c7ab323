//! Console logins: users from `[console.users]` (an argon2 password hash, or a token file),
//! failed logins rate-limited (`console::limiter`), sessions as random ids in an `HttpOnly`
//! SameSite=Strict cookie, each ending [`crate::config::ConsoleSettings::session`] after its
//! login.

use std::collections::{BTreeMap, HashMap};
use std::net::IpAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::Duration;

use argon2::password_hash::PasswordVerifier;
use subtle::ConstantTimeEq;
use thiserror::Error;

use crate::config::{ConsoleSettings, Secret};
use crate::console::{Limited, LoginLimiter, Role, SessionId};

/// The session cookie's name.
pub const COOKIE: &str = "linterpd_session";

/// A user's way in, read at start.
#[derive(Debug, Clone)]
enum Key {
    Hash(String),
    Token(String),
}

/// One login.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Session {
    /// Its number (the jog and the seat know it by this).
    pub id: SessionId,
    /// The user.
    pub user: String,
    /// Their role.
    pub role: Role,
    expires: tokio::time::Instant,
}

/// Why a login failed.
#[derive(Debug, Error)]
pub enum LoginError {
    /// Too many failures.
    #[error(transparent)]
    Limited(#[from] Limited),
    /// Wrong user or password (which of them is not said).
    #[error("wrong user or password")]
    Wrong,
}

/// Why the console cannot start.
#[derive(Debug, Error)]
pub enum UsersError {
    /// A user's token file cannot be read, or is empty.
    #[error("console user {user}: cannot use token file {}: {why}", file.display())]
    Token {
        /// The user.
        user: String,
        /// The file.
        file: std::path::PathBuf,
        /// Why.
        why: String,
    },
}

/// The users, the sessions, the limiter.
#[derive(Debug)]
pub struct Sessions {
    users: BTreeMap<String, (Role, Key)>,
    live: Mutex<HashMap<String, Session>>,
    limiter: Mutex<LoginLimiter>,
    next_id: AtomicU64,
    lasts: Duration,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl Sessions {
    /// The users of `settings`, their token files read.
    pub fn new(settings: &ConsoleSettings) -> Result<Self, UsersError> {
        let mut users = BTreeMap::new();
        for (name, user) in &settings.users {
            let key = match &user.secret {
                Secret::PasswordHash(hash) => Key::Hash(hash.clone()),
                Secret::TokenFile(file) => {
                    let bad = |why: String| UsersError::Token {
                        user: name.clone(),
                        file: file.clone(),
                        why,
                    };
                    let text = std::fs::read_to_string(file).map_err(|e| bad(e.to_string()))?;
                    let token = text.trim();
                    if token.len() < 16 {
                        return Err(bad(format!(
                            "the token is {} characters; at least 16",
                            token.len()
                        )));
                    }
                    Key::Token(token.to_owned())
                }
            };
            users.insert(name.clone(), (user.role, key));
        }
        Ok(Self {
            users,
            live: Mutex::new(HashMap::new()),
            limiter: Mutex::new(LoginLimiter::default()),
            next_id: AtomicU64::new(1),
            lasts: settings.session,
        })
    }

    /// Logs `user` in from `client` with `secret` (a password, or a token): the cookie's value
    /// and the session.
    pub async fn login(
        &self,
        client: IpAddr,
        user: &str,
        secret: &str,
    ) -> Result<(String, Session), LoginError> {
        let at = tokio::time::Instant::now().into_std();
        lock(&self.limiter).check(client, user, at)?;
        let verified = match self.users.get(user) {
            Some((role, Key::Hash(hash))) => {
                let (hash, secret) = (hash.clone(), secret.to_owned());
                // Argon2 takes tens of milliseconds of one core: off the async threads.
                let ok = tokio::task::spawn_blocking(move || verify(&hash, &secret))
                    .await
                    .unwrap_or(false);
                ok.then_some(*role)
            }
            Some((role, Key::Token(token))) => {
                bool::from(token.as_bytes().ct_eq(secret.as_bytes())).then_some(*role)
            }
            None => None,
        };
        let Some(role) = verified else {
            lock(&self.limiter).failed(client, user, tokio::time::Instant::now().into_std());
            tracing::warn!(user, client = %client, "console login refused");
            return Err(LoginError::Wrong);
        };
        lock(&self.limiter).succeeded(user);
        let session = Session {
            id: self.next_id.fetch_add(1, Ordering::SeqCst),
            user: user.to_owned(),
            role,
            expires: tokio::time::Instant::now() + self.lasts,
        };
        let cookie = random_id();
        lock(&self.live).insert(cookie.clone(), session.clone());
        tracing::info!(user, role = role.name(), client = %client, "console login");
        Ok((cookie, session))
    }

    /// The session of a cookie's value, while it lasts.
    #[must_use]
    pub fn get(&self, cookie: &str) -> Option<Session> {
        let now = tokio::time::Instant::now();
        let mut live = lock(&self.live);
        live.retain(|_, s| s.expires > now);
        live.get(cookie).cloned()
    }

    /// Ends the session of a cookie's value.
    pub fn logout(&self, cookie: &str) -> Option<Session> {
        lock(&self.live).remove(cookie)
    }

    /// How long a login lasts.
    #[must_use]
    pub fn lasts(&self) -> Duration {
        self.lasts
    }
}

fn verify(hash: &str, password: &str) -> bool {
    let Ok(parsed) = argon2::password_hash::phc::PasswordHash::new(hash) else {
        return false;
    };
    argon2::Argon2::default()
        .verify_password(password.as_bytes(), &parsed)
        .is_ok()
}

/// 32 random bytes from the OS, as 64 hex digits.
fn random_id() -> String {
    let mut bytes = [0_u8; 32];
    getrandom::fill(&mut bytes).expect("the OS's random source");
    bytes.iter().fold(String::with_capacity(64), |mut s, b| {
        use std::fmt::Write;
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// Why a password could not be hashed.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct HashError(argon2::password_hash::Error);

/// An argon2id PHC string of `password` (`linterpd console hash-password`).
pub fn hash_password(password: &str) -> Result<String, HashError> {
    use argon2::password_hash::PasswordHasher;
    argon2::Argon2::default()
        .hash_password(password.as_bytes())
        .map(|h| h.to_string())
        .map_err(HashError)
}

/// The value of cookie `name` in a `Cookie` header.
#[must_use]
pub(super) fn cookie_value<'a>(header: &'a str, name: &str) -> Option<&'a str> {
    header.split(';').find_map(|pair| {
        let (k, v) = pair.trim().split_once('=')?;
        (k == name).then_some(v)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hash_made_here_verifies_only_its_password() {
        let hash = hash_password("correct horse").unwrap();
        assert!(hash.starts_with("$argon2id$"), "{hash}");
        assert!(verify(&hash, "correct horse"));
        assert!(!verify(&hash, "correct hors"));
        assert!(!verify("not a hash", "x"));
    }

    #[test]
    fn cookies_are_read_by_name() {
        let h = "a=1; linterpd_session=abc; b=2";
        assert_eq!(cookie_value(h, COOKIE), Some("abc"));
        assert_eq!(cookie_value(h, "c"), None);
    }

    #[test]
    fn session_ids_are_64_hex_digits_and_differ() {
        let (a, b) = (random_id(), random_id());
        assert_eq!(a.len(), 64);
        assert!(a.bytes().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
    }
}
