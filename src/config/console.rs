//! `[console]` and `[robots.NAME.console]` -> [`ConsoleSettings`], [`RobotConsoleSettings`]: the
//! operator's console the daemon serves (docs/CONSOLE.md).
//!
//! ```toml
//! [console]                              # absent: no console
//! listen = "127.0.0.1:8470"              # default; beyond loopback only with `allow`
//! allow = ["10.0.0.0/24"]                # the clients it serves (IPs, CIDR networks)
//! origins = ["https://hmi.plant.local"]  # pages on other origins allowed (a proxy in front)
//! session = "12h"                        # a login lasts this long (1 min to 7 days)
//! [console.users.ann]
//! role = "operator"                      # viewer | operator | admin
//! password_hash = "$argon2id$v=19$..."   # `linterpd console hash-password` makes one
//! [console.users.line-screen]
//! role = "viewer"
//! token_file = "/etc/linterpd/screen.token"   # or a token: its file's content is the secret
//!
//! [robots.press-loader.console]
//! manual_speed_mm_s = 50                 # the jog's speed cap: above 0, at most 250 (ISO 10218-1)
//! ```

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use serde::{Deserialize, Serialize};
use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{RawConsole, RawConsoleUser, RawRobotConsole};
use super::units::parse_duration_s;
use crate::gateway::ClientNet;
use crate::robot::{POSITION_NAME_RULE, is_position_name};

/// The most a robot's manual speed may be, mm/s: ISO 10218-1's reduced speed.
pub const MAX_MANUAL_SPEED_MM_S: f64 = 250.0;
/// A robot's manual speed when its config does not say, mm/s.
pub const DEFAULT_MANUAL_SPEED_MM_S: f64 = 50.0;

/// What a console user may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Sees everything, stops the robot.
    Viewer,
    /// Moves, jogs, runs cycles, teaches (holding the seat).
    Operator,
    /// Deletes positions, changes the mode.
    Admin,
}

impl Role {
    /// Its name, as config and the page write it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Viewer => "viewer",
            Self::Operator => "operator",
            Self::Admin => "admin",
        }
    }
}

/// Where the console listens when the config does not say.
pub const DEFAULT_CONSOLE_LISTEN: &str = "127.0.0.1:8470";
/// How long a login lasts when the config does not say.
const DEFAULT_SESSION: Duration = Duration::from_secs(12 * 3600);
/// The shortest and longest a login may last, s.
const SESSION_RANGE_S: std::ops::RangeInclusive<f64> = 60.0..=(7.0 * 86_400.0);

/// The operator's console: where it listens, whom it serves, its users.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConsoleSettings {
    /// IP and port.
    pub listen: SocketAddr,
    /// The clients it serves; without one, loopback clients only.
    pub allow: Vec<ClientNet>,
    /// Origins besides the page's own whose pages may use it (`scheme://host[:port]`).
    pub origins: Vec<String>,
    /// How long a login lasts.
    pub session: Duration,
    /// The users, by name.
    pub users: BTreeMap<String, ConsoleUser>,
}

/// A console user.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConsoleUser {
    /// What they may do.
    pub role: Role,
    /// How they prove who they are.
    pub secret: Secret,
}

/// A user's secret.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Secret {
    /// A PHC string of an argon2 hash of their password.
    PasswordHash(String),
    /// A file whose content (blanks around it aside) is their token.
    TokenFile(PathBuf),
}

/// A robot's console settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobotConsoleSettings {
    /// The fastest a jog moves the tool, mm/s.
    pub manual_speed_mm_s: f64,
}

impl Default for RobotConsoleSettings {
    fn default() -> Self {
        Self {
            manual_speed_mm_s: DEFAULT_MANUAL_SPEED_MM_S,
        }
    }
}

/// The settings `[console]` describes.
pub(super) fn settings(at: &At, raw: &Spanned<RawConsole>) -> Result<ConsoleSettings, ConfigError> {
    let r = raw.get_ref();
    let (listen, allow) = super::gateway::listen_allow(
        at,
        (r.listen.as_ref(), r.allow.as_deref()),
        DEFAULT_CONSOLE_LISTEN.parse().expect("a valid address"),
        "127.0.0.1:8470",
    )?;
    if let Some(text) = &r.listen
        && allow.is_empty()
        && !listen.ip().to_canonical().is_loopback()
    {
        return Err(at.child("listen").invalid(
            text,
            format!(
                "{} is beyond loopback: it needs console.allow, the client IPs or CIDR networks \
                 it serves (and keep the console off the internet)",
                listen.ip()
            ),
        ));
    }
    let mut origins = Vec::new();
    for (i, text) in r.origins.as_deref().unwrap_or_default().iter().enumerate() {
        origins.push(origin(&at.child("origins").index(i), text)?);
    }
    let session = match &r.session {
        None => DEFAULT_SESSION,
        Some(text) => session(&at.child("session"), text)?,
    };
    let users = users(at, raw)?;
    Ok(ConsoleSettings {
        listen,
        allow,
        origins,
        session,
        users,
    })
}

