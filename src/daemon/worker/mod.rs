//! The task that owns one robot's PLC link. Everything else sends it requests; it carries out
//! the contract (docs/CONTRACT.md, "What the host does for one move"). Its decisions are the
//! pure [`Dispatcher`]'s (the queue, one record per move in flight, how a move starts, what the
//! worker is doing as one [`Activity`], the contract's [`Machine`] deciding what every status
//! block means, and what comes next as an [`Action`]); the worker is its driver: one loop that
//! takes in what came, asks the dispatcher for the next action, carries it out over the link's
//! session and feeds back what came of it, and applies what the machine says in one place
//! ([`events`]).
//!
//! ```text
//! run: loop { take in | action = dispatcher.next(seen, now) | carry it out }
//!   Connect | Stop | Commands | Finish | ReadMode | JudgeLead | PreloadAhead | AheadStep | Begin
//!   | UploadStep | ProveRead | WriteStart
//!   | Unprepare | Gateway | Poll | Pause | Wait (the one select!: requests, stops, gateway,
//!   shutdown, a read asked for, a held bank's gate, the timer)
//!   mod.rs       the loop, carrying actions out, stops, home and clear-fault, shutdown
//!   dispatch.rs  PURE: the decisions (queue, InFlight, StartMode, Activity, followers);
//!                dispatch/next.rs: what comes next ([`Action`])
//!   activity.rs  the steps of the move whose turn came
//!   link.rs      (re)connecting, a link that fails or a PLC program that does not answer right
//!   events.rs    reading the status block into the machine; applying its events to the reports
//!   moves.rs     a turn, planning, preloading a section's parts, the start written once
//!   lead.rs      a path's first part behind a running start: judged; its second part ahead
//! ```
//!
//! A stop overtakes everything: it is taken between any two exchanges (an upload in progress is
//! abandoned between two of its writes, never mid-frame) and cancels every queued move. A request
//! wakes the worker at once: nothing waits for the next poll.

mod activity;
mod dispatch;
mod events;
mod followers;
mod gateway;
mod lead;
mod link;
mod moves;
mod pace;
mod placement;
mod preload;
mod prepared;
mod session;

use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::Ordering;

use tokio::sync::{mpsc, watch};

use super::gate::Gate;
use super::request::{CommandError, ConflictReason, Reply, Request};
use super::setup::{Connector, DaemonOptions, RobotSetup};
use super::shared::{Publisher, Shared};
use crate::contract::machine::{Machine, Phase};
use crate::contract::{CHANNELS, State};
use crate::kinematics::JOINTS;
use crate::plc::exchange::{CommandWrite, Contract, ContractError, ContractSettings};
use crate::plc::{AnyPlc, Plc};
use crate::robot::Robot;
use crate::wire::{MoveId, Stage};
use dispatch::{Action, Activity, Dispatcher, PollPace, Seen};

/// What a worker receives on.
pub(super) struct Channels {
    /// Moves, homes, clear-faults.
    pub requests: mpsc::UnboundedReceiver<Request>,
    /// Stops (they overtake everything).
    pub stops: mpsc::UnboundedReceiver<Reply>,
    /// Register gateway requests.
    pub gateway: mpsc::UnboundedReceiver<super::gateway::Job>,
    /// The daemon shutting down.
    pub shutdown: watch::Receiver<bool>,
}

/// The time now, on tokio's clock (paused in tests), as the pure core takes it.
fn now() -> std::time::Instant {
    tokio::time::Instant::now().into_std()
}

/// An error and every cause under it, in one line (`link failed during stop: the PLC link is
/// down`): what reports and replies say.
pub(super) fn describe(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        let more = cause.to_string();
        if !text.contains(&more) {
            text = format!("{text}: {more}");
        }
        source = cause.source();
    }
    text
}

/// Whether an error means the link must be reopened.
fn link_broken(e: &ContractError) -> bool {
    matches!(e, ContractError::Plc(p) if p.is_link_failure())
}

/// One robot's link owner: the driver of its [`Dispatcher`] over its link.
pub(super) struct Worker {
    robot: Robot,
    settings: ContractSettings,
    home_counts: [i64; JOINTS],
    shared: Arc<Shared>,
    /// What the worker publishes: the robot's snapshot (it alone sends on it).
    out: Publisher,
    /// The link: how to open it, the open session, the backoff.
    conn: link::Connection,
    /// What comes in, and what was taken in and waits to be carried out.
    inbox: Inbox,
    /// The queue, the moves in flight, the contract's machine and what the worker does next:
    /// what it decides.
    dispatch: Dispatcher,
}

