//! The console's control task, one per robot: it owns the robot's control seat and its jog
//! lease, takes the sessions' requests, and carries out what the pure machines
//! (`console::seat`, `console::lease`) decide, in one `select!` loop:
//!
//! ```text
//!  requests (check, take/leave the seat, jog, keep-alive, release, hidden, closed) --+
//!  the lease's deadline --------------------------------------------------------------+--> on()
//!  the live snapshot (faults, the link, a cycle, remote mode; the pieces' reports) --+
//!      actions: Stop -> RobotHandle::stop (timed: the longest is the worst case's exchange)
//!               Submit -> RobotHandle::submit(a piece) -> Queued | Refused, fed back
//!               Ended -> the page sees why in the snapshot's `console.jog.last_end`
//!  publishes: seat and jog -> the live stream's console side
//! ```

use std::sync::Arc;
use std::time::Duration;

use tokio::sync::{mpsc, oneshot, watch};
use tokio_util::sync::CancellationToken;

use super::super::stream::{Frame, RobotStream};
use crate::cell::Mode;
use crate::console::{
    Action, Asker, Command, EndedBy, Event, JogAxis, JogFacts, Lease, LeaseSettings, Refusal, Role,
    Seat, SessionId, TravelInputs, jog, piece_order, start_hz_speed,
};
use crate::contract::State;
use crate::daemon::RobotHandle;
use crate::geometry::Pose;
use crate::wire::{ActiveJog, ConsoleLive, JogLive, Live, RobotPhase, SeatHolder};

/// The stop write assumed before one was timed, for the worst case shown.
const ASSUMED_EXCHANGE: Duration = Duration::from_millis(100);

/// A session as the control task sees it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Who {
    /// Its id.
    pub session: SessionId,
    /// Its user.
    pub user: String,
    /// Its role.
    pub role: Role,
}

impl Who {
    fn asker(&self) -> Asker<'_> {
        Asker {
            session: self.session,
            user: &self.user,
            role: self.role,
        }
    }
}

/// What a session asks of a robot's control task.
#[derive(Debug)]
pub enum Request {
    /// May `who` do `command` now?
    Check {
        /// Who.
        who: Who,
        /// What.
        command: Command,
        /// The answer.
        reply: oneshot::Sender<Result<(), Refusal>>,
    },
    /// `who` takes the seat.
    TakeSeat {
        /// Who.
        who: Who,
        /// The answer.
        reply: oneshot::Sender<Result<(), Refusal>>,
    },
    /// `session` gives the seat up.
    LeaveSeat {
        /// Who.
        session: SessionId,
    },
    /// A jog button went down.
    Jog {
        /// Who.
        who: Who,
        /// Along what.
        axis: JogAxis,
        /// Which way.
        positive: bool,
        /// The keep-alive's number.
        seq: u64,
        /// Refused, or started.
        reply: oneshot::Sender<Result<(), JogRefusal>>,
    },
    /// A keep-alive, a release, a hidden page, a closed connection: for the lease.
    Lease(Event),
}

/// Why a hold-to-run jog was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum JogRefusal {
    /// The session may not operate the robot (the seat, the mode).
    #[error(transparent)]
    Seat(#[from] Refusal),
    /// The robot cannot jog now (a fault, the link, a cycle), `why`.
    #[error("jog refused: {why}")]
    NotNow {
        /// Why, in words.
        why: String,
    },
    /// A joint asked for: hold-to-run jogs the tool.
    #[error("hold-to-run jogs the tool along x, y, z or a; a joint jogs in steps")]
    Joint,
    /// Another session jogs the robot.
    #[error("another session jogs this robot")]
    OtherSession,
}

/// A robot's control task's handle.
#[derive(Debug, Clone)]
pub struct Control {
    requests: mpsc::Sender<Request>,
}

/// Requests waiting for the control task at most (keep-alives are small and quick).
const QUEUE: usize = 1024;

impl Control {
    /// Starts the control task of `handle`'s robot, publishing into `stream`'s console side.
    #[must_use]
    pub fn start(
        handle: RobotHandle,
        stream: &RobotStream,
        manual_speed_mm_s: f64,
        closing: CancellationToken,
    ) -> Self {
        let (requests, rx) = mpsc::channel(QUEUE);
        let task = Task {
            handle,
            settings: LeaseSettings::default(),
            manual_speed_mm_s,
            seat: Seat::default(),
            lease: Lease::default(),
            jogger: None,
            last_end: None,
            exchange: ASSUMED_EXCHANGE,
            side: stream.side(),
            live: stream.latest(),
        };
        tokio::spawn(task.run(rx, closing));
        Self { requests }
    }

    /// Sends `request`; `false` when the task is gone (the daemon is closing).
    pub async fn send(&self, request: Request) -> bool {
        self.requests.send(request).await.is_ok()
    }