/// How long a login lasts: `text`, from 1 min to 7 days.
fn session(at: &At, text: &Spanned<String>) -> Result<Duration, ConfigError> {
    let s = parse_duration_s(text.get_ref()).map_err(|e| at.invalid(text, e.problem))?;
    if !SESSION_RANGE_S.contains(&s) {
        return Err(at.invalid(text, "must be at least 1 min and at most 7 days"));
    }
    Ok(Duration::from_secs_f64(s))
}

/// `[console.users.NAME]`: at least one.
fn users(at: &At, raw: &Spanned<RawConsole>) -> Result<BTreeMap<String, ConsoleUser>, ConfigError> {
    let mut users = BTreeMap::new();
    let r = raw.get_ref();
    for (name, user) in r.users.as_ref().map(|u| u.iter()).into_iter().flatten() {
        let at = at.child("users").child(name.get_ref());
        if !is_position_name(name.get_ref()) {
            return Err(at.invalid(name, format!("a user name: {POSITION_NAME_RULE}")));
        }
        users.insert(name.get_ref().clone(), self::user(&at, user)?);
    }
    if users.is_empty() {
        return Err(at.missing(
            &raw.span(),
            "the console needs at least one user: [console.users.NAME] with a role and a \
             password_hash (`linterpd console hash-password`) or a token_file",
        ));
    }
    Ok(users)
}

fn user(at: &At, raw: &Spanned<RawConsoleUser>) -> Result<ConsoleUser, ConfigError> {
    let r = raw.get_ref();
    let role = match r.role.get_ref().as_str() {
        "viewer" => Role::Viewer,
        "operator" => Role::Operator,
        "admin" => Role::Admin,
        _ => {
            return Err(at
                .child("role")
                .invalid(&r.role, "must be \"viewer\", \"operator\" or \"admin\""));
        }
    };
    let secret = secret(at, raw)?;
    Ok(ConsoleUser { role, secret })
}

/// How a user proves who it is: exactly one of a password hash (argon2) and a token file.
fn secret(at: &At, raw: &Spanned<RawConsoleUser>) -> Result<Secret, ConfigError> {
    let r = raw.get_ref();
    match (&r.password_hash, &r.token_file) {
        (Some(hash), None) => {
            argon2::password_hash::phc::PasswordHash::new(hash.get_ref())
                .ok()
                .filter(|h| h.algorithm.as_str().starts_with("argon2"))
                .ok_or_else(|| {
                    at.child("password_hash").invalid(
                        hash,
                        "must be an argon2 PHC string ($argon2id$v=19$m=...,t=...,p=...$salt$hash): \
                         `linterpd console hash-password` makes one",
                    )
                })?;
            Ok(Secret::PasswordHash(hash.get_ref().clone()))
        }
        (None, Some(file)) if !file.get_ref().trim().is_empty() => {
            Ok(Secret::TokenFile(PathBuf::from(file.get_ref())))
        }
        (None, Some(file)) => Err(at.child("token_file").invalid(file, "needs a file path")),
        (Some(_), Some(file)) => Err(at
            .child("token_file")
            .invalid(file, "a user has a password_hash or a token_file, not both")),
        (None, None) => Err(at.missing(
            &raw.span(),
            "a user needs a password_hash (`linterpd console hash-password`) or a token_file",
        )),
    }
}

/// An origin as a browser sends it: `scheme://host[:port]`, no path.
fn origin(at: &At, text: &Spanned<String>) -> Result<String, ConfigError> {
    let t = text.get_ref();
    let rest = t
        .strip_prefix("http://")
        .or_else(|| t.strip_prefix("https://"));
    match rest {
        Some(host) if !host.is_empty() && !host.contains('/') => Ok(t.clone()),
        _ => Err(at.invalid(
            text,
            "must be an origin, scheme://host[:port] (\"https://hmi.plant.local\"), no path",
        )),
    }
}

