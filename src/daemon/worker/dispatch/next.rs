//! PURE. What the worker does next, as a value ([`Action`]): from what it is doing
//! ([`Activity`]), what it took in ([`Seen`]) and `now`. The driver carries the action out over
//! its session and feeds back what came of it ([`Dispatcher::polled`], [`Dispatcher::proven`],
//! [`Dispatcher::uploaded`], ...); it decides nothing itself.
//!
//! ```text
//!   Idle:      shut down | connect | stop | commands | finish | read mode | judge a path's
//!              first part behind the start running | begin | gateway
//!              (taking turns with the status read when both are due) | poll | wait
//!   Uploading: one exchange of the bank (a status read first when one is due)
//!   Preloading: one exchange of a path's second part ahead (a status read first when one is
//!              due), or abandoned for what overtakes it
//!   Holding:   release (write the start, or prove it) | cancel | gateway | poll | wait on its gate
//!   Proving:   one proof read, a pause of half a scan between two | the start written once
//! ```

use std::time::{Duration, Instant};

use super::{Activity, CYCLE_WENT_ON, Dispatcher, Finish, Hold, Queued, Uploaded, Uploading};
use crate::contract::machine::{Blocker, Phase, Planned};
use crate::daemon::gate::{Gate, GateState};
use crate::wire::MoveId;

/// How often the worker reads the status block: at the busy pace, and a scan apart near a
/// move's planned end (the contract's settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::daemon::worker) struct PollPace {
    /// The busy pace.
    pub poll_interval: Duration,
    /// The PLC's scan time.
    pub scan_time: Duration,
}

/// Polling while nothing is in flight (the heartbeat's freshness comes from these reads).
const IDLE_POLL: Duration = Duration::from_millis(250);
/// How often the PLC's mode (RUN / PROG) is read while nothing is in flight.
const MODE_POLL: Duration = Duration::from_secs(10);

/// While the link is down, when it is opened again.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(in crate::daemon::worker) enum Retry {
    /// At once (the link just failed, or what came during the backoff was answered).
    #[default]
    Now,
    /// An attempt failed: the worker waits until then.
    At(Instant),
    /// The backoff is over: what came meanwhile is answered, then the link opened.
    Answering,
}

/// What the driver has taken in, as far as the next step depends on it: each an independent
/// fact of the moment, not a mode.
#[allow(clippy::struct_excessive_bools)]
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(in crate::daemon::worker) struct Seen {
    /// A session is open.
    pub link_up: bool,
    /// The daemon shuts down.
    pub shutting_down: bool,
    /// A stop waits to be written.
    pub stop: bool,
    /// A home or clear-fault request waits.
    pub commands: bool,
    /// A register gateway request waits.
    pub gateway: bool,
    /// A stop was asked for and is on its way (it cancels a held bank).
    pub stop_pending: bool,
}

/// The next step of the worker, carried out by its driver.
#[derive(Debug)]
pub(in crate::daemon::worker) enum Action {
    /// Withdraw a waiting start, end everything queued, answer everything waiting; then stop.
    ShutDown,
    /// Open the link (it is down and nothing is between its turn and its start).
    Connect,
    /// Write the stop asked for; the queue is cancelled.
    Stop,
    /// Carry out the home and clear-fault requests (answered `link down` without a link).
    Commands,
    /// End these reports (a queue that expired, prepared moves whose gate shut).
    Finish(Vec<Finish>),
    /// Read the PLC's mode (RUN / PROG).
    ReadMode,
    /// Begin the head of the queue: its turn on a fresh status block, planned, its section's
    /// parts preloaded, its upload made ready ([`Activity::Uploading`]).
    Begin(Box<Queued>),
    /// Judge whether the head of the queue, the first part of a path section cut into parts,
    /// may begin behind start `behind` ([`super::Lead`]): no exchange, its parts planned.
    JudgeLead {
        /// The head.
        id: MoveId,
        /// The start running, it would begin behind.
        behind: Box<Planned>,
    },
    /// Begin preloading a path's second part ahead of its first part's turn
    /// ([`Dispatcher::ahead_due`]).
    PreloadAhead(Box<super::AheadDue>),
    /// One exchange of a preload ahead; `watch`: a status read first.
    AheadStep {
        /// The preload.
        ahead: Box<super::Ahead>,
        /// Whether the status block is read first.
        watch: bool,
    },
    /// One exchange of the upload; `watch`: a status read first (a start runs meanwhile).
    UploadStep {
        /// The upload.
        uploading: Box<Uploading>,
        /// Whether the status block is read first.
        watch: bool,
    },
    /// One proof read for the start of this bank.
    ProveRead(Box<Uploaded>),
    /// Write the start of this bank, once.
    WriteStart(Box<Uploaded>),
    /// Cancel prepared move `id` before its start (`why`).
    Unprepare {
        /// The move.
        id: MoveId,
        /// Why.
        why: String,
    },
    /// One register gateway exchange.
    Gateway,
    /// Read the status block and apply it.
    Poll,
    /// Pause until `until`, taking nothing in meanwhile (between two proof reads).
    Pause {
        /// The end of the pause.
        until: Instant,
    },
    /// Wait for what comes next: until `until`, a request, a stop, or `gate` deciding.
    Wait {
        /// The latest the wait lasts.
        until: Instant,
        /// A held bank's gate, still closed.
        gate: Option<Gate>,
    },
}

