//! The task that owns one robot's PLC link. Everything else sends it requests; it runs the
//! contract's flow (CONTRACT.md, "What linterpd does for one move"): check the PLC, plan from the
//! counts it reports, upload into the idle bank, verify, start, follow to the end and compare the
//! final counts with the plan. While a move runs, the next queued one is planned from where the
//! running one will end, uploaded into the other bank and started, so the PLC program starts it
//! in the first scan after the running one ends, with no host round trip between them.
//!
//! A stop overtakes everything: it is taken between any two exchanges (an upload in progress is
//! abandoned between two of its writes, never mid-frame) and cancels every queued move. A lost
//! link is reconnected with backoff; on (re)connection the PLC's state is read back, and a move
//! found running is followed as a recovered move.

use std::collections::VecDeque;
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use tokio::sync::{mpsc, oneshot, watch};
use tokio::time::Instant;

use super::handle::Shared;
use super::order::CheckedOrder;
use super::report::{MoveId, MoveReport, Stage};
use crate::contract::State;
use crate::plc::contract::{Contract, ContractError, ContractSettings};
use crate::plc::{AnyPlc, Plc, PlcError};
use crate::robot::Robot;

/// Opens the robot's PLC link (called again after every link failure).
pub type Connector =
    Box<dyn FnMut() -> Pin<Box<dyn Future<Output = Result<AnyPlc, PlcError>> + Send>> + Send>;

/// What the worker is asked to do (stops come on their own channel, to overtake).
#[derive(Debug)]
pub(super) enum Request {
    /// Run a checked order as move `id`.
    Move(MoveId, CheckedOrder),
    /// Clear a latched fault.
    ClearFault(oneshot::Sender<Result<(), String>>),
}

/// A move the PLC has been given.
#[derive(Debug, Clone, Copy)]
struct Active {
    id: MoveId,
    seq: u16,
    /// Target counts per channel (`None` for a recovered move).
    target: Option<[i64; 4]>,
    duration_s: f64,
    /// Seen as the PLC's latest accepted start.
    accepted: bool,
    started: Instant,
}

/// Polling while a move runs, and while idle.
const IDLE_POLL: Duration = Duration::from_millis(250);
/// Reconnection backoff bounds.
const BACKOFF_MIN: Duration = Duration::from_millis(100);
const BACKOFF_MAX: Duration = Duration::from_secs(5);

/// One robot's link owner.
pub(super) struct Worker {
    pub robot: Robot,
    pub settings: ContractSettings,
    pub connect: Connector,
    pub requests: mpsc::UnboundedReceiver<Request>,
    pub stops: mpsc::UnboundedReceiver<oneshot::Sender<Result<(), String>>>,
    pub shutdown: watch::Receiver<bool>,
    pub shared: Arc<Shared>,
    link: Option<Contract<AnyPlc>>,
    queue: VecDeque<(MoveId, CheckedOrder)>,
    current: Option<Active>,
    waiting: Option<Active>,
    next_seq: u16,
    next_bank: u16,
    backoff: Duration,
    /// Stops taken while waiting, answered by the next `take_stops`.
    pending_stops: Vec<oneshot::Sender<Result<(), String>>>,
    /// Sequence numbers of the starts this worker wrote (the latest few).
    issued: VecDeque<u16>,
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

impl Worker {
    pub(super) fn new(
        robot: Robot,
        settings: ContractSettings,
        connect: Connector,
        requests: mpsc::UnboundedReceiver<Request>,
        stops: mpsc::UnboundedReceiver<oneshot::Sender<Result<(), String>>>,
        shutdown: watch::Receiver<bool>,
        shared: Arc<Shared>,
    ) -> Self {
        Self {
            robot,
            settings,
            connect,
            requests,
            stops,
            shutdown,
            shared,
            link: None,
            queue: VecDeque::new(),
            current: None,
            waiting: None,
            next_seq: 1,
            next_bank: 0,
            backoff: BACKOFF_MIN,
            pending_stops: Vec::new(),
            issued: VecDeque::new(),
        }
    }