/// What the worker receives, and what it took in that waits for its turn.
struct Inbox {
    /// Moves, homes, clear-faults.
    requests: mpsc::UnboundedReceiver<Request>,
    /// Stops (they overtake everything).
    stops: mpsc::UnboundedReceiver<Reply>,
    /// Register gateway requests.
    gateway_rx: mpsc::UnboundedReceiver<super::gateway::Job>,
    /// The daemon shutting down.
    shutdown: watch::Receiver<bool>,
    /// Register gateway requests, served one exchange at a time between the worker's own.
    gateway: VecDeque<super::gateway::Job>,
    /// Stops taken while waiting, answered by the next `take_stops`.
    pending_stops: Vec<Reply>,
    /// Home and clear-fault requests taken while waiting.
    commands: Vec<Request>,
    /// Answers waiting for the home routine's end.
    homing: Vec<Reply>,
}

impl Worker {
    pub(super) fn new(
        setup: RobotSetup,
        options: &DaemonOptions,
        channels: Channels,
        shared: Arc<Shared>,
        out: Publisher,
    ) -> Self {
        let machine = Machine::new(setup.settings.watch, options.host);
        let pace = PollPace {
            poll_interval: setup.settings.poll_interval,
            scan_time: setup.settings.scan_time,
        };
        Self {
            robot: setup.robot,
            settings: setup.settings,
            home_counts: setup.home_counts,
            shared,
            out,
            conn: link::Connection::new(setup.connect),
            inbox: Inbox {
                requests: channels.requests,
                stops: channels.stops,
                gateway_rx: channels.gateway,
                shutdown: channels.shutdown,
                gateway: VecDeque::new(),
                pending_stops: Vec::new(),
                commands: Vec::new(),
                homing: Vec::new(),
            },
            dispatch: Dispatcher::new(machine, options.start_within, pace),
        }
    }

    /// Runs until shutdown: one loop that takes in what came, asks the dispatcher what comes
    /// next ([`Dispatcher::next`]) and carries it out.
    pub(super) async fn run(mut self) {
        loop {
            self.shared.beat.mark();
            self.take_in();
            let seen = self.seen();
            let action = self.dispatch.next(seen, now());
            if matches!(action, Action::ShutDown) {
                self.shut_down().await;
                return;
            }
            if let Err(e) = self.carry_out(action).await {
                if link_broken(&e) {
                    self.link_failed(&e);
                } else {
                    self.note_error(&e);
                }
            }
        }
    }

    /// Carries out one of the dispatcher's actions over the session.
    async fn carry_out(&mut self, action: Action) -> Result<(), ContractError> {
        match action {
            Action::ShutDown => {
                self.shut_down().await;
                Ok(())
            }
            Action::Connect => {
                self.reconnect().await;
                Ok(())
            }
            Action::Stop => self.take_stops().await,
            Action::Commands => self.run_commands().await,
            Action::Finish(ends) => {
                self.finish_all(ends);
                Ok(())
            }
            Action::ReadMode => self.read_mode().await,
            Action::Gateway => {
                let done = self.gateway_exchange().await;
                self.held_through(done)
            }
            Action::Poll => {
                let done = self.poll_step().await;
                self.held_through(done)
            }
            Action::Wait { until, gate } => {
                self.wait_until(until, gate.as_ref()).await;
                Ok(())
            }
            Action::Pause { until } => {
                tokio::time::sleep_until(until.into()).await;
                Ok(())
            }
            // The rest are steps on the queue's moves.
            action => self.move_step(action).await,
        }
    }

    /// The status block read for the dispatcher's [`Action::Poll`], and what it learns of it.
    async fn poll_step(&mut self) -> Result<(), ContractError> {
        self.poll().await?;
        let mode_read = self.conn.session.as_ref().and_then(|s| s.mode_read);
        let watched = self.shared.inputs_watched.load(Ordering::Relaxed);
        self.dispatch.polled(now(), mode_read, watched);
        Ok(())
    }

