//! What a cycle's steps do to the robot, each through the robot's handle as any client would:
//! a move or a path queued and followed to its end, a wait on the cell's inputs decided on every
//! status block the worker reads, outputs written through the gateway, a dwell. Each gives way
//! to a control request (stop now, or a stop / pause that waits for the step's end) as soon as
//! one comes.

use std::time::Duration;

use tokio::sync::watch;

use super::control::Control;
use crate::contract::INPUT_WORDS;
use crate::cycle::Condition;
use crate::daemon::{MoveOrder, PathOrder, RobotHandle};
use crate::gateway::Address;
use crate::wire::{MoveId, MoveReport, Stage};

/// How a step's motion ended.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum MotionEnd {
    /// Every start of it ended done.
    Done,
    /// The PLC held it (its permit dropped): the robot stands where it stopped.
    Held {
        /// The report's words (which input dropped).
        why: String,
    },
    /// It was refused, failed, stopped or cancelled.
    Failed {
        /// Why.
        why: String,
    },
    /// A stop asked for now: the robot was stopped.
    StoppedNow,
}

/// Queues `order`: the ids of its starts, or how the step ends when it cannot be queued (held
/// from outside the PLC, or refused).
pub(super) async fn submit_move(
    handle: &RobotHandle,
    order: MoveOrder,
    control: &watch::Receiver<Control>,
) -> Result<Vec<MoveId>, MotionEnd> {
    let hold = control.borrow().hold;
    if let Some(why) = hold {
        return Err(MotionEnd::Held {
            why: why.to_owned(),
        });
    }
    handle
        .submit_starts(order)
        .await
        .map_err(|e| MotionEnd::Failed {
            why: format!("refused: {e}"),
        })
}

/// Queues `order` (a path) and follows every start of it to its end.
pub(super) async fn run_path(
    handle: &RobotHandle,
    order: &PathOrder,
    control: &mut watch::Receiver<Control>,
    started: &mut Vec<MoveId>,
) -> MotionEnd {
    let hold = control.borrow().hold;
    if let Some(why) = hold {
        return MotionEnd::Held {
            why: why.to_owned(),
        };
    }
    // The handle plans it off the runtime (a path takes milliseconds), as for the API.
    match handle.submit_path(order).await {
        Ok(ids) => follow(handle, &ids, control, started).await,
        Err(e) => MotionEnd::Failed {
            why: format!("refused: {e}"),
        },
    }
}

/// Follows every start of `ids` to its end.
pub(super) async fn follow(
    handle: &RobotHandle,
    ids: &[MoveId],
    control: &mut watch::Receiver<Control>,
    started: &mut Vec<MoveId>,
) -> MotionEnd {
    started.extend_from_slice(ids);
    for &id in ids {
        let Some(mut feed) = handle.subscribe(id) else {
            return MotionEnd::Failed {
                why: format!("move {id} has no report"),
            };
        };
        let report = loop {
            let ended = async {
                let r = feed.wait_for(|r| r.stage.is_final()).await;
                r.map(|r| r.clone()).ok()
            };
            tokio::select! {
                ended = ended => break ended,
                changed = control.changed() => {
                    if changed.is_err() || control.borrow().stop_now {
                        let _ = handle.stop().await;
                        return MotionEnd::StoppedNow;
                    }
                }
            }
        };
        // A hold from outside the PLC is set before the robot is stopped: the move that ends
        // short under it was held.
        let held = control.borrow().hold;
        match report.or_else(|| handle.report(id)) {
            Some(r) if r.stage == Stage::Done => {}
            Some(_) if held.is_some() => {
                return MotionEnd::Held {
                    why: held.unwrap_or_default().to_owned(),
                };
            }
            Some(r) => return ended_short(&r),
            None => {
                return MotionEnd::Failed {
                    why: format!("move {id}'s report was dropped"),
                };
            }
        }
    }
    MotionEnd::Done
}

fn ended_short(r: &MoveReport) -> MotionEnd {
    let why = r.error.clone().unwrap_or_else(|| r.stage.name().to_owned());
    if r.held() {
        MotionEnd::Held { why }
    } else {
        MotionEnd::Failed {
            why: format!("move {} ended {}: {why}", r.id, r.stage.name()),
        }
    }
}

/// The oldest status block a wait is decided on (two busy polls).
pub(super) const FRESH: Duration = Duration::from_millis(40);

/// How a wait ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum WaitEnd {
    /// The condition held.
    Met,
    /// The timeout passed first.
    TimedOut,
    /// A stop asked for (now, or at the step's end: a wait moves nothing, so it ends at once).
    StoppedNow,
    /// A pause asked for: the wait gives way, and is waited again on resume.
    Paused,
}