    /// Runs until shutdown.
    pub(super) async fn run(mut self) {
        loop {
            if *self.shutdown.borrow() {
                self.shut_down().await;
                return;
            }
            if self.link.is_none() {
                self.reconnect().await;
                continue;
            }
            if let Err(e) = self.step().await {
                self.link_failed(&e);
            }
        }
    }

    fn link_failed(&mut self, e: &ContractError) {
        tracing::warn!(robot = %self.robot.name, error = %e, "PLC link failed; reconnecting");
        self.link = None;
        self.shared.state(|s| {
            s.link.connected = false;
            s.link.error = Some(describe(e));
        });
    }

    async fn reconnect(&mut self) {
        match (self.connect)().await {
            Ok(plc) => {
                let mut contract = Contract::new(plc, self.settings);
                contract.set_abort(Arc::clone(&self.shared.stop_pending));
                self.link = Some(contract);
                self.backoff = BACKOFF_MIN;
                self.shared.state(|s| {
                    s.link.connected = true;
                    s.link.reconnects += 1;
                });
                if let Err(e) = self.read_back().await {
                    self.note_error(&e);
                    if link_broken(&e) {
                        self.link_failed(&e);
                    }
                }
            }
            Err(e) => {
                self.shared.state(|s| {
                    s.link.connected = false;
                    s.link.error = Some(describe(&e));
                });
                let wait = self.backoff;
                self.backoff = (self.backoff * 2).min(BACKOFF_MAX);
                self.wait(wait).await;
                // A stop cannot wait for the link: it is answered now (the link is down) and
                // cancels the queued moves.
                if !self.pending_stops.is_empty() {
                    let _ = self.take_stops().await;
                }
            }
        }
    }

    fn note_error(&self, e: &ContractError) {
        self.shared.state(|s| s.link.error = Some(describe(e)));
    }

    /// After (re)connecting: the sequence number and bank to use next, and a move found running.
    async fn read_back(&mut self) -> Result<(), ContractError> {
        let layout = self.settings.layout;
        let link = self.link.as_mut().expect("connected");
        let status = link.status().await?;
        let bank = link.plc().read_words(layout.command_base + 3, 1).await?[0];
        self.next_seq = status.block.seq.wrapping_add(1).max(1);
        self.next_bank = 1 - bank.min(1);
        self.adopt(&status, bank);
        self.shared.state(|s| s.link.error = None);
        Ok(())
    }

    /// Follows a move running on the PLC that this worker did not start (started by an earlier
    /// run of the daemon, found on (re)connection or when its pending start is taken).
    fn adopt(&mut self, status: &crate::plc::contract::Status, bank: u16) {
        let seq = status.block.seq;
        if status.state != State::Running || self.current.is_some() || self.issued.contains(&seq) {
            return;
        }
        let id = self.shared.next_id();
        let mut report = MoveReport::new(id, &self.robot.name, super::order::MoveOrder::default());
        report.recovered = true;
        report.stage = Stage::Running;
        report.seq = Some(seq);
        report.bank = Some(bank);
        self.shared.moves(|m| m.insert(report));
        self.shared.state(|s| s.current_move = Some(id));
        self.current = Some(Active {
            id,
            seq,
            target: None,
            duration_s: 0.0,
            accepted: true,
            started: Instant::now(),
        });
        self.issued.push_back(seq);
        self.next_seq = seq.wrapping_add(1).max(1);
        tracing::info!(robot = %self.robot.name, seq, "following a move this run did not start");
    }

    /// One round: a stop first, then start or prefetch a move, then read the status.
    async fn step(&mut self) -> Result<(), ContractError> {
        self.take_stops().await?;
        if self.current.is_none() {
            if let Some((id, order)) = self.queue.pop_front() {
                return self.begin(id, order, None).await;
            }
        } else if self.waiting.is_none()
            && self
                .current
                .is_some_and(|c| c.accepted && c.target.is_some())
            && let Some((id, order)) = self.queue.pop_front()
        {
            let from = self.current.and_then(|c| c.target);
            return self.begin(id, order, from).await;
        }
        self.poll().await?;
        let pause = if self.current.is_some() {
            self.settings.poll_interval
        } else {
            IDLE_POLL
        };
        self.wait(pause).await;
        Ok(())
    }

