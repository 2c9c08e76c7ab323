//! The robot in its press line, PURE: who drives it (the [`Mode`]) and the register face the
//! line's PLC or HMI drives it through ([`face`]). No IO and no clock: the daemon carries the
//! face's actions out and feeds it what the robot does (`daemon/cell_face.rs`).

pub mod face;

use std::fmt;

use serde::{Deserialize, Serialize};

/// Who drives the robot. One controller at a time: in `local` the CLI and the API start motion
/// and cycles, and the cell face's commands are refused; in `remote` the cell face does, and
/// the CLI's and API's are refused. A stop works in both, from both.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, Hash)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// The CLI and the API drive the robot.
    #[default]
    Local,
    /// The line's PLC or HMI drives the robot through the cell face.
    Remote,
}

impl Mode {
    /// Its name, as the config, the API and the CLI write it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Local => "local",
            Self::Remote => "remote",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A mode's name that is neither `local` nor `remote`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("mode {0:?}: `local` or `remote`")]
pub struct ModeError(pub String);

impl std::str::FromStr for Mode {
    type Err = ModeError;

    fn from_str(s: &str) -> Result<Self, ModeError> {
        match s {
            "local" => Ok(Self::Local),
            "remote" => Ok(Self::Remote),
            other => Err(ModeError(other.to_owned())),
        }
    }
}
