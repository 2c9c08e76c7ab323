//! What a robot's handle asks its worker, and the typed answers: a refusal by the PLC, a link
//! that is down and a daemon that is shutting down are different errors, each with its own status
//! at the API.

use thiserror::Error;
use tokio::sync::oneshot;

use crate::contract::State;
use crate::kinematics::JOINTS;
use crate::order::CheckedOrder;
use crate::plc::exchange::fault_meaning;
use crate::wire::{MoveId, MoveReport};

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
    /// The gate a single start waits for once it is uploaded (a cycle's move prepared ahead).
    pub gate: Option<super::gate::Gate>,
    /// The PLC's incident count it was asked under (a cycle's move): cancelled at its turn once
    /// another incident came; `None`: whenever.
    pub epoch: Option<u64>,
    /// The answer: the starts' ids, or why none was queued.
    pub reply: oneshot::Sender<Result<Vec<MoveId>, super::SubmitError>>,
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
