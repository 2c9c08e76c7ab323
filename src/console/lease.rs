//! PURE. Hold-to-run jog as a lease the daemon enforces: `(state, event, now) -> actions`.
//!
//! ```text
//!             Start (fresh seq)                      Release | Closed | Hidden | SeatTaken
//!   Idle  ------------------------> Jogging  ------> Fault | lease expired | a piece refused
//!    ^        Submit, Submit          |  ^           or ended short:   Stop, Ended -> Idle
//!    |                                |  | KeepAlive (newer seq): the lease runs LEASE on
//!    +--------------------------------+  | PieceEnded done: Submit another while fresh
//! ```
//! The page sends a keep-alive at most every 100 ms while the pointer is down; the lease runs
//! [`LeaseSettings::lease`] (300 ms) from the newest one. Motion is given to the PLC in short
//! constant-speed pieces of [`LeaseSettings::piece`], at most [`LeaseSettings::in_flight`] at a
//! time (one running, one waiting in the PLC's other bank), and a new one only while the lease
//! is fresh: the PLC never holds more jog motion than `in_flight * piece`, which is at most the
//! lease. Whatever ends the jog, the machine's first action is [`Action::Stop`] (written at once,
//! overtaking everything queued); then [`Action::Ended`] tells the page why.
//!
//! Keep-alives carry a sequence number that must grow (IEC 62745's freshness): a late or
//! repeated one does not extend the lease, nor one from another session.

use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

/// A console session, as the jog and the seat know it.
pub type SessionId = u64;

/// What a jog moves along.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JogAxis {
    /// The tool along x, mm.
    X,
    /// The tool along y, mm.
    Y,
    /// The tool along z, mm.
    Z,
    /// The tool's angle a, degrees.
    A,
    /// One joint, by its index in the joints' order (degrees or mm).
    #[serde(rename = "joint")]
    Joint(usize),
}

impl JogAxis {
    /// Its name as the page and the log show it.
    #[must_use]
    pub fn name(self) -> String {
        match self {
            Self::X => "x".into(),
            Self::Y => "y".into(),
            Self::Z => "z".into(),
            Self::A => "a".into(),
            Self::Joint(j) => format!("joint {}", j + 1),
        }
    }
}

/// The lease's timings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LeaseSettings {
    /// How long a keep-alive keeps the jog going.
    pub lease: Duration,
    /// The motion of one piece.
    pub piece: Duration,
    /// The most pieces given to the daemon and not yet ended (running or waiting).
    pub in_flight: usize,
}

/// The lease: 300 ms from the newest keep-alive (the page sends one every 100 ms at most).
pub const LEASE: Duration = Duration::from_millis(300);
/// A piece: 150 ms of motion, so two of them (one running, one waiting) are the lease.
pub const PIECE: Duration = Duration::from_millis(150);

impl Default for LeaseSettings {
    fn default() -> Self {
        Self {
            lease: LEASE,
            piece: PIECE,
            in_flight: 2,
        }
    }
}

impl LeaseSettings {
    /// The most jog motion the PLC may hold at once: every piece in flight.
    #[must_use]
    pub fn committed(&self) -> Duration {
        self.piece * u32::try_from(self.in_flight).unwrap_or(u32::MAX)
    }
}

/// Why a jog ended.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "why", rename_all = "kebab-case")]
pub enum EndedBy {
    /// The pointer was released.
    Released,
    /// No keep-alive came within the lease.
    Expired,
    /// The page's connection closed.
    Closed,
    /// The page lost focus or was hidden.
    Hidden,
    /// Another session took the control seat.
    SeatTaken,
    /// The robot faulted, lost its link, or stopped being able to move.
    Fault {
        /// What happened.
        reason: String,
    },
    /// A piece could not be planned or queued (a joint limit, the reach), or ended short.
    Refused {
        /// Why.
        reason: String,
    },
}

