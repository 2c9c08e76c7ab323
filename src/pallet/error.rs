//! [`PalletError`]: why a pallet or a frame cannot be used, naming the pallet (or frame), the key
//! and the limit, or the slot that cannot be reached.

use thiserror::Error;

use super::{FrameError, PatternError};

/// Where on a pallet a refused pose is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SlotAt {
    /// The slot's index in fill order.
    pub index: usize,
    /// Its layer, row and column.
    pub layer: usize,
    /// Its row.
    pub row: usize,
    /// Its column.
    pub column: usize,
    /// Which pose of it: `the slot`, `approach waypoint 1`, ...
    pub what: String,
}

impl std::fmt::Display for SlotAt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "slot {} (layer {}, row {}, column {}), {}",
            self.index, self.layer, self.row, self.column, self.what
        )
    }
}

/// Why a pallet or a frame cannot be used.
#[derive(Debug, Error)]
pub enum PalletError {
    /// A value of a pallet's or a frame's table is refused.
    #[error("{owner}: {key} = {value}: {reason}")]
    Value {
        /// `pallet "out"` or `frame "station"`.
        owner: String,
        /// The key inside its table (`rows`, `kinds.B.turn_deg`).
        key: String,
        /// The value as written.
        value: String,
        /// What is wrong, with the limit.
        reason: String,
    },
    /// A key the rest of the table makes necessary is absent.
    #[error("{owner}: {key} is missing: {reason}")]
    Missing {
        /// `pallet "out"` or `frame "station"`.
        owner: String,
        /// The absent key.
        key: String,
        /// Why it is needed.
        reason: String,
    },
    /// Points that make no frame.
    #[error("{owner}: {source}")]
    Frame {
        /// `frame "station"` or `pallet "out"` (its corners).
        owner: String,
        /// Why.
        #[source]
        source: FrameError,
    },
    /// A `@name` point that names no taught position.
    #[error("{owner}: {key} = \"@{position}\": no position {position:?} is taught")]
    NotTaught {
        /// `frame "station"` or `pallet "out"`.
        owner: String,
        /// The key.
        key: String,
        /// The position's name.
        position: String,
    },
    /// A slot's pose (or one of its waypoints) the robot cannot reach or hold.
    #[error("pallet {pallet:?}, {at}: {reason}")]
    Unreachable {
        /// The pallet.
        pallet: String,
        /// The slot and the pose.
        at: SlotAt,
        /// Why (out of reach, a joint past its limit), with the limit.
        reason: String,
    },
    /// The built slots break a pattern's rule.
    #[error(transparent)]
    Pattern(#[from] PatternError),
}

impl PalletError {
    /// The key inside the pallet's or frame's table that this error is about, if one.
    #[must_use]
    pub fn key(&self) -> Option<&str> {
        match self {
            Self::Value { key, .. } | Self::Missing { key, .. } | Self::NotTaught { key, .. } => {
                Some(key)
            }
            _ => None,
        }
    }
}