    /// What came of an exchange made while a prepared bank is held: its failure cancels it.
    fn held_through(&mut self, done: Result<(), ContractError>) -> Result<(), ContractError> {
        let Err(e) = done else {
            return Ok(());
        };
        match std::mem::take(&mut self.dispatch.activity) {
            Activity::Holding(held) => {
                let why = describe(&e);
                self.unprepared(held.turn.id, &why, Some(e))
            }
            other => {
                self.dispatch.activity = other;
                Err(e)
            }
        }
    }

    /// Takes in every stop and gateway request already sent, without waiting, and the requests
    /// unless a bank is being written or proven (they wait for its start).
    fn take_in(&mut self) {
        if matches!(
            self.dispatch.activity,
            Activity::Idle | Activity::Holding(_)
        ) {
            self.take_pending_requests();
        }
        while let Ok(reply) = self.inbox.stops.try_recv() {
            self.inbox.pending_stops.push(reply);
        }
        while let Ok(job) = self.inbox.gateway_rx.try_recv() {
            self.inbox.gateway.push_back(job);
        }
    }

    /// What was taken in, as the dispatcher sees it.
    fn seen(&self) -> Seen {
        Seen {
            link_up: self.conn.session.is_some(),
            shutting_down: *self.inbox.shutdown.borrow(),
            stop: !self.inbox.pending_stops.is_empty(),
            commands: !self.inbox.commands.is_empty(),
            gateway: !self.inbox.gateway.is_empty(),
            stop_pending: self.shared.stop_pending.load(Ordering::SeqCst),
        }
    }

    /// The open link's session. Every exchange is made from a step the loop runs only while
    /// the link is up ([`Self::run`]); without one this is the link-down refusal, never a panic.
    fn session(&mut self) -> Result<&mut session::Session, ContractError> {
        self.conn.session.as_mut().ok_or(ContractError::Blocked(
            crate::contract::machine::Blocker::LinkDown,
        ))
    }

    /// The contract over the open link ([`Self::session`]).
    fn link(&mut self) -> Result<&mut Contract<AnyPlc>, ContractError> {
        Ok(&mut self.session()?.contract)
    }

    /// Reads the PLC's mode (RUN / PROG) for the robot's state; a PLC that cannot say is not a
    /// failure (over Modbus the RUN relay is unverified).
    pub(super) async fn read_mode(&mut self) -> Result<(), ContractError> {
        let session = self.session()?;
        session.mode_read = Some(now());
        match session.contract.plc().mode().await {
            Ok(mode) => {
                self.out.state(|s| s.plc_mode = Some(mode));
                Ok(())
            }
            Err(e) if e.is_link_failure() => Err(ContractError::Plc(e)),
            Err(e) => {
                tracing::debug!(robot = %self.robot.name, error = %e, "cannot read the PLC's mode");
                Ok(())
            }
        }
    }