impl Dispatcher {
    /// The next step, given what was `seen` at `now`. The activity it continues is taken into
    /// the action (the driver puts back what comes of it) or left in place.
    pub(in crate::daemon::worker) fn next(&mut self, seen: Seen, now: Instant) -> Action {
        let just_polled = std::mem::take(&mut self.just_polled);
        match std::mem::take(&mut self.activity) {
            Activity::Idle => self.next_idle(seen, now),
            Activity::Uploading(uploading) => self.next_upload(uploading, now),
            Activity::Holding(held) => self.next_hold(held, seen, just_polled, now),
            Activity::Preloading(ahead) => self.next_ahead(ahead, seen, now),
            Activity::Proving(uploaded, not_before) => match not_before {
                Some(until) if now < until => {
                    self.activity = Activity::Proving(uploaded, None);
                    Action::Pause { until }
                }
                _ => Action::ProveRead(uploaded),
            },
        }
    }

    /// A round with no move between its turn and its start: a stop first, then commands, the
    /// queue's ends, the mode read a poll asked for, a move to begin, the status block when its
    /// read is due or one register gateway exchange, else a wait.
    fn next_idle(&mut self, seen: Seen, now: Instant) -> Action {
        if seen.shutting_down {
            return Action::ShutDown;
        }
        if !seen.link_up {
            return self.next_offline(seen, now);
        }
        if seen.stop {
            return Action::Stop;
        }
        if seen.commands {
            return Action::Commands;
        }
        let mut ends = self.drop_shut();
        ends.extend(self.expire(true, now));
        if !ends.is_empty() {
            return Action::Finish(ends);
        }
        if std::mem::take(&mut self.mode_due) {
            return Action::ReadMode;
        }
        if let Some(action) = self.next_lead(now) {
            return action;
        }
        if self.has_room(now) {
            self.next_poll = None;
            let head = self.queue.pop_front().expect("room for the head");
            return Action::Begin(Box::new(head));
        }
        let poll_due = self.poll_due(now);
        // Gateway exchanges go between the worker's own, one at a time; when the status read is
        // due too they take turns, so neither waits behind more than one of the other.
        if seen.gateway && (!poll_due || self.gateway_turn) {
            self.gateway_turn = false;
            return Action::Gateway;
        }
        match self.next_poll {
            Some(until) if !poll_due => Action::Wait { until, gate: None },
            _ => Action::Poll,
        }
    }

    /// For a path's first part at the head of the queue behind the start running: judged
    /// against it, or its second part preloaded ahead ([`Dispatcher::lead_to_judge`],
    /// [`Dispatcher::ahead_due`]).
    fn next_lead(&mut self, now: Instant) -> Option<Action> {
        if let Some((id, behind)) = self.lead_to_judge(now) {
            let behind = Box::new(behind);
            return Some(Action::JudgeLead { id, behind });
        }
        self.ahead_due(now)
            .map(|due| Action::PreloadAhead(Box::new(due)))
    }

    /// The link is down: it is opened at once; after an attempt failed, the worker waits its
    /// backoff (never past the instant a move in flight expires), answers what came meanwhile
    /// (stops and commands: the link is down; the queue's expiry; gateway requests), and tries
    /// again.
    fn next_offline(&mut self, seen: Seen, now: Instant) -> Action {
        if let Retry::At(at) = self.retry {
            self.retry = Retry::Answering;
            let until = self
                .machine
                .expires_while_down()
                .map_or(at, |expiry| expiry.min(at));
            if now < until {
                return Action::Wait { until, gate: None };
            }
        }
        if self.retry == Retry::Answering {
            if seen.stop {
                return Action::Stop;
            }
            if seen.commands {
                return Action::Commands;
            }
            let ends = self.expire(false, now);
            if !ends.is_empty() {
                return Action::Finish(ends);
            }
            if seen.gateway {
                return Action::Gateway;
            }
        }
        self.retry = Retry::Now;
        Action::Connect
    }

