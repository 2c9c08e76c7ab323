//! [`ConfigError`]: everything that can be wrong with a config file or the choice of a robot in it.
//! File errors name the line, the key path and the value, and the limit where one applies.

use std::io;
use std::path::PathBuf;

use thiserror::Error;

/// Why a config cannot be used.
#[derive(Debug, Error)]
pub enum ConfigError {
    /// Not TOML, or not the schema: a syntax error, an unknown key, a missing key, a wrong type
    /// or an unknown name (as reported by the TOML parser).
    #[error("config line {line}: {}{message}", key.as_deref().map(|k| format!("{k}: ")).unwrap_or_default())]
    Syntax {
        /// 1-based line of the offending text.
        line: usize,
        /// Key path of the offending line (`robots.press-loader.motion.period`), when it could be
        /// read off the file.
        key: Option<String>,
        /// The parser's message.
        message: String,
    },
    /// A value linterpd does not accept.
    #[error("config line {line}: {key} = {value}: {reason}")]
    Invalid {
        /// 1-based line of the value.
        line: usize,
        /// Key path (`robots.press-loader.joints[2].max_freq_hz`).
        key: String,
        /// The value as written in TOML.
        value: String,
        /// What is wrong, with the limit where one applies.
        reason: String,
    },
    /// A key the rest of the table makes necessary is absent.
    #[error("config line {line}: {key} is missing: {reason}")]
    Missing {
        /// 1-based line of the table that lacks the key.
        line: usize,
        /// Key path of the absent key.
        key: String,
        /// Why it is needed.
        reason: String,
    },
    /// A pallet or frame that cannot be laid out or reached (a slot out of reach, points that
    /// make no frame).
    #[error("config line {line}: {key}: {error}")]
    Pallet {
        /// 1-based line of the pallet's or frame's table.
        line: usize,
        /// Its key path (`robots.press-loader.pallets.out`).
        key: String,
        /// What is wrong (shown in this error's message, not as its source).
        error: Box<crate::pallet::PalletError>,
    },
    /// The file defines no robot.
    #[error("config defines no robot: add a [robots.NAME] table")]
    NoRobots,
    /// Several robots and none named.
    #[error("config defines several robots ({known}); name one of them")]
    RobotNotChosen {
        /// The robots' names, comma separated, in file order.
        known: String,
    },
    /// A robot name the config does not define.
    #[error("config defines no robot {name:?}; it defines {known}")]
    UnknownRobot {
        /// The name asked for.
        name: String,
        /// The robots' names, comma separated, in file order.
        known: String,
    },
    /// What is wrong with a file, named.
    #[error("{}: {error}", path.display())]
    InFile {
        /// The file.
        path: PathBuf,
        /// What is wrong in it (shown in this error's message, not as its source).
        error: Box<ConfigError>,
    },
    /// The file could not be read.
    #[error("cannot read config file {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
}