impl EndedBy {
    /// In words, for the page and the log.
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            Self::Released => "released".into(),
            Self::Expired => "no keep-alive within the lease".into(),
            Self::Closed => "the page's connection closed".into(),
            Self::Hidden => "the page lost focus or was hidden".into(),
            Self::SeatTaken => "another session took the control seat".into(),
            Self::Fault { reason } => format!("the robot cannot move: {reason}"),
            Self::Refused { reason } => format!("the next piece was refused: {reason}"),
        }
    }
}

/// What comes to the lease.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A session holds a jog button down (its first keep-alive, `seq`).
    Start {
        /// Who.
        session: SessionId,
        /// Along what.
        axis: JogAxis,
        /// +1 or -1.
        positive: bool,
        /// The keep-alive's sequence number.
        seq: u64,
    },
    /// The button is still held.
    KeepAlive {
        /// Who.
        session: SessionId,
        /// Its sequence number (must be above the last one taken).
        seq: u64,
    },
    /// The pointer was released (or cancelled).
    Release {
        /// Who.
        session: SessionId,
    },
    /// The session's connection closed.
    Closed {
        /// Who.
        session: SessionId,
    },
    /// The session's page lost focus or was hidden.
    Hidden {
        /// Who.
        session: SessionId,
    },
    /// Another session took the control seat.
    SeatTaken,
    /// The robot cannot move now (a fault, the link lost, stalled, a cycle, remote mode).
    Fault {
        /// Why.
        reason: String,
    },
    /// A piece was queued by the daemon as `id`.
    Queued {
        /// The piece's move id.
        id: u64,
    },
    /// A piece could not be queued.
    Refused {
        /// Why.
        reason: String,
    },
    /// A piece ended; `done` unless it was stopped, failed or cancelled.
    PieceEnded {
        /// Its move id.
        id: u64,
        /// Whether it ended done.
        done: bool,
    },
    /// Time passed (the deadline [`Lease::deadline`] gave came).
    Tick,
}

/// What the lease asks for, carried out in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// Stop the robot now (every channel; every queued piece cancelled).
    Stop,
    /// Queue one more piece along `axis`.
    Submit {
        /// Along what.
        axis: JogAxis,
        /// Which way.
        positive: bool,
    },
    /// Tell `session` its jog ended, and why.
    Ended {
        /// Who.
        session: SessionId,
        /// Why.
        by: EndedBy,
    },
}

/// One jog under way.
#[derive(Debug, Clone, PartialEq)]
pub struct Jogging {
    /// Whose.
    pub session: SessionId,
    /// Along what.
    pub axis: JogAxis,
    /// Which way.
    pub positive: bool,
    /// The newest keep-alive's sequence number.
    pub seq: u64,
    /// When the lease runs out.
    pub expires: Instant,
    /// Pieces asked for and not yet queued (a submit in progress).
    pub asked: usize,
    /// Pieces queued and not yet ended, by move id.
    pub pieces: Vec<u64>,
}

/// The lease machine: idle, or one jog.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Lease {
    /// No jog.
    #[default]
    Idle,
    /// A jog.
    Jogging(Jogging),
}

impl Lease {
    /// The jog under way, if any.
    #[must_use]
    pub fn jogging(&self) -> Option<&Jogging> {
        match self {
            Self::Idle => None,
            Self::Jogging(j) => Some(j),
        }
    }

    /// When [`Event::Tick`] is next due: the lease's end while jogging.
    #[must_use]
    pub fn deadline(&self) -> Option<Instant> {
        self.jogging().map(|j| j.expires)
    }

    /// Takes `event` at `now`; returns what to do, in order.
    pub fn on(&mut self, event: Event, now: Instant, settings: &LeaseSettings) -> Vec<Action> {
        match std::mem::take(self) {
            Self::Idle => match event {
                Event::Start {
                    session,
                    axis,
                    positive,
                    seq,
                } => {
                    let jog = Jogging {
                        session,
                        axis,
                        positive,
                        seq,
                        expires: now + settings.lease,
                        asked: 0,
                        pieces: Vec::new(),
                    };
                    self.refill(jog, now, settings)
                }
                _ => Vec::new(),
            },
            Self::Jogging(jog) => self.on_jogging(jog, event, now, settings),
        }
    }

