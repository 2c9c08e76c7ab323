//! What a robot's handle asks the owner of its cycle (`daemon/cycle`): at most one cycle at a
//! time, run, steered (stop, pause, hold, resume) and told what the robot did (stopped from
//! outside the cycle, its fault cleared). The owner answers each; the cycle's status is
//! published, not asked for ([`crate::daemon::shared`]).

use std::future::Future;
use std::pin::Pin;

use thiserror::Error;
use tokio::sync::{oneshot, watch};

use crate::cycle::runner::Control;
use crate::daemon::shared::CycleOut;
use crate::wire::CycleStatus;

/// Why a cycle request was refused.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CycleError {
    /// No cycle has run on this robot since the daemon started.
    #[error("no cycle has run on this robot since the daemon started")]
    NoCycle,
    /// A cycle is under way (run refused).
    #[error("cycle {program} is {state}: stop it first (linterpd cycle stop)")]
    Running {
        /// Its program.
        program: String,
        /// Its state.
        state: String,
    },
    /// The request does not fit the cycle's state.
    #[error("cycle {program} is {state}: {what}")]
    Conflict {
        /// Its program.
        program: String,
        /// Its state.
        state: String,
        /// Why the request does not fit.
        what: &'static str,
    },
    /// The program cannot run: unknown, or refused by the check (the step and value named).
    #[error("{0}")]
    Program(String),
    /// A faulted cycle resumes only after the fault was cleared.
    #[error(
        "cycle {program} faulted ({why}): clear the fault first (linterpd clear-fault), then resume"
    )]
    FaultNotCleared {
        /// Its program.
        program: String,
        /// Why it faulted.
        why: String,
    },
    /// The daemon is shutting down: the robot's cycle takes no more requests.
    #[error("the daemon is shutting down")]
    ShuttingDown,
}

/// A cycle's driver, started by the owner with the control it watches and the status it writes.
pub(crate) type CycleRunner = Box<
    dyn FnOnce(watch::Receiver<Control>, CycleOut) -> Pin<Box<dyn Future<Output = ()> + Send>>
        + Send,
>;

/// What a cycle request is answered with.
pub(crate) type Answer = oneshot::Sender<Result<CycleStatus, CycleError>>;

/// A request to the robot's cycle owner.
pub(crate) enum CycleRequest {
    /// Run a cycle (`status`: as it starts) with `runner` as its driver: refused while another
    /// is under way.
    Run {
        /// The cycle's status as it starts.
        status: CycleStatus,
        /// Its driver.
        runner: CycleRunner,
        /// The status, or why it was refused.
        reply: Answer,
    },
    /// Stop the cycle at the end of its current step, or `now`.
    Stop {
        /// At once (the robot stopped too), not at the step's end.
        now: bool,
        /// The status, or why it was refused.
        reply: Answer,
    },
    /// Pause the cycle at the end of its current step.
    Pause(Answer),
    /// Resume a paused cycle, or a faulted one whose fault was cleared at the PLC's incident
    /// count `incidents` (the count now).
    Resume {
        /// The PLC's incident count now.
        incidents: u64,
        /// The status as it goes on, or why it was refused.
        reply: Answer,
    },
    /// Hold the cycle from outside the PLC (`why`): whether one was under way.
    Hold {
        /// Why, in words.
        why: &'static str,
        /// Whether a cycle was under way.
        reply: oneshot::Sender<bool>,
    },
    /// The robot's fault was cleared at the PLC's incident count `incidents`.
    FaultCleared {
        /// The PLC's incident count at the clear.
        incidents: u64,
        /// Whether a faulted cycle may now resume.
        reply: oneshot::Sender<bool>,
    },
    /// The robot was stopped from outside the cycle: the cycle ends with it (answered once its
    /// control says so, before the stop is written).
    RobotStopped(oneshot::Sender<()>),
}

impl std::fmt::Debug for CycleRequest {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self {
            Self::Run { .. } => "Run",
            Self::Stop { .. } => "Stop",
            Self::Pause(_) => "Pause",
            Self::Resume { .. } => "Resume",
            Self::Hold { .. } => "Hold",
            Self::FaultCleared { .. } => "FaultCleared",
            Self::RobotStopped(_) => "RobotStopped",
        };
        f.write_str(name)
    }
}
