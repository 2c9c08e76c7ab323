//! A robot's cycle: at most one at a time, its status as the runner last wrote it, and the
//! control value the runner watches. Requests that make no sense in the cycle's state (pause a
//! stopped cycle, run while one runs) are refused with the state named.

use std::future::Future;
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use thiserror::Error;
use tokio::sync::watch;

use crate::cycle::runner::Control;
use crate::wire::{CycleState, CycleStatus};

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
}

/// The shared status a runner writes.
pub(crate) type SharedStatus = Arc<Mutex<CycleStatus>>;

fn lock(status: &SharedStatus) -> MutexGuard<'_, CycleStatus> {
    status.lock().unwrap_or_else(PoisonError::into_inner)
}

/// One robot's cycle slot.
#[derive(Debug, Default)]
pub(crate) struct CycleSlot {
    current: Mutex<Option<Current>>,
}

#[derive(Debug)]
struct Current {
    status: SharedStatus,
    control: watch::Sender<Control>,
    /// The PLC's incident count when the fault the cycle is in was cleared (`None`: not cleared
    /// since it faulted). A resume needs it to be the count now: an incident after the clear
    /// needs another.
    cleared_at: Option<u64>,
}

fn state_name(state: CycleState) -> String {
    serde_json::to_value(state)
        .ok()
        .and_then(|v| v.as_str().map(str::to_owned))
        .unwrap_or_default()
}

impl CycleSlot {
    fn current(&self) -> MutexGuard<'_, Option<Current>> {
        self.current.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The cycle's status.
    pub(crate) fn status(&self) -> Option<CycleStatus> {
        self.current().as_ref().map(|c| lock(&c.status).clone())
    }

    /// Starts a cycle: `runner` gets the control to watch and the status to write. Refused
    /// while another cycle is under way (not stopped or done).
    pub(crate) fn start<F, Fut>(
        &self,
        status: CycleStatus,
        runner: F,
    ) -> Result<CycleStatus, CycleError>
    where
        F: FnOnce(watch::Receiver<Control>, SharedStatus) -> Fut,
        Fut: Future<Output = ()> + Send + 'static,
    {
        let mut current = self.current();
        if let Some(c) = current.as_ref() {
            let s = lock(&c.status);
            if !s.state.is_final() {
                return Err(CycleError::Running {
                    program: s.program.clone(),
                    state: state_name(s.state),
                });
            }
        }
        let shared = Arc::new(Mutex::new(status.clone()));
        let (control, watched) = watch::channel(Control::default());
        tokio::spawn(runner(watched, Arc::clone(&shared)));
        *current = Some(Current {
            status: shared,
            control,
            cleared_at: None,
        });
        Ok(status)
    }

    fn with_live<T>(
        &self,
        f: impl FnOnce(&mut Current, &CycleStatus) -> Result<T, CycleError>,
    ) -> Result<T, CycleError> {
        let mut current = self.current();
        let Some(c) = current.as_mut() else {
            return Err(CycleError::NoCycle);
        };
        let status = lock(&c.status).clone();
        f(c, &status)
    }

    /// Stops the cycle: at the end of its current step, or `now` (the robot stopped at once).
    pub(crate) fn stop(&self, now: bool) -> Result<CycleStatus, CycleError> {
        self.with_live(|c, s| {
            if s.state.is_final() {
                return Err(conflict(s, "it has ended already"));
            }
            c.control.send_modify(|k| k.stop(now));
            Ok(s.clone())
        })
    }

    /// Pauses the cycle at the end of its current step.
    pub(crate) fn pause(&self) -> Result<CycleStatus, CycleError> {
        self.with_live(|c, s| match s.state {
            CycleState::Running | CycleState::Waiting => {
                c.control.send_modify(Control::pause_asked);
                Ok(s.clone())
            }
            _ => Err(conflict(s, "only a running or waiting cycle pauses")),
        })
    }

    /// Holds the cycle from outside the PLC (`why`): the move running ends held and the cycle
    /// pauses (the caller stops the robot). Whether a cycle was under way.
    pub(crate) fn hold(&self, why: &'static str) -> bool {
        match self.current().as_ref() {
            Some(c) if !lock(&c.status).state.is_final() => {
                c.control.send_modify(|k| k.hold_asked(why));
                true
            }
            _ => false,
        }
    }

    /// Resumes a paused cycle, or a faulted one whose fault was cleared with no incident since
    /// (`incidents`: the PLC's incident count now). The status returned is the cycle's as it
    /// goes on: running, at the step it was at.
    pub(crate) fn resume(&self, incidents: u64) -> Result<CycleStatus, CycleError> {
        let mut current = self.current();
        let Some(c) = current.as_mut() else {
            return Err(CycleError::NoCycle);
        };
        let mut status = lock(&c.status);
        let epoch = match status.state {
            CycleState::Paused => None,
            CycleState::Faulted if c.cleared_at == Some(incidents) => c.cleared_at.take(),
            CycleState::Faulted => {
                return Err(CycleError::FaultNotCleared {
                    program: status.program.clone(),
                    why: status.reason.clone().unwrap_or_default(),
                });
            }
            _ => return Err(conflict(&status, "only a paused or faulted cycle resumes")),
        };
        c.control.send_modify(|k| k.resume(epoch));
        // What the runner writes as it takes the resume; said here so the answer is true.
        status.state = CycleState::Running;
        status.reason = None;
        Ok(status.clone())
    }

    /// The robot's fault was cleared (at the PLC's incident count `incidents`): a faulted
    /// cycle may resume. Whether one was faulted.
    pub(crate) fn fault_cleared(&self, incidents: u64) -> bool {
        let mut current = self.current();
        match current.as_mut() {
            Some(c) if lock(&c.status).state == CycleState::Faulted => {
                c.cleared_at = Some(incidents);
                true
            }
            _ => false,
        }
    }

    /// The robot was stopped from outside the cycle (`linterpd stop`): the cycle ends with it.
    pub(crate) fn robot_stopped(&self) {
        if let Some(c) = self.current().as_ref() {
            c.control.send_modify(|k| k.stop(true));
        }
    }
}

fn conflict(s: &CycleStatus, what: &'static str) -> CycleError {
    CycleError::Conflict {
        program: s.program.clone(),
        state: state_name(s.state),
        what,
    }
}
