//! `[daemon]` -> [`DaemonSettings`]: where `linterpd serve` offers its HTTP/JSON API.
//!
//! ```toml
//! [daemon]                           # optional, as are all its keys
//! socket = "/run/linterpd/api.sock"  # the Unix socket (default)
//! socket_mode = "0660"               # its permissions, octal (default "0660"; at most "0770")
//! listen = "127.0.0.1:8420"          # an optional TCP listener, IP:port
//! token_file = "/etc/linterpd/token" # bearer token; required when listen is not loopback
//! start_within = "10s"               # a queued move that cannot start this long after its turn
//!                                    # came ends failed (never runs later)
//! state_dir = "/var/lib/linterpd"    # move ids (and taught positions) kept across restarts
//!
//! [daemon.journal]                   # the cell's journal in state_dir/journal (optional)
//! file_bytes = 4194304               # a file's size cap, bytes (default 4 MiB; 64 KiB..1 GiB)
//! files = 8                          # files kept, the oldest removed (default 8; 2..1000)
//! queue = 4096                       # entries waiting for the disk before more are dropped
//!                                    # and counted (default 4096; 16..1000000)
//! ```

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{RawDaemon, RawJournal};
use super::units::parse_duration_s;

/// The API socket when the config names none (deploy/linterpd.service's `RuntimeDirectory`).
pub const DEFAULT_SOCKET: &str = "/run/linterpd/api.sock";
/// The socket's permissions when the config gives none: owner and group read/write.
const DEFAULT_SOCKET_MODE: u32 = 0o660;
/// The socket's "other" bits: any of them lets every user of the machine connect, and so move
/// the robot (the Unix socket asks for no token).
const OTHERS: u32 = 0o007;
/// The state directory when the config names none (deploy/linterpd.service's `StateDirectory`).
pub(super) const DEFAULT_STATE_DIR: &str = "/var/lib/linterpd";
/// How long a queued move may wait for its start after its turn came, by default.
const DEFAULT_START_WITHIN: Duration = Duration::from_secs(10);

/// How `linterpd serve` offers its API.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DaemonSettings {
    /// The Unix socket's path.
    pub socket: PathBuf,
    /// The Unix socket's permission bits.
    pub socket_mode: u32,
    /// A TCP listener, if any.
    pub listen: Option<SocketAddr>,
    /// The file holding the bearer token TCP clients must send, if any.
    pub token_file: Option<PathBuf>,
    /// A queued move that cannot start this long after its turn came ends failed.
    pub start_within: Duration,
    /// Where state kept across restarts lives.
    pub state_dir: PathBuf,
    /// The cell's journal (in `state_dir/journal`).
    pub journal: JournalSettings,
}

/// `[daemon.journal]`: how big the journal may grow, and how many entries may wait for the
/// disk. At most `files` x `file_bytes` bytes are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct JournalSettings {
    /// A file's size cap, bytes: the next entry that would pass it starts a new file.
    pub file_bytes: u64,
    /// Files kept: the oldest is removed when a new one would make more.
    pub files: u32,
    /// Entries that may wait for the writer; more are dropped and counted.
    pub queue: usize,
}

impl Default for JournalSettings {
    fn default() -> Self {
        Self {
            file_bytes: 4 * 1024 * 1024,
            files: 8,
            queue: 4096,
        }
    }
}

impl Default for DaemonSettings {
    fn default() -> Self {
        Self {
            socket: PathBuf::from(DEFAULT_SOCKET),
            socket_mode: DEFAULT_SOCKET_MODE,
            listen: None,
            token_file: None,
            start_within: DEFAULT_START_WITHIN,
            state_dir: PathBuf::from(DEFAULT_STATE_DIR),
            journal: JournalSettings::default(),
        }
    }
}