    /// May `who` do `command` now?
    pub async fn check(&self, who: Who, command: Command) -> Result<(), Refusal> {
        let (reply, answer) = oneshot::channel();
        if !self
            .send(Request::Check {
                who,
                command,
                reply,
            })
            .await
        {
            return Err(Refusal::Remote { what: "anything" });
        }
        answer
            .await
            .unwrap_or(Err(Refusal::Remote { what: "anything" }))
    }
}

/// The task's state: the seat, the lease, and what the page is shown of them.
struct Task {
    handle: RobotHandle,
    settings: LeaseSettings,
    manual_speed_mm_s: f64,
    seat: Seat,
    lease: Lease,
    /// The user of the jog under way.
    jogger: Option<String>,
    last_end: Option<String>,
    /// The longest stop write timed.
    exchange: Duration,
    side: Arc<watch::Sender<ConsoleLive>>,
    live: watch::Receiver<Arc<Frame>>,
}

impl Task {
    async fn run(mut self, mut requests: mpsc::Receiver<Request>, closing: CancellationToken) {
        self.show();
        loop {
            let deadline = self.lease.deadline();
            let expiry = async {
                match deadline {
                    Some(at) => tokio::time::sleep_until(at.into()).await,
                    None => std::future::pending().await,
                }
            };
            let events = tokio::select! {
                biased;
                () = closing.cancelled() => {
                    if self.lease.jogging().is_some() {
                        let _ = self.handle.stop().await;
                    }
                    return;
                }
                request = requests.recv() => match request {
                    Some(request) => self.take(request),
                    None => return,
                },
                () = expiry => vec![Event::Tick],
                changed = self.live.changed() => {
                    if changed.is_err() { return }
                    self.on_snapshot()
                }
            };
            for event in events {
                self.feed(event).await;
            }
            self.show();
        }
    }

    /// Feeds `event` to the lease and carries out every action, feeding back what came of them.
    async fn feed(&mut self, event: Event) {
        let mut pending = vec![event];
        while let Some(event) = pending.pop() {
            let actions = self.lease.on(event, now(), &self.settings);
            for action in actions {
                if let Some(next) = self.act(action).await {
                    pending.push(next);
                }
            }
        }
    }

    /// Carries out one action; what came of it, for the lease.
    async fn act(&mut self, action: Action) -> Option<Event> {
        match action {
            Action::Stop => {
                let asked = tokio::time::Instant::now();
                let stopped = self.handle.stop().await;
                let took = asked.elapsed();
                if stopped.is_ok() {
                    self.exchange = self.exchange.max(took);
                }
                tracing::debug!(robot = %self.handle.robot().name, ms = took.as_millis(), "jog stop written");
                None
            }
            Action::Submit { axis, positive } => Some(self.submit(axis, positive).await),
            Action::Ended { by, .. } => {
                let text = by.describe();
                if !matches!(by, EndedBy::Released) {
                    tracing::info!(robot = %self.handle.robot().name, user = ?self.jogger, why = %text, "jog ended");
                }
                self.last_end = Some(text);
                self.jogger = None;
                None
            }
        }
    }

    /// Queues one piece: its speed, the manual speed within the drives' `start_hz`, planned
    /// under the speed override, for one piece's time.
    async fn submit(&mut self, axis: JogAxis, positive: bool) -> Event {
        let live = Arc::clone(&self.live.borrow());
        let speed = self.jog_speed(&live.live, axis);
        let length = speed * self.override_share() * self.settings.piece.as_secs_f64();
        match self
            .handle
            .submit(piece_order(axis, positive, length, speed))
            .await
        {
            Ok(id) => Event::Queued { id },
            Err(e) => Event::Refused {
                reason: e.to_string(),
            },
        }
    }

    fn override_share(&self) -> f64 {
        f64::from(self.handle.speed_override().clamp(1, 100)) / 100.0
    }

    /// The speed a piece along `axis` is asked at (before the override): the manual speed, or
    /// less where a drive's `start_hz` says so.
    fn jog_speed(&self, live: &Live, axis: JogAxis) -> f64 {
        let robot = self.handle.robot();
        let cap = live
            .state
            .pose
            .map(|[x, y, z, a]| Pose::from_mm_deg(x, y, z, a))
            .and_then(|pose| start_hz_speed(robot, &pose, axis));
        cap.map_or(self.manual_speed_mm_s, |c| c.min(self.manual_speed_mm_s))
    }