    /// Waits up to `pause`, taking requests as they come; a stop or shutdown ends the wait.
    async fn wait(&mut self, pause: Duration) {
        let until = Instant::now() + pause;
        loop {
            tokio::select! {
                biased;
                _ = self.shutdown.changed() => return,
                () = tokio::time::sleep_until(until) => return,
                stop = self.stops.recv() => {
                    if let Some(reply) = stop {
                        self.pending_stops.push(reply);
                    }
                    return;
                }
                request = self.requests.recv() => match request {
                    Some(Request::Move(id, order)) => self.queue.push_back((id, order)),
                    Some(Request::ClearFault(reply)) => {
                        let result = match self.link.as_mut() {
                            Some(link) => link.clear_fault().await.map_err(|e| describe(&e)),
                            None => Err("the PLC link is down".to_owned()),
                        };
                        let _ = reply.send(result);
                    }
                    None => return,
                },
            }
        }
    }

    /// Writes a stop if one was asked for, and cancels every move in flight.
    async fn take_stops(&mut self) -> Result<(), ContractError> {
        let mut replies = std::mem::take(&mut self.pending_stops);
        while let Ok(reply) = self.stops.try_recv() {
            replies.push(reply);
        }
        if replies.is_empty() {
            return Ok(());
        }
        let result = match self.link.as_mut() {
            Some(link) => link.stop().await,
            None => Err(ContractError::Plc(PlcError::Link {
                operation: "stop".into(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotConnected,
                    "the PLC link is down",
                ),
            })),
        };
        self.shared.stop_pending.store(false, Ordering::SeqCst);
        let text = result.as_ref().err().map(|e| describe(e));
        for reply in replies {
            let _ = reply.send(text.clone().map_or(Ok(()), Err));
        }
        // Orders already sent (before this stop) join the queue, to be cancelled with it.
        while let Ok(request) = self.requests.try_recv() {
            match request {
                Request::Move(id, order) => self.queue.push_back((id, order)),
                Request::ClearFault(reply) => {
                    let _ = reply.send(Err("a stop came first; ask again".to_owned()));
                }
            }
        }
        // Queued moves never reached the PLC: cancelled either way. Moves the PLC was given
        // are stopped only if the stop reached it; otherwise they are followed on reconnection.
        let mut ids: Vec<MoveId> = self.queue.drain(..).map(|q| q.0).collect();
        if result.is_ok() {
            ids.extend(
                self.current
                    .take()
                    .into_iter()
                    .chain(self.waiting.take())
                    .map(|a| a.id),
            );
        }
        let why = if result.is_ok() {
            "stopped by request"
        } else {
            "cancelled by a stop request"
        };
        for id in ids {
            self.finish(id, Stage::Stopped, Some(why.into()), None);
        }
        tracing::info!(robot = %self.robot.name, ok = result.is_ok(), "stop taken");
        result
    }

    fn finish(
        &self,
        id: MoveId,
        stage: Stage,
        error: Option<String>,
        final_error: Option<[i64; 4]>,
    ) {
        self.shared.moves(|m| {
            m.update(id, |r| {
                if !r.stage.is_final() {
                    r.stage = stage;
                    r.error = error;
                    r.final_error_pulses = final_error;
                }
            });
        });
        self.shared.state(|s| {
            s.queued.retain(|q| *q != id);
            if s.current_move == Some(id) {
                s.current_move = None;
            }
        });
        if stage != Stage::Done {
            // Later orders are checked from where the robot really is, not from a target this
            // move will not reach.
            self.shared.forget_planned_end();
        }
    }
}

mod flow;

pub(crate) use flow::plan_order;