/// The settings a `[daemon]` table describes (every default without one).
pub(super) fn settings(
    at: &At,
    raw: Option<&Spanned<RawDaemon>>,
) -> Result<DaemonSettings, ConfigError> {
    let mut settings = DaemonSettings::default();
    let Some(raw) = raw else {
        return Ok(settings);
    };
    let r = raw.get_ref();
    if let Some(v) = &r.socket {
        settings.socket = path(&at.child("socket"), v)?;
    }
    if let Some(v) = &r.socket_mode {
        settings.socket_mode = mode(&at.child("socket_mode"), v)?;
    }
    if let Some(v) = &r.token_file {
        settings.token_file = Some(path(&at.child("token_file"), v)?);
    }
    if let Some(v) = &r.start_within {
        settings.start_within = start_within(&at.child("start_within"), v)?;
    }
    if let Some(v) = &r.state_dir {
        settings.state_dir = path(&at.child("state_dir"), v)?;
    }
    if let Some(v) = &r.journal {
        settings.journal = journal(&at.child("journal"), v.get_ref())?;
    }
    if let Some(v) = &r.listen {
        let address = listen(&at.child("listen"), v)?;
        if !address.ip().is_loopback() && settings.token_file.is_none() {
            return Err(at.child("listen").invalid(
                v,
                "a listener beyond loopback needs daemon.token_file (a bearer token for clients)",
            ));
        }
        settings.listen = Some(address);
    }
    Ok(settings)
}

/// How long a move may wait to start: longer than 0 s, at most 1 h.
fn start_within(at: &At, v: &Spanned<String>) -> Result<Duration, ConfigError> {
    let seconds = parse_duration_s(v.get_ref()).map_err(|e| at.invalid(v, e.problem))?;
    if !(seconds > 0.0 && seconds <= 3_600.0) {
        return Err(at.invalid(v, "must be longer than 0 s and at most 1 h"));
    }
    Ok(Duration::from_secs_f64(seconds))
}

/// `[daemon.journal]`, each key within its range.
fn journal(at: &At, raw: &RawJournal) -> Result<JournalSettings, ConfigError> {
    let mut settings = JournalSettings::default();
    let within = |key: &str, v: &Spanned<i64>, min: i64, max: i64| {
        if (min..=max).contains(v.get_ref()) {
            Ok(*v.get_ref() as u64)
        } else {
            Err(at
                .child(key)
                .invalid(v, format!("must be from {min} to {max}")))
        }
    };
    if let Some(v) = &raw.file_bytes {
        settings.file_bytes = within("file_bytes", v, 65_536, 1 << 30)?;
    }
    if let Some(v) = &raw.files {
        settings.files = within("files", v, 2, 1000)? as u32;
    }
    if let Some(v) = &raw.queue {
        settings.queue = within("queue", v, 16, 1_000_000)? as usize;
    }
    Ok(settings)
}

fn path(at: &At, value: &Spanned<String>) -> Result<PathBuf, ConfigError> {
    if value.get_ref().trim().is_empty() {
        return Err(at.invalid(value, "needs a file path"));
    }
    Ok(PathBuf::from(value.get_ref()))
}

/// Octal permission bits, `"0660"` or `"660"`, that let no other user in ([`OTHERS`]).
fn mode(at: &At, value: &Spanned<String>) -> Result<u32, ConfigError> {
    let text = value.get_ref();
    let digits_ok =
        (3..=4).contains(&text.len()) && text.bytes().all(|b| (b'0'..=b'7').contains(&b));
    match u32::from_str_radix(text, 8) {
        Ok(bits) if digits_ok && bits & OTHERS != 0 => Err(at.invalid(
            value,
            "lets every user of the machine move the robot (an \"other\" bit is set); at most \
             0770: give the robot's users the socket's group instead",
        )),
        Ok(bits) if digits_ok && bits <= 0o777 => Ok(bits),
        _ => Err(at.invalid(value, "must be octal permission bits, e.g. \"0660\"")),
    }
}

fn listen(at: &At, value: &Spanned<String>) -> Result<SocketAddr, ConfigError> {
    value.get_ref().parse().map_err(|_| {
        at.invalid(
            value,
            "must be an IP address and port, e.g. \"127.0.0.1:8420\" or \"[::1]:8420\"",
        )
    })
}

#[cfg(test)]
mod tests {
    use super::super::Config;
    use super::super::fixture::{MINIMAL, message};
    use super::*;

    fn with_daemon(table: &str) -> String {
        format!("{MINIMAL}[daemon]\n{table}\n")
    }

    /// The line of the first key of the `[daemon]` table `with_daemon` appends.
    fn first_key_line() -> usize {
        MINIMAL.lines().count() + 2
    }

    #[test]
    fn no_daemon_table_gives_the_defaults() {
        let config = Config::from_toml(MINIMAL).unwrap();
        assert_eq!(config.daemon, DaemonSettings::default());
        assert_eq!(config.daemon.socket, PathBuf::from(DEFAULT_SOCKET));
        assert_eq!(config.daemon.socket_mode, 0o660);
    }

