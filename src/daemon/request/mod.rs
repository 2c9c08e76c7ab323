//! What a robot's handle asks the owners of the robot's state, and their typed answers: its
//! worker (moves, home, clear-fault; a refusal by the PLC, a link that is down and a daemon that
//! is shutting down are different errors, each with its own status at the API), its cycle's
//! owner ([`cycle`]) and its cell's ([`cell`]). The handle only sends these; the owners
//! (`daemon/worker`, `daemon/cycle`, `daemon/cell`) take them, one at a time.

mod cell;
mod cycle;

pub(crate) use cell::CellRequest;
pub use cell::{ModeError, Owner};
pub use cycle::CycleError;
pub(crate) use cycle::{CycleRequest, CycleRunner};

use thiserror::Error;
use tokio::sync::oneshot;

use crate::contract::State;
use crate::contract::machine::Blocker;
use crate::kinematics::JOINTS;
use crate::order::CheckedOrder;
use crate::order::OrderError;
use crate::plan::PlanError;
use crate::plc::exchange::fault_meaning;
use crate::wire::{MoveId, MoveReport};

/// Why a move was not accepted.
#[derive(Debug, Error)]
pub enum SubmitError {
    /// A field of the order is wrong.
    #[error(transparent)]
    Order(#[from] OrderError),
    /// The move cannot be planned from where the robot is (or will be).
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// A taught position kept in a frame cannot be carried to the world now.
    #[error(transparent)]
    Taught(#[from] crate::pallet::PalletError),
    /// The robot cannot take a move now (link down, not homed, a fault...).
    #[error("{blocker}{}", detail.as_ref().map(|d| format!(": {d}")).unwrap_or_default())]
    NotNow {
        /// Why.
        blocker: Blocker,
        /// The link's last error, when that is why.
        detail: Option<String>,
    },
    /// The queue would hold more starts than it takes.
    #[error(
        "{queued} starts are queued or running and the order adds {adding}; at most {limit} \
         at once: wait for some to end"
    )]
    QueueFull {
        /// Starts queued or running now.
        queued: usize,
        /// Starts the order would add.
        adding: usize,
        /// The most, [`MAX_QUEUED_STARTS`].
        limit: usize,
    },
    /// The robot is in remote mode and the cell face's move-enable is off.
    #[error(
        "the cell face's move-enable is off (remote mode): no motion until the line turns it on"
    )]
    MoveEnableOff,
    /// The daemon is shutting down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// Asked for by a cycle before the PLC restarted, stalled or was lost: refused.
    #[error("{why} since the cycle asked for it")]
    Untrusted {
        /// What happened.
        why: String,
    },
}

/// The most starts a robot's queue holds, the running one included: an order that would pass
/// it is refused whole.
pub const MAX_QUEUED_STARTS: usize = 1_000;

/// Why a stop, home or clear-fault did not happen.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CommandError {
    /// The PLC link is down (or its program does not answer as the contract says).
    #[error("the PLC link is down{}", detail.as_ref().map(|d| format!(": {d}")).unwrap_or_default())]
    LinkDown {
        /// The last link error.
        detail: Option<String>,
    },
    /// The robot's state does not allow it now.
    #[error("{reason}")]
    Conflict {
        /// What is in the way.
        reason: ConflictReason,
    },
    /// The PLC refused the command or failed to carry it out (an exchange that failed other
    /// than by the link going down).
    #[error("{detail}")]
    Plc {
        /// What the PLC answered, or how the exchange failed.
        detail: String,
    },
    /// The PLC's home routine ended without the robot homed.
    #[error("{}", home_failure(*fault))]
    HomeFailed {
        /// The fault word it latched (0: none, the homed bit just stayed clear).
        fault: u16,
    },
    /// The daemon is shutting down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
}

/// What keeps a command from being carried out now.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum ConflictReason {
    /// A stop was taken while the command waited.
    #[error("a stop came first; ask again")]
    StopCameFirst,
    /// A fault is cleared only when nothing runs.
    #[error("the PLC is {}: stop it first; a fault is cleared only when nothing runs", state.name())]
    PlcBusy {
        /// The PLC program's state (running or homing).
        state: State,
    },
    /// There is no fault to clear.
    #[error("the PLC reports no fault")]
    NoFault,
    /// Homing while a move runs.
    #[error("a move runs: stop it before homing")]
    MoveRuns,
    /// Homing while the home routine runs.
    #[error("the robot is already homing")]
    AlreadyHoming,
    /// Homing with a fault latched.
    #[error("the PLC reports fault {fault}: clear it before homing")]
    FaultLatched {
        /// The fault word.
        fault: u16,
    },
}

/// Why the home routine failed, in words.
fn home_failure(fault: u16) -> String {
    if fault == 0 {
        "the home routine did not end with the homed bit set".to_owned()
    } else {
        format!(
            "the home routine failed: fault {fault} ({})",
            fault_meaning(fault)
        )
    }
}

/// A command's answer channel.
pub(super) type Reply = oneshot::Sender<Result<(), CommandError>>;

/// What the worker is asked to do (stops come on their own channel, to overtake).
#[derive(Debug)]
pub(super) enum Request {
    /// Queue a checked order's starts (one, or the parts of a path or of a line cut), whole or
    /// not at all; answered with their ids.
    Moves(Batch),
    /// Home the robot (answered when the home routine has ended).
    Home(Reply),
    /// Clear a latched fault.
    ClearFault(Reply),
}

/// One order's starts given to the worker, each a move it runs in its turn.
#[derive(Debug)]
pub(super) struct Batch {
    /// Each start's report (as accepted) and checked order (planned, when its start was known).
    pub starts: Vec<(MoveReport, CheckedOrder)>,
    /// Where the last start is planned to end (the next order is planned from there).
    pub end: Option<[i64; JOINTS]>,
    /// The gate the first start waits for once it is uploaded (a cycle's move or path prepared
    /// ahead); the starts behind it are queued behind it, ungated.
    pub gate: Option<crate::daemon::gate::Gate>,
    /// The PLC's incident count it was asked under (a cycle's move): cancelled at its turn once
    /// another incident came; `None`: whenever.
    pub epoch: Option<u64>,
    /// The answer: the starts' ids, or why none was queued.
    pub reply: oneshot::Sender<Result<Vec<MoveId>, SubmitError>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_conflict_says_what_is_in_the_way_as_before() {
        let said = |reason| CommandError::Conflict { reason }.to_string();
        assert_eq!(
            said(ConflictReason::PlcBusy {
                state: State::Homing
            }),
            "the PLC is homing: stop it first; a fault is cleared only when nothing runs"
        );
        assert_eq!(said(ConflictReason::NoFault), "the PLC reports no fault");
        assert_eq!(
            said(ConflictReason::FaultLatched { fault: 4 }),
            "the PLC reports fault 4: clear it before homing"
        );
        assert_eq!(
            said(ConflictReason::StopCameFirst),
            "a stop came first; ask again"
        );
    }

    #[test]
    fn a_failed_home_names_its_fault_and_its_meaning() {
        assert_eq!(
            CommandError::HomeFailed { fault: 0 }.to_string(),
            "the home routine did not end with the homed bit set"
        );
        let text = CommandError::HomeFailed { fault: 3 }.to_string();
        assert_eq!(
            text,
            format!("the home routine failed: fault 3 ({})", fault_meaning(3))
        );
    }
}