    /// Takes `event` while `j` is under way.
    fn on_jogging(
        &mut self,
        mut j: Jogging,
        event: Event,
        now: Instant,
        settings: &LeaseSettings,
    ) -> Vec<Action> {
        match event {
            Event::KeepAlive { session, seq } if j.session == session && seq > j.seq => {
                j.seq = seq;
                j.expires = now + settings.lease;
                self.refill(j, now, settings)
            }
            Event::Queued { id } => {
                j.asked = j.asked.saturating_sub(1);
                j.pieces.push(id);
                *self = Self::Jogging(j);
                Vec::new()
            }
            Event::PieceEnded { id, done } if j.pieces.contains(&id) => {
                j.pieces.retain(|p| *p != id);
                if done {
                    self.refill(j, now, settings)
                } else {
                    let reason = format!("piece {id} did not end done (a stop came)");
                    end(j.session, EndedBy::Refused { reason })
                }
            }
            other => {
                if let Some(by) = ending(&j, other, now) {
                    end(j.session, by)
                } else {
                    *self = Self::Jogging(j);
                    Vec::new()
                }
            }
        }
    }

    /// Keeps `jog` going: while its lease is fresh, asks for pieces up to the limit in flight.
    fn refill(&mut self, mut jog: Jogging, now: Instant, settings: &LeaseSettings) -> Vec<Action> {
        if now >= jog.expires {
            return end(jog.session, EndedBy::Expired);
        }
        let mut actions = Vec::new();
        while jog.asked + jog.pieces.len() < settings.in_flight {
            jog.asked += 1;
            actions.push(Action::Submit {
                axis: jog.axis,
                positive: jog.positive,
            });
        }
        *self = Self::Jogging(jog);
        actions
    }
}

/// Why `event` ends `jog` at `now`, when it does: its page lets go, closes or hides, the seat
/// is taken, a fault or a refusal comes, or the lease runs out.
fn ending(jog: &Jogging, event: Event, now: Instant) -> Option<EndedBy> {
    let own = |session: SessionId| session == jog.session;
    match event {
        Event::Release { session } if own(session) => Some(EndedBy::Released),
        Event::Closed { session } if own(session) => Some(EndedBy::Closed),
        Event::Hidden { session } if own(session) => Some(EndedBy::Hidden),
        Event::SeatTaken => Some(EndedBy::SeatTaken),
        Event::Fault { reason } => Some(EndedBy::Fault { reason }),
        Event::Refused { reason } => Some(EndedBy::Refused { reason }),
        Event::Tick if now >= jog.expires => Some(EndedBy::Expired),
        _ => None,
    }
}

/// The jog of `session` ends: a stop first, then the page is told.
fn end(session: SessionId, by: EndedBy) -> Vec<Action> {
    vec![Action::Stop, Action::Ended { session, by }]
}

/// What the robot's state says about jogging now.
#[allow(clippy::struct_excessive_bools)] // five facts, each a yes or no
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct JogFacts {
    /// The PLC link is up and its heartbeat fresh.
    pub link_up: bool,
    /// The PLC's homed bit.
    pub homed: bool,
    /// A fault is latched.
    pub faulted: bool,
    /// A cycle program is under way (running, waiting or paused).
    pub cycle_under_way: bool,
    /// The robot is in remote mode (the cell face drives it).
    pub remote: bool,
}

impl JogFacts {
    /// Why a jog may not start (or go on) now; `None`: it may.
    #[must_use]
    pub fn refusal(&self) -> Option<&'static str> {
        if !self.link_up {
            Some("the PLC link is down or stalled")
        } else if self.faulted {
            Some("a fault is latched: clear it first")
        } else if !self.homed {
            Some("the robot is not homed: home it first")
        } else if self.cycle_under_way {
            Some("a cycle program is under way: stop it first")
        } else if self.remote {
            Some("the robot is in remote mode: the cell face drives it")
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests;
