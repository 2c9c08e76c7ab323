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
                let _ = reply.send(self.start(*status, runner));
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

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use tokio::sync::{mpsc, oneshot, watch};

    use super::own;
    use crate::cycle::runner::Control;
    use crate::daemon::request::{CycleError, CycleRequest, CycleRunner};
    use crate::wire::{CycleState, CycleStatus};

    /// A driver that hands its control and status out, and does nothing by itself.
    fn handing_out(
        taken: oneshot::Sender<(watch::Receiver<Control>, super::CycleOut)>,
    ) -> CycleRunner {
        Box::new(move |control, status| {
            let _ = taken.send((control, status));
            Box::pin(async {})
        })
    }

    async fn ask<T>(
        to: &mpsc::UnboundedSender<CycleRequest>,
        request: impl FnOnce(oneshot::Sender<T>) -> CycleRequest,
    ) -> T {
        let (tx, rx) = oneshot::channel();
        to.send(request(tx)).unwrap();
        rx.await.unwrap()
    }

    #[tokio::test]
    async fn a_faulted_cycle_resumes_only_after_a_clear_with_no_incident_since() {
        let (out, published) = watch::channel(None);
        let (to, requests) = mpsc::unbounded_channel();
        tokio::spawn(own(Arc::new(out), requests));
        let (taken, driver) = oneshot::channel();
        let status = Box::new(CycleStatus::starting("p", Some(1)));
        let runner = handing_out(taken);
        ask(&to, |reply| CycleRequest::Run {
            status,
            runner,
            reply,
        })
        .await
        .unwrap();
        let (control, status) = driver.await.unwrap();
        // A second run is refused while the first is under way, naming it.
        let (again, _) = oneshot::channel();
        let (status2, runner2) = (
            Box::new(CycleStatus::starting("q", None)),
            handing_out(again),
        );
        let refused = ask(&to, |reply| CycleRequest::Run {
            status: status2,
            runner: runner2,
            reply,
        })
        .await;
        assert!(matches!(refused, Err(CycleError::Running { ref program, .. }) if program == "p"));
        // The driver faults the cycle.
        status.send_modify(|s| {
            let s = s.as_mut().unwrap();
            s.state = CycleState::Faulted;
            s.reason = Some("the PLC restarted".to_owned());
        });
        let resume = |incidents| move |reply| CycleRequest::Resume { incidents, reply };
        assert!(matches!(
            ask(&to, resume(1)).await,
            Err(CycleError::FaultNotCleared { .. })
        ));
        assert!(
            ask(&to, |reply| CycleRequest::FaultCleared {
                incidents: 1,
                reply
            })
            .await
        );
        // Another incident since the clear: it needs another clear.
        assert!(matches!(
            ask(&to, resume(2)).await,
            Err(CycleError::FaultNotCleared { .. })
        ));
        assert!(
            ask(&to, |reply| CycleRequest::FaultCleared {
                incidents: 2,
                reply
            })
            .await
        );
        let resumed = ask(&to, resume(2)).await.unwrap();
        assert_eq!(resumed.state, CycleState::Running);
        assert_eq!(
            published.borrow().as_ref().unwrap().state,
            CycleState::Running
        );
        assert_eq!(control.borrow().pause(), None);
        // A stop from outside the cycle reaches its control before the answer.
        ask(&to, CycleRequest::RobotStopped).await;
        assert!(control.borrow().stops_now());
    }
}