    /// A request, as lease events (a check or the seat is answered here).
    fn take(&mut self, request: Request) -> Vec<Event> {
        let remote = self.handle.mode() == Mode::Remote;
        match request {
            Request::Check {
                who,
                command,
                reply,
            } => {
                let _ = reply.send(self.seat.check(who.asker(), command, remote));
                Vec::new()
            }
            Request::TakeSeat { who, reply } => match self.seat.take(who.asker(), remote) {
                Ok(lost) => {
                    let _ = reply.send(Ok(()));
                    let from = lost.as_ref().map(|h| h.user.clone());
                    tracing::warn!(robot = %self.handle.robot().name, user = %who.user, from = ?from, "console: control seat taken");
                    // Whoever jogged, the jog stops: only the seat's holder jogs.
                    lost.map(|_| Event::SeatTaken).into_iter().collect()
                }
                Err(e) => {
                    let _ = reply.send(Err(e));
                    Vec::new()
                }
            },
            Request::LeaveSeat { session } => {
                self.seat.leave(session);
                vec![Event::Release { session }]
            }
            Request::Jog {
                who,
                axis,
                positive,
                seq,
                reply,
            } => {
                let refused = self.jog_refused(&who, axis, remote);
                let ok = refused.is_ok();
                let _ = reply.send(refused);
                if !ok {
                    Vec::new()
                } else if self.lease.jogging().is_none() {
                    self.jogger = Some(who.user.clone());
                    let session = who.session;
                    vec![Event::Start {
                        session,
                        axis,
                        positive,
                        seq,
                    }]
                } else {
                    let session = who.session;
                    vec![Event::KeepAlive { session, seq }]
                }
            }
            Request::Lease(event) => vec![event],
        }
    }

    /// Why `who` may not jog along `axis` now, if it may not.
    fn jog_refused(&self, who: &Who, axis: JogAxis, remote: bool) -> Result<(), JogRefusal> {
        self.seat.check(who.asker(), Command::Operate, remote)?;
        if let Some(why) = self.facts().refusal() {
            return Err(JogRefusal::NotNow {
                why: why.to_owned(),
            });
        }
        if let JogAxis::Joint(_) = axis {
            return Err(JogRefusal::Joint);
        }
        match self.lease.jogging() {
            Some(j) if j.session != who.session => Err(JogRefusal::OtherSession),
            _ => Ok(()),
        }
    }

    /// What a new snapshot means for the jog: a fault, or a piece that ended.
    fn on_snapshot(&mut self) -> Vec<Event> {
        let Some(jog) = self.lease.jogging() else {
            if self.handle.mode() == Mode::Remote {
                self.seat.vacate();
            }
            return Vec::new();
        };
        if let Some(why) = self.facts().refusal() {
            return vec![Event::Fault {
                reason: why.to_owned(),
            }];
        }
        jog.pieces
            .iter()
            .filter_map(|&id| {
                let report = self.handle.report(id)?;
                report.stage.is_final().then(|| Event::PieceEnded {
                    id,
                    done: report.stage == crate::wire::Stage::Done,
                })
            })
            .collect()
    }

    /// What the latest snapshot says about jogging.
    fn facts(&self) -> JogFacts {
        let frame = self.live.borrow();
        let s = &frame.live.state;
        JogFacts {
            link_up: s.link.connected
                && !matches!(
                    s.phase,
                    RobotPhase::LinkDown | RobotPhase::Stalled | RobotPhase::NotPublished
                ),
            homed: s.homed,
            faulted: s.fault.is_some() || s.state == Some(State::Fault),
            cycle_under_way: s.cycle.as_ref().is_some_and(|c| !c.state.is_final()),
            remote: self.handle.mode() == Mode::Remote,
        }
    }

    /// Publishes the seat and the jog into the live stream's console side.
    fn show(&self) {
        let speed = self.manual_speed_mm_s * self.override_share();
        let travel = TravelInputs {
            speed_mm_s: speed,
            lease_s: self.settings.lease.as_secs_f64(),
            exchange_s: self.exchange.as_secs_f64(),
            committed_s: self.settings.committed().as_secs_f64(),
            brake_mm_s2: jog::brake_mm_s2(self.handle.robot()),
        }
        .travel();
        let active = self.lease.jogging().map(|j| ActiveJog {
            user: self.jogger.clone().unwrap_or_default(),
            axis: j.axis.name(),
            positive: j.positive,
        });
        let view = ConsoleLive {
            seat: self.seat.holder().map(|h| SeatHolder {
                user: h.user.clone(),
                role: h.role.name().to_owned(),
            }),
            jog: JogLive {
                active,
                last_end: self.last_end.clone(),
                refuses: self.facts().refusal().map(str::to_owned),
                manual_speed_mm_s: self.manual_speed_mm_s,
                speed_mm_s: speed,
                lease_ms: self.settings.lease.as_millis() as u64,
                piece_ms: self.settings.piece.as_millis() as u64,
                exchange_ms: self.exchange.as_millis() as u64,
                travel_alive_mm: travel.alive_mm,
                travel_hung_mm: travel.hung_mm,
            },
        };
        self.side.send_if_modified(|side| {
            if *side == view {
                false
            } else {
                *side = view;
                true
            }
        });
    }
}

/// Tokio's clock, as the pure machines take it.
fn now() -> std::time::Instant {
    tokio::time::Instant::now().into_std()
}
