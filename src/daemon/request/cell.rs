//! What a robot's handle asks the owner of its cell (`daemon/cell`): the mode held while an
//! order is taken, the mode changed, a write to the cell face's command words. The owner takes
//! them one at a time; the mode and the face are published, not asked for
//! ([`crate::daemon::shared`]).

use thiserror::Error;
use tokio::sync::{OwnedRwLockReadGuard, oneshot};

use crate::cell::Mode;

/// Why a request was refused by the mode.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ModeError {
    /// The other controller drives the robot.
    #[error("{}", not_yours(*mode))]
    NotYours {
        /// The robot's mode.
        mode: Mode,
    },
    /// The mode changes only while the robot is idle.
    #[error("the mode changes only while nothing runs: {what}")]
    Busy {
        /// What runs.
        what: String,
    },
    /// Remote needs a cell face.
    #[error(
        "robot {robot} has no cell face ([robots.{robot}.cell.face]): it is driven locally only"
    )]
    NoFace {
        /// The robot.
        robot: String,
    },
    /// The daemon is shutting down: the robot's cell takes no more requests.
    #[error("the daemon is shutting down")]
    ShuttingDown,
}

fn not_yours(mode: Mode) -> &'static str {
    match mode {
        Mode::Remote => {
            "the robot is in remote mode: the cell face drives it (`linterpd mode local` takes it \
             back; `linterpd stop` works in both modes)"
        }
        Mode::Local => {
            "the robot is in local mode: the CLI and the API drive it (`linterpd mode remote` \
             gives it to the cell face)"
        }
    }
}

/// The mode held while an order is taken: it cannot change until this is dropped.
#[derive(Debug)]
pub struct Owner(
    #[allow(dead_code, reason = "held, not read")] pub(crate) OwnedRwLockReadGuard<Mode>,
);

/// A request to the robot's cell owner.
#[derive(Debug)]
pub(crate) enum CellRequest {
    /// The mode, held, when `who` drives the robot.
    Hold {
        /// Who asks to drive.
        who: Mode,
        /// The mode held, or who drives it.
        reply: oneshot::Sender<Result<Owner, ModeError>>,
    },
    /// Set who drives the robot.
    SetMode {
        /// The mode asked for.
        to: Mode,
        /// The mode set, or why not.
        reply: oneshot::Sender<Result<Mode, ModeError>>,
    },
    /// The line wrote `values` from command word `at`: answered once their actions were carried
    /// out (`false`: the robot has no face).
    FaceWrite {
        /// The first command word written.
        at: usize,
        /// The words.
        values: Vec<u16>,
        /// Whether the robot has a face.
        reply: oneshot::Sender<bool>,
    },
}
