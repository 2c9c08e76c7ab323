//! What a robot's handle asks its worker, and the typed answers: a refusal by the PLC, a link
//! that is down and a daemon that is shutting down are different errors, each with its own status
//! at the API.

use thiserror::Error;
use tokio::sync::oneshot;

use super::order::CheckedOrder;
use super::report::MoveId;

/// Why a stop, home or clear-fault did not happen.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CommandError {
    /// The PLC link is down (or its program does not answer as the contract says).
    #[error("the PLC link is down{}", detail.as_ref().map(|d| format!(": {d}")).unwrap_or_default())]
    LinkDown {
        /// The last link error.
        detail: Option<String>,
    },
    /// The robot's state does not allow it (a move runs, no fault to clear, not homed...).
    #[error("{0}")]
    Conflict(String),
    /// The PLC refused or failed to carry it out.
    #[error("{0}")]
    Plc(String),
    /// The daemon is shutting down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
}

/// A command's answer channel.
pub(super) type Reply = oneshot::Sender<Result<(), CommandError>>;

/// What the worker is asked to do (stops come on their own channel, to overtake).
#[derive(Debug)]
pub(super) enum Request {
    /// Run a checked order as move `id`.
    Move(MoveId, CheckedOrder),
    /// Home the robot (answered when the home routine has ended).
    Home(Reply),
    /// Clear a latched fault.
    ClearFault(Reply),
}