    #[test]
    fn every_key_is_read() {
        let text = with_daemon(
            "socket = \"/tmp/x.sock\"\nsocket_mode = \"0600\"\nlisten = \"0.0.0.0:8420\"\n\
             token_file = \"/etc/linterpd/token\"\nstart_within = \"3s\"\nstate_dir = \"/tmp/s\"",
        );
        let d = Config::from_toml(&text).unwrap().daemon;
        assert_eq!(d.start_within, Duration::from_secs(3));
        assert_eq!(d.state_dir, PathBuf::from("/tmp/s"));
        assert_eq!(d.socket, PathBuf::from("/tmp/x.sock"));
        assert_eq!(d.socket_mode, 0o600);
        assert_eq!(d.listen, Some("0.0.0.0:8420".parse().unwrap()));
        assert_eq!(d.token_file, Some(PathBuf::from("/etc/linterpd/token")));
    }

    #[test]
    fn the_journal_s_caps_are_read_and_out_of_range_ones_named() {
        let d = Config::from_toml(&format!(
            "{MINIMAL}[daemon.journal]\nfile_bytes = 65536\nfiles = 3\nqueue = 16\n"
        ))
        .unwrap()
        .daemon;
        assert_eq!(
            d.journal,
            JournalSettings {
                file_bytes: 65_536,
                files: 3,
                queue: 16
            }
        );
        assert_eq!(
            Config::from_toml(MINIMAL).unwrap().daemon.journal,
            JournalSettings::default()
        );
        let m = message(&format!("{MINIMAL}[daemon.journal]\nfiles = 1\n"));
        assert!(
            m.ends_with("daemon.journal.files = 1: must be from 2 to 1000"),
            "{m}"
        );
        let m = message(&format!("{MINIMAL}[daemon.journal]\nsize = 1\n"));
        assert!(
            m.contains("daemon.journal.size: unknown field `size`"),
            "{m}"
        );
    }

    #[test]
    fn start_within_names_its_limits() {
        let m = message(&with_daemon("start_within = \"7200s\""));
        assert!(
            m.contains("daemon.start_within = \"7200s\": must be longer than 0 s and at most 1 h"),
            "{m}"
        );
    }

    #[test]
    fn loopback_listener_needs_no_token() {
        let d = Config::from_toml(&with_daemon("listen = \"127.0.0.1:8420\""))
            .unwrap()
            .daemon;
        assert_eq!(d.listen, Some("127.0.0.1:8420".parse().unwrap()));
        assert!(Config::from_toml(&with_daemon("listen = \"[::1]:0\"")).is_ok());
    }

    #[test]
    fn listener_beyond_loopback_without_token_is_refused() {
        assert_eq!(
            message(&with_daemon("listen = \"0.0.0.0:8420\"")),
            format!(
                "config line {}: daemon.listen = \"0.0.0.0:8420\": a listener beyond loopback \
                 needs daemon.token_file (a bearer token for clients)",
                first_key_line()
            )
        );
    }

    #[test]
    fn a_socket_mode_that_lets_every_user_in_is_refused() {
        let line = first_key_line();
        for mode in ["0777", "0666", "0661", "0004", "0662"] {
            assert_eq!(
                message(&with_daemon(&format!("socket_mode = \"{mode}\""))),
                format!(
                    "config line {line}: daemon.socket_mode = \"{mode}\": lets every user of the \
                     machine move the robot (an \"other\" bit is set); at most 0770: give the \
                     robot's users the socket's group instead"
                )
            );
        }
        for mode in ["0770", "0660", "0600", "770"] {
            assert!(
                Config::from_toml(&with_daemon(&format!("socket_mode = \"{mode}\""))).is_ok(),
                "{mode}"
            );
        }
    }

    #[test]
    fn bad_values_name_key_value_and_line() {
        let line = first_key_line();
        assert_eq!(
            message(&with_daemon("socket_mode = \"0999\"")),
            format!(
                "config line {line}: daemon.socket_mode = \"0999\": must be octal permission \
                 bits, e.g. \"0660\""
            )
        );
        assert!(
            message(&with_daemon("listen = \"localhost\"")).starts_with(&format!(
                "config line {line}: daemon.listen = \"localhost\": "
            ))
        );
        assert!(
            message(&with_daemon("socket = \"\""))
                .starts_with(&format!("config line {line}: daemon.socket = \"\": "))
        );
        assert!(message(&with_daemon("port = 1")).starts_with(&format!(
            "config line {line}: daemon.port: unknown field `port`"
        )));
    }
}
