//! A robot's cycle and its one owner: a task that takes the cycle requests one at a time (at
//! most one cycle under way, steered by the control value its driver watches) and publishes the
//! status the driver writes ([`CycleOut`]). Requests that make no sense in the cycle's state
//! (pause a stopped cycle, run while one runs) are refused with the state named.
//!
//! ```text
//!  handles --CycleRequest--> own(): CycleSlot --Control (watch)--> the cycle's driver
//!  handles <--Option<CycleStatus> (watch)-- CycleSlot (starts, resumes), driver (the rest)
//! ```

use tokio::sync::{mpsc, watch};

use crate::cycle::runner::Control;
use crate::daemon::request::{CycleError, CycleRequest, CycleRunner};
use crate::daemon::shared::CycleOut;
use crate::wire::{CycleState, CycleStatus};

/// Takes `requests` until every handle is gone.
pub(crate) async fn own(out: CycleOut, mut requests: mpsc::UnboundedReceiver<CycleRequest>) {
    let mut slot = CycleSlot { out, current: None };
    while let Some(request) = requests.recv().await {
        slot.take(request);
    }
}

/// One robot's cycle slot.
struct CycleSlot {
    /// The cycle's status, published.
    out: CycleOut,
    current: Option<Current>,
}

struct Current {
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
    fn take(&mut self, request: CycleRequest) {
        match request {
            CycleRequest::Run {
                status,
                runner,
                reply,
            } => {
                let _ = reply.send(self.start(status, runner));
            }
            CycleRequest::Stop { now, reply } => {
                let _ = reply.send(self.stop(now));
            }
            CycleRequest::Pause(reply) => {
                let _ = reply.send(self.pause());
            }
            CycleRequest::Resume { incidents, reply } => {
                let _ = reply.send(self.resume(incidents));
            }
            CycleRequest::Hold { why, reply } => {
                let _ = reply.send(self.hold(why));
            }
            CycleRequest::FaultCleared { incidents, reply } => {
                let _ = reply.send(self.fault_cleared(incidents));
            }
            CycleRequest::RobotStopped(reply) => {
                self.robot_stopped();
                let _ = reply.send(());
            }
        }
    }

    /// The cycle's status.
    fn status(&self) -> Option<CycleStatus> {
        self.out.borrow().clone()
    }

    /// Starts a cycle: `runner` gets the control to watch and the status to write. Refused
    /// while another cycle is under way (not stopped or done).
    fn start(
        &mut self,
        status: CycleStatus,
        runner: CycleRunner,
    ) -> Result<CycleStatus, CycleError> {
        if let Some(s) = self.status().filter(|s| !s.state.is_final()) {
            return Err(CycleError::Running {
                program: s.program,
                state: state_name(s.state),
            });
        }
        self.out.send_replace(Some(status.clone()));
        let (control, watched) = watch::channel(Control::default());
        tokio::spawn(runner(watched, std::sync::Arc::clone(&self.out)));
        self.current = Some(Current {
            control,
            cleared_at: None,
        });
        Ok(status)
    }

    fn with_live<T>(
        &mut self,
        f: impl FnOnce(&mut Current, &CycleStatus) -> Result<T, CycleError>,
    ) -> Result<T, CycleError> {
        let status = self.status();
        match (self.current.as_mut(), status) {
            (Some(c), Some(status)) => f(c, &status),
            _ => Err(CycleError::NoCycle),
        }
    }

    /// Stops the cycle: at the end of its current step, or `now` (the robot stopped at once).
    fn stop(&mut self, now: bool) -> Result<CycleStatus, CycleError> {
        self.with_live(|c, s| {
            if s.state.is_final() {
                return Err(conflict(s, "it has ended already"));
            }
            c.control.send_modify(|k| k.stop(now));
            Ok(s.clone())
        })
    }

    /// Pauses the cycle at the end of its current step.
    fn pause(&mut self) -> Result<CycleStatus, CycleError> {
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
    fn hold(&mut self, why: &'static str) -> bool {
        self.with_live(|c, s| {
            if s.state.is_final() {
                return Ok(false);
            }
            c.control.send_modify(|k| k.hold_asked(why));
            Ok(true)
        })
        .unwrap_or(false)
    }

    /// Resumes a paused cycle, or a faulted one whose fault was cleared with no incident since
    /// (`incidents`: the PLC's incident count now). The status returned is the cycle's as it
    /// goes on: running, at the step it was at.
    fn resume(&mut self, incidents: u64) -> Result<CycleStatus, CycleError> {
        let status = self.with_live(|c, s| {
            let epoch = match s.state {
                CycleState::Paused => None,
                CycleState::Faulted if c.cleared_at == Some(incidents) => c.cleared_at.take(),
                CycleState::Faulted => {
                    return Err(CycleError::FaultNotCleared {
                        program: s.program.clone(),
                        why: s.reason.clone().unwrap_or_default(),
                    });
                }
                _ => return Err(conflict(s, "only a paused or faulted cycle resumes")),
            };
            c.control.send_modify(|k| k.resume(epoch));
            Ok(s.clone())
        })?;
        // What the driver writes as it takes the resume; said here so the answer is true.
        let mut resumed = None;
        self.out.send_modify(|s| {
            if let Some(s) = s.as_mut() {
                s.state = CycleState::Running;
                s.reason = None;
                resumed = Some(s.clone());
            }
        });
        Ok(resumed.unwrap_or(status))
    }

    /// The robot's fault was cleared (at the PLC's incident count `incidents`): a faulted
    /// cycle may resume. Whether one was faulted.
    fn fault_cleared(&mut self, incidents: u64) -> bool {
        self.with_live(|c, s| {
            if s.state != CycleState::Faulted {
                return Ok(false);
            }
            c.cleared_at = Some(incidents);
            Ok(true)
        })
        .unwrap_or(false)
    }

    /// The robot was stopped from outside the cycle (`linterpd stop`): the cycle ends with it.
    fn robot_stopped(&mut self) {
        if let Some(c) = &self.current {
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