/// What a wait decides on: the cell's input words of a status block, and the words a condition
/// reads beyond them (DT words, bits outside the input words), read through the gateway.
pub(super) struct Inputs {
    /// The status block's input words (`None` while the link is down: nothing is met).
    pub words: Option<[u16; INPUT_WORDS]>,
    /// The extra reads, in the order asked.
    pub reads: Vec<(Address, Option<u16>)>,
}

/// Waits until `holds` says the inputs meet the condition, deciding on every status block the
/// worker reads (and reading `extra` through the gateway each time, when the condition needs
/// it), at most `timeout`.
pub(super) async fn wait_until(
    handle: &RobotHandle,
    holds: impl Fn(&Inputs) -> bool,
    extra: &[Address],
    timeout: Option<Duration>,
    control: &mut watch::Receiver<Control>,
) -> WaitEnd {
    let mut reads = handle.watch_reads();
    let deadline = timeout.map(|t| tokio::time::Instant::now() + t);
    let _watching = Watching::inputs(handle);
    wait_loop(handle, holds, extra, deadline, control, &mut reads).await
}

/// The worker reads the status block at its busy pace while this lives: dropped when the wait
/// ends, or is given up (the cycle faulted on an incident meanwhile).
struct Watching<'h>(&'h RobotHandle);

impl<'h> Watching<'h> {
    fn inputs(handle: &'h RobotHandle) -> Self {
        handle.watch_inputs(true);
        Self(handle)
    }
}

impl Drop for Watching<'_> {
    fn drop(&mut self) {
        self.0.watch_inputs(false);
    }
}

async fn wait_loop(
    handle: &RobotHandle,
    holds: impl Fn(&Inputs) -> bool,
    extra: &[Address],
    deadline: Option<tokio::time::Instant>,
    control: &mut watch::Receiver<Control>,
    reads: &mut crate::daemon::Reads,
) -> WaitEnd {
    loop {
        let inputs = Inputs::read(handle, extra).await;
        // Decided only on a status block read within the last poll or two: one read while the
        // robot stood (every 250 ms) may show an input that has changed since.
        let fresh = handle.since_status_read().is_some_and(|age| age <= FRESH);
        if fresh && inputs.words.is_some() && holds(&inputs) {
            return WaitEnd::Met;
        }
        let expired = async {
            match deadline {
                Some(at) => tokio::time::sleep_until(at).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            read = reads.next() => {
                if read.is_err() {
                    // The robot's worker is gone (the daemon shuts down): nothing more is read.
                    return WaitEnd::StoppedNow;
                }
            }
            () = expired => return WaitEnd::TimedOut,
            changed = control.changed() => {
                let c = *control.borrow();
                if changed.is_err() || c.stop_now || c.stop {
                    return WaitEnd::StoppedNow;
                }
                if c.pause {
                    return WaitEnd::Paused;
                }
            }
        }
    }
}

impl Inputs {
    /// The input words of the last status block, and `extra` read through the gateway now.
    pub(super) async fn read(handle: &RobotHandle, extra: &[Address]) -> Self {
        let mut reads = Vec::with_capacity(extra.len());
        for &address in extra {
            reads.push((address, read_one(handle, address).await));
        }
        Self {
            words: handle.state().inputs,
            reads,
        }
    }

    /// Whether `until` holds on them (never while the input words are unknown).
    pub(super) fn meet(&self, until: &Condition) -> bool {
        let read = |a| {
            self.reads
                .iter()
                .find(|(r, _)| *r == a)
                .and_then(|(_, v)| *v)
        };
        self.words.is_some_and(|w| until.holds(&w, &read))
    }
}

/// One word or bit read through the gateway (`None`: it could not be read).
async fn read_one(handle: &RobotHandle, address: Address) -> Option<u16> {
    match handle.read_registers(address, 1).await {
        Ok(crate::daemon::Values::Words(w)) => w.first().copied(),
        Ok(crate::daemon::Values::Bits(b)) => b.first().map(|&on| u16::from(on)),
        Err(_) => None,
    }
}

/// Sleeps `for_`, or until a stop (now or at the step's end: a dwell moves nothing): whether it
/// slept the whole time.
pub(super) async fn dwell(for_: Duration, control: &mut watch::Receiver<Control>) -> bool {
    let end = tokio::time::Instant::now() + for_;
    loop {
        tokio::select! {
            () = tokio::time::sleep_until(end) => return true,
            changed = control.changed() => {
                let c = *control.borrow();
                if changed.is_err() || c.stop_now || c.stop {
                    return false;
                }
            }
        }
    }
}