    /// Waits until `until`; a request, a stop, a gateway request, shutdown, a read asked for
    /// soon or `gate` deciding (a held bank's) ends the wait.
    async fn wait_until(&mut self, until: std::time::Instant, gate: Option<&Gate>) {
        let decided = async {
            match gate {
                Some(gate) => gate.decided().await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            biased;
            _ = self.inbox.shutdown.changed() => {}
            stop = self.inbox.stops.recv() => {
                if let Some(reply) = stop {
                    self.inbox.pending_stops.push(reply);
                }
            }
            request = self.inbox.requests.recv() => {
                if let Some(request) = request {
                    self.take_request(request);
                }
            }
            job = self.inbox.gateway_rx.recv() => {
                if let Some(job) = job {
                    self.inbox.gateway.push_back(job);
                }
            }
            () = tokio::time::sleep_until(until.into()) => {}
            () = self.shared.read_soon.notified() => self.dispatch.poll_now(),
            () = decided => {}
        }
    }

    /// Takes every request already sent, without waiting.
    pub(super) fn take_pending_requests(&mut self) {
        while let Ok(request) = self.inbox.requests.try_recv() {
            self.take_request(request);
        }
    }

    fn take_request(&mut self, request: Request) {
        // Something to do: the status block is read at once, not at the next idle poll.
        self.dispatch.poll_now();
        match request {
            Request::Moves(batch) => self.accept(batch),
            command => self.inbox.commands.push(command),
        }
    }

    /// Queues a batch of starts, whole or not at all (the queue would pass
    /// [`MAX_QUEUED_STARTS`](super::MAX_QUEUED_STARTS)): their reports recorded, the queue and
    /// where it ends published, and the asker answered.
    fn accept(&mut self, batch: super::request::Batch) {
        let queued = self
            .out
            .state(|s| s.queued.len() + usize::from(s.current_move.is_some()));
        let limit = super::MAX_QUEUED_STARTS;
        if queued + batch.starts.len() > limit {
            let _ = batch.reply.send(Err(super::SubmitError::QueueFull {
                queued,
                adding: batch.starts.len(),
                limit,
            }));
            return;
        }
        let ids: Vec<MoveId> = batch.starts.iter().map(|(r, _)| r.id).collect();
        self.shared.moves(|m| {
            for (report, _) in &batch.starts {
                m.insert(report.clone());
            }
        });
        self.out.state(|s| s.queued.extend(&ids));
        let starts = batch.starts.into_iter().map(|(r, o)| (r.id, o)).collect();
        self.dispatch
            .push_order(starts, batch.gate, batch.epoch, now());
        self.out.set_planned_end(batch.end);
        let _ = batch.reply.send(Ok(ids));
    }

    /// Writes a stop if one was asked for; the moves given to the PLC end as it shows, every
    /// queued move is cancelled.
    async fn take_stops(&mut self) -> Result<(), ContractError> {
        let mut replies = std::mem::take(&mut self.inbox.pending_stops);
        while let Ok(reply) = self.inbox.stops.try_recv() {
            replies.push(reply);
        }
        if replies.is_empty() {
            return Ok(());
        }
        self.dispatch.poll_now();
        let result = match self.conn.session.as_mut() {
            Some(session) => session.contract.stop().await,
            None => Err(ContractError::Blocked(
                crate::contract::machine::Blocker::LinkDown,
            )),
        };
        self.shared.stop_pending.store(false, Ordering::SeqCst);
        self.dispatch.stop_asked(now());
        self.cancel_for_stop();
        if result.is_ok() {
            self.dispatch.machine.stop_written(now());
        }
        let answer_for = self.stop_answer(&result);
        for reply in replies {
            let _ = reply.send(answer_for.clone());
        }
        tracing::info!(robot = %self.robot.name, ok = result.is_ok(), "stop taken");
        match result {
            Err(e) if link_broken(&e) => Err(e),
            _ => Ok(()),
        }
    }

    /// A stop was taken: the orders sent before it and the queue are cancelled, the commands
    /// refused.
    fn cancel_for_stop(&mut self) {
        // Orders sent before this stop join the queue, to be cancelled with it.
        while let Ok(request) = self.inbox.requests.try_recv() {
            self.take_request(request);
        }
        for command in std::mem::take(&mut self.inbox.commands) {
            answer(
                command,
                Err(CommandError::Conflict {
                    reason: ConflictReason::StopCameFirst,
                }),
            );
        }
        self.cancel_queue("cancelled by a stop request");
        // Orders asked after it plan from where the robot stops, not from a queue's end.
        self.out.set_planned_end(None);
    }

    /// What the askers of a stop are answered, its write having come to `result`.
    fn stop_answer(&self, result: &Result<(), ContractError>) -> Result<(), CommandError> {
        match result {
            Ok(()) => Ok(()),
            Err(_) if self.conn.session.is_none() => Err(CommandError::LinkDown {
                detail: self.out.state(|s| s.link.error.clone()),
            }),
            Err(e) if link_broken(e) => Err(CommandError::LinkDown {
                detail: Some(describe(e)),
            }),
            Err(e) => Err(CommandError::Plc {
                detail: describe(e),
            }),
        }
    }

    /// Home and clear-fault requests, each checked against what the PLC shows.
    async fn run_commands(&mut self) -> Result<(), ContractError> {
        for command in std::mem::take(&mut self.inbox.commands) {
            let checked = self.command_allowed(&command);
            match (command, checked) {
                (command, Err(e)) => answer(command, Err(e)),
                (Request::ClearFault(reply), Ok(())) => match self.link()?.clear_fault().await {
                    Ok(()) => {
                        tracing::info!(robot = %self.robot.name, "fault cleared");
                        let _ = reply.send(Ok(()));
                    }
                    Err(e) => {
                        let detail = describe(&e);
                        let _ = reply.send(Err(CommandError::Plc { detail }));
                        if link_broken(&e) {
                            return Err(e);
                        }
                    }
                },
                (Request::Home(reply), Ok(())) => self.home(reply).await?,
                (Request::Moves(..), Ok(())) => unreachable!("moves are queued, not commands"),
            }
        }
        Ok(())
    }

    /// Whether `command` may be written now: a link, and a PLC in a state that takes it.
    fn command_allowed(&self, command: &Request) -> Result<(), CommandError> {
        let last = match (&self.conn.session, self.dispatch.machine.last()) {
            (Some(_), Some(last))
                if !matches!(self.dispatch.machine.phase(), Phase::LinkDown { .. }) =>
            {
                *last
            }
            _ => {
                return Err(CommandError::LinkDown {
                    detail: self.out.state(|s| s.link.error.clone()),
                });
            }
        };
        let in_flight = !self.dispatch.machine.given().is_empty();
        match command {
            Request::ClearFault(_) if matches!(last.state, State::Running | State::Homing) => {
                Err(ConflictReason::PlcBusy { state: last.state })
            }
            Request::ClearFault(_) if last.state != State::Fault && last.block.fault == 0 => {
                Err(ConflictReason::NoFault)
            }
            Request::Home(_) if in_flight || last.state == State::Running => {
                Err(ConflictReason::MoveRuns)
            }
            Request::Home(_) if last.state == State::Homing => Err(ConflictReason::AlreadyHoming),
            Request::Home(_) if last.state == State::Fault => Err(ConflictReason::FaultLatched {
                fault: last.block.fault,
            }),
            _ => Ok(()),
        }
        .map_err(|reason| CommandError::Conflict { reason })
    }

    /// Writes the home command for every joint's channel, each preset to its home count; the
    /// reply is answered when the home routine ends.
    async fn home(&mut self, reply: Reply) -> Result<(), ContractError> {
        let mut mask = 0;
        let mut from = [0_i32; CHANNELS];
        for (joint, count) in self.robot.joints.iter().zip(self.home_counts) {
            mask |= 1 << joint.channel;
            from[usize::from(joint.channel)] = count as i32;
        }
        match self.link()?.home(mask, from).await {
            Ok(write) => {
                if let CommandWrite::Unconfirmed(e) = &write {
                    tracing::warn!(robot = %self.robot.name, error = %e, "home command unconfirmed");
                }
                self.dispatch.machine.home_written(now());
                self.inbox.homing.push(reply);
                tracing::info!(robot = %self.robot.name, from = %from.map(|c| c.to_string()).join(","), "homing");
                Ok(())
            }
            Err(e) => {
                let detail = describe(&e);
                let _ = reply.send(Err(CommandError::Plc { detail }));
                if link_broken(&e) { Err(e) } else { Ok(()) }
            }
        }
    }

    /// On shutdown: a start still waiting on the PLC is withdrawn (command back to 0), so no
    /// start is left pending; a running move runs on to its end under the PLC program.
    async fn shut_down(&mut self) {
        if let Phase::Chained { next, .. } = self.dispatch.machine.phase().clone()
            && let Some(session) = self.conn.session.as_mut()
        {
            let result = session.contract.withdraw().await;
            match &result {
                Ok(()) => {
                    tracing::info!(robot = %self.robot.name, id = next.tag, "withdrew the waiting start");
                }
                Err(e) => {
                    tracing::warn!(robot = %self.robot.name, id = next.tag, error = %describe(e), "could not withdraw the waiting start");
                }
            }
            self.finish(
                next.tag,
                Stage::Cancelled,
                Some("withdrawn: the daemon shut down".into()),
                None,
            );
        }
        self.settle(None);
        self.cancel_queue("cancelled: the daemon shut down");
        self.cancel_followers("cancelled: the daemon shut down");
        for command in std::mem::take(&mut self.inbox.commands) {
            answer(command, Err(CommandError::ShuttingDown));
        }
        for reply in std::mem::take(&mut self.inbox.homing) {
            let _ = reply.send(Err(CommandError::ShuttingDown));
        }
        while let Ok(job) = self.inbox.gateway_rx.try_recv() {
            self.inbox.gateway.push_back(job);
        }
        for job in std::mem::take(&mut self.inbox.gateway) {
            let _ = job
                .reply
                .send(Err(super::gateway::GatewayError::ShuttingDown));
        }
    }
}

/// Answers a command request.
fn answer(command: Request, result: Result<(), CommandError>) {
    match command {
        Request::Home(reply) | Request::ClearFault(reply) => {
            let _ = reply.send(result);
        }
        Request::Moves(..) => {}
    }
}