/// A robot's `[robots.NAME.console]`.
pub(super) fn robot(
    at: &At,
    raw: &Spanned<RawRobotConsole>,
) -> Result<RobotConsoleSettings, ConfigError> {
    let mut settings = RobotConsoleSettings::default();
    if let Some(v) = &raw.get_ref().manual_speed_mm_s {
        let at = at.child("manual_speed_mm_s");
        let speed = at.finite(v)?;
        if !(speed > 0.0 && speed <= MAX_MANUAL_SPEED_MM_S) {
            return Err(at.invalid(
                v,
                format!(
                    "must be above 0 and at most {MAX_MANUAL_SPEED_MM_S} mm/s (ISO 10218-1's \
                     reduced speed)"
                ),
            ));
        }
        settings.manual_speed_mm_s = speed;
    }
    Ok(settings)
}

#[cfg(test)]
mod tests {
    use super::super::Config;
    use super::super::fixture::{MINIMAL, message};
    use super::*;

    const HASH: &str = "$argon2id$v=19$m=19456,t=2,p=1$c2FsdHNhbHRzYWx0$Q0FhO2L2kbD6cd9ukGZC0b8hXMnF0jX3e3CtMHhYzYM";

    fn with_console(table: &str) -> String {
        format!(
            "{MINIMAL}[console]\n{table}\n[console.users.ann]\nrole = \"operator\"\npassword_hash = \"{HASH}\"\n"
        )
    }

    #[test]
    fn a_console_listens_on_loopback_by_default_with_its_users() {
        let c = Config::from_toml(&with_console("")).unwrap();
        let console = c.console.clone().unwrap();
        assert_eq!(console.listen, DEFAULT_CONSOLE_LISTEN.parse().unwrap());
        assert_eq!(console.users["ann"].role, Role::Operator);
        assert_eq!(console.session, DEFAULT_SESSION);
        assert!((c.robot_console("r").manual_speed_mm_s - 50.0).abs() < 1e-12);
    }

    #[test]
    fn no_console_table_no_console() {
        assert!(Config::from_toml(MINIMAL).unwrap().console.is_none());
    }

    #[test]
    fn a_console_beyond_loopback_needs_an_allow_list() {
        let m = message(&with_console("listen = \"0.0.0.0:8470\""));
        assert!(
            m.contains("console.listen = \"0.0.0.0:8470\": 0.0.0.0 is beyond loopback")
                && m.contains("needs console.allow"),
            "{m}"
        );
        let c = Config::from_toml(&with_console(
            "listen = \"0.0.0.0:8470\"\nallow = [\"10.0.0.0/24\"]",
        ))
        .unwrap();
        assert_eq!(c.console.unwrap().allow.len(), 1);
    }

    #[test]
    fn a_console_without_users_is_refused() {
        let m = message(&format!(
            "{MINIMAL}[console]\nlisten = \"127.0.0.1:8470\"\n"
        ));
        assert!(m.contains("the console needs at least one user"), "{m}");
    }

    #[test]
    fn bad_users_name_the_key_and_the_rule() {
        let bad_role =
            format!("{MINIMAL}[console.users.bob]\nrole = \"boss\"\npassword_hash = \"{HASH}\"\n");
        assert!(
            message(&bad_role).contains(
                "console.users.bob.role = \"boss\": must be \"viewer\", \"operator\" or \"admin\""
            ),
            "{}",
            message(&bad_role)
        );
        let bad_hash =
            format!("{MINIMAL}[console.users.bob]\nrole = \"admin\"\npassword_hash = \"secret\"\n");
        assert!(
            message(&bad_hash)
                .contains("console.users.bob.password_hash = \"secret\": must be an argon2 PHC"),
            "{}",
            message(&bad_hash)
        );
        let neither = format!("{MINIMAL}[console.users.bob]\nrole = \"admin\"\n");
        assert!(message(&neither).contains("a user needs a password_hash"));
    }

    #[test]
    fn manual_speed_is_at_most_250_mm_s() {
        let text = format!(
            "{}[robots.r.console]\nmanual_speed_mm_s = 300\n",
            with_console("")
        );
        let m = message(&text);
        assert!(
            m.contains(
                "robots.r.console.manual_speed_mm_s = 300: must be above 0 and at most 250 mm/s"
            ),
            "{m}"
        );
        let ok = format!(
            "{}[robots.r.console]\nmanual_speed_mm_s = 120\n",
            with_console("")
        );
        let speed = Config::from_toml(&ok)
            .unwrap()
            .robot_console("r")
            .manual_speed_mm_s;
        assert!((speed - 120.0).abs() < 1e-12);
    }

    #[test]
    fn origins_are_scheme_host_and_port() {
        let m = message(&with_console("origins = [\"hmi.local/x\"]"));
        assert!(
            m.contains("console.origins[0] = \"hmi.local/x\": must be an origin"),
            "{m}"
        );
        assert!(Config::from_toml(&with_console("origins = [\"https://hmi.local:8443\"]")).is_ok());
    }
}