    /// One exchange of a preload ahead ([`Activity::Preloading`]), a status read first while a
    /// start runs and the last read is `every` old. It is abandoned between two exchanges (what
    /// was written is not preloaded: nothing points at it) when its part is no longer second in
    /// the queue, or anything overtakes it: the daemon shutting down, a stop or a command asked
    /// for, the link lost.
    fn next_ahead(&mut self, ahead: Box<super::Ahead>, seen: Seen, now: Instant) -> Action {
        let wanted = self.queue.get(1).is_some_and(|q| q.id == ahead.id);
        if !wanted || seen.shutting_down || seen.stop || seen.commands || !seen.link_up {
            return self.next_idle(seen, now);
        }
        let watch = self.watch_due(ahead.every, now);
        Action::AheadStep { ahead, watch }
    }

    /// Whether the status block is read before an upload's next exchange: a start the PLC was
    /// given may run, and the last read is `every` old.
    fn watch_due(&self, every: Duration, now: Instant) -> bool {
        let due = self
            .machine
            .read_at()
            .is_none_or(|at| now.saturating_duration_since(at) >= every);
        due && !self.machine.given().is_empty()
    }

    /// One exchange of an upload; a status read first while a start the PLC was given may run
    /// and the last read is `every` old. The upload of a prepared move whose gate shut ends.
    fn next_upload(&mut self, uploading: Box<Uploading>, now: Instant) -> Action {
        let shut = uploading
            .turn
            .mode
            .gate()
            .is_some_and(|g| g.state() == GateState::Shut);
        if shut {
            self.forget_preloads();
            return Action::Unprepare {
                id: uploading.turn.id,
                why: CYCLE_WENT_ON.to_owned(),
            };
        }
        let watch = self.watch_due(uploading.every, now);
        Action::UploadStep { uploading, watch }
    }

    /// One step of holding a prepared move's bank until its gate opens ([`Hold`]): released on
    /// a status block read within a poll (the one that met its wait) it starts on it, else on
    /// a fresh proof read; the status block read at the busy pace (the cycle's wait is decided
    /// on it) and the gateway served meanwhile. Anything else cancels it: the gate shut, a
    /// stop or a command asked for, the daemon shutting down, the PLC no longer where the
    /// upload left it (seen on the read `just_polled`).
    fn next_hold(
        &mut self,
        held: Box<Uploaded>,
        seen: Seen,
        just_polled: bool,
        now: Instant,
    ) -> Action {
        let id = held.turn.id;
        let gate = held.turn.mode.gate().expect("held behind a gate").clone();
        if just_polled && self.changed_under_upload(now) {
            return unprepare(id, "the PLC changed under it");
        }
        let runs_ahead = self.machine.uploading_behind().is_some();
        match Hold::on_gate(gate.state(), runs_ahead) {
            Hold::Cancel(why) => return unprepare(id, why),
            Hold::Release => return self.release(held, now),
            Hold::Wait => {}
        }
        let stopping = seen.stop || seen.stop_pending;
        if let Hold::Cancel(why) = Hold::on_requests(seen.shutting_down, stopping, seen.commands) {
            return unprepare(id, why);
        }
        self.activity = Activity::Holding(held);
        if seen.gateway {
            return Action::Gateway;
        }
        match self.next_poll {
            Some(until) if !self.poll_due(now) => Action::Wait {
                until,
                gate: (gate.state() == GateState::Closed).then_some(gate),
            },
            _ => Action::Poll,
        }
    }

    /// Whether the PLC, as last read, is no longer where the upload left it: no upload under
    /// way behind a running move (which may end meanwhile, followed as ever) or alone, or a
    /// start refused for more than the running move.
    fn changed_under_upload(&self, now: Instant) -> bool {
        let uploading = matches!(self.machine.phase(), Phase::Uploading { .. });
        !uploading
            || self
                .machine
                .blocker(now)
                .is_some_and(|b| b != Blocker::Full)
    }

    /// A held bank whose gate opened: started on the status block just read if it is fresh
    /// and lets it start, else after a proof read.
    fn release(&mut self, held: Box<Uploaded>, now: Instant) -> Action {
        let fresh = self.is_fresh(now) && self.machine.may_start(&held.planned, now).is_ok();
        if fresh {
            Action::WriteStart(held)
        } else {
            Action::ProveRead(held)
        }
    }

    /// Whether the status block last read is fresh: read within a poll interval.
    pub(in crate::daemon::worker) fn is_fresh(&self, now: Instant) -> bool {
        self.machine
            .read_at()
            .is_some_and(|at| now.saturating_duration_since(at) < self.pace.poll_interval)
    }

    fn poll_due(&self, now: Instant) -> bool {
        self.next_poll.is_none_or(|at| now >= at)
    }

    /// The status block is to be read at once (a request came, a read was asked for).
    pub(in crate::daemon::worker) fn poll_now(&mut self) {
        self.next_poll = None;
    }

    /// When the status block is next to be read (`None`: now).
    pub(in crate::daemon::worker) fn next_poll(&self) -> Option<Instant> {
        self.next_poll
    }

    /// The status block was read at `now` by [`Action::Poll`]: the gateway's turn comes next,
    /// the PLC's mode is read when the robot rests and it was last read (`mode_read`) long
    /// ago, and the next read is a pause away (short while anything is in flight or queued,
    /// or inputs are watched).
    pub(in crate::daemon::worker) fn polled(
        &mut self,
        now: Instant,
        mode_read: Option<Instant>,
        inputs_watched: bool,
    ) {
        self.just_polled = true;
        if matches!(self.activity, Activity::Idle) {
            self.gateway_turn = true;
            let rests = matches!(self.machine.phase(), Phase::Idle | Phase::Unhomed);
            self.mode_due =
                rests && mode_read.is_none_or(|t| now.saturating_duration_since(t) > MODE_POLL);
        }
        self.next_poll = Some(now + self.poll_pause(inputs_watched, now));
    }

    /// How long until the next status read: short while anything is in flight or queued.
    pub(in crate::daemon::worker) fn poll_pause(
        &self,
        inputs_watched: bool,
        now: Instant,
    ) -> Duration {
        let busy = !matches!(
            self.machine.phase(),
            Phase::Idle | Phase::Unhomed | Phase::Stalled
        ) || !self.queue.is_empty()
            || self.any_settling()
            || inputs_watched;
        if !busy {
            return IDLE_POLL;
        }
        // Near a move's planned end reads come a scan apart: the next step (a start from rest,
        // a cycle's output) waits on seeing it end.
        let pace = self.pace.poll_interval;
        if self.machine.near_planned_end(now, 2 * pace) {
            self.pace.scan_time.min(pace)
        } else {
            pace
        }
    }

    /// An attempt to open the link failed at `now`; the next is `backoff` later.
    pub(in crate::daemon::worker) fn connect_failed(&mut self, now: Instant, backoff: Duration) {
        self.retry = Retry::At(now + backoff);
    }

    /// The upload of `uploading` ended in its verified bank at `now`: a prepared move is held,
    /// any other proven. With it, how long the upload took and whether it was prepared.
    pub(in crate::daemon::worker) fn uploaded(
        &mut self,
        uploading: Uploading,
        bank: crate::plc::exchange::VerifiedBank,
        now: Instant,
    ) -> (super::MoveId, f64, bool) {
        // Written whole from the directory's end, a bank may lie over tables preloaded past
        // its own, which no later start may rest on. Only a start from rest, whose section's
        // parts were placed around it, keeps them.
        if !(bank.on_preload || uploading.from_rest) {
            self.forget_preloads();
        }
        let upload_s = now.saturating_duration_since(uploading.began).as_secs_f64();
        let Uploading { turn, planned, .. } = uploading;
        let (id, prepared) = (turn.id, turn.mode.gate().is_some());
        let uploaded = Box::new(Uploaded {
            turn,
            planned,
            bank,
            upload_s,
        });
        self.activity = if prepared {
            Activity::Holding(uploaded)
        } else {
            Activity::Proving(uploaded, None)
        };
        (id, upload_s, prepared)
    }

    /// A proof read for `uploaded` at `now`: proven, its start is written next; not yet, the
    /// next read is half a scan later.
    pub(in crate::daemon::worker) fn proven(
        &mut self,
        uploaded: Box<Uploaded>,
        proven: bool,
        now: Instant,
    ) -> Option<Box<Uploaded>> {
        if proven {
            return Some(uploaded);
        }
        self.activity = Activity::Proving(uploaded, Some(now + self.pace.scan_time / 2));
        None
    }
}

fn unprepare(id: MoveId, why: &str) -> Action {
    Action::Unprepare {
        id,
        why: why.to_owned(),
    }
}
