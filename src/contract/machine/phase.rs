//! The machine's phases and the transition each status block makes from each of them.

use std::time::{Duration, Instant};

use super::{Event, Machine, Outcome, Planned, Status, WatchSettings};
use crate::contract::{CHANNELS, READY_HOMED, State};

/// How far past the host's own clock (the time since it saw a start running) its plan is
/// searched for the counts read: the PLC plays the tables no faster than planned, but it began
/// them up to a status read before the host saw it (a read over a slow link takes a few hundred
/// ms). It keeps a plan that passes again near where it was (a path that comes back on itself)
/// from being found at its second pass.
pub const AHEAD: Duration = Duration::from_millis(500);

/// A start the PLC runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Running {
    /// What it was planned to do.
    pub start: Planned,
    /// When the host saw it start.
    pub since: Instant,
    /// Where along its plan's [`Planned::curve`] its counts were last found (zero without one).
    pub reached: Duration,
}

impl Running {
    /// `start`, seen running at `since`.
    #[must_use]
    pub fn new(start: Planned, since: Instant) -> Self {
        Self {
            start,
            since,
            reached: Duration::ZERO,
        }
    }

    /// Share of its planned duration at which its plan reaches the counts read (`elapsed`, at
    /// `now`), 0 to 1, moving [`Self::reached`] on: the instant of its [`Planned::curve`] whose
    /// counts are nearest, searched forward from where it was last found (so it never goes back)
    /// up to [`AHEAD`] past the time since it was seen running. A robot held back, or a PLC that
    /// runs slow, shows where it is, not where the clock says it should be.
    ///
    /// Without a curve (a start found running after the daemon restarted, whose plan it does
    /// not have), the clock: the time since it was seen running over its planned duration.
    pub fn progress(&mut self, elapsed: &[i32; CHANNELS], now: Instant) -> f64 {
        let ran = now.saturating_duration_since(self.since);
        if let Some(curve) = &self.start.curve {
            self.reached = curve.locate(elapsed, self.reached, ran + AHEAD);
            return curve.share(self.reached);
        }
        let planned = self.start.duration.as_secs_f64();
        if planned <= 0.0 {
            return 1.0;
        }
        (ran.as_secs_f64() / planned).min(1.0)
    }
}

/// A command word the host wrote and waits to see acted on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Written {
    /// When.
    pub at: Instant,
    /// The heartbeat of the first status block read after it (scans are counted from there:
    /// the PLC has had at least that many scans to act on it; `None` until then).
    pub beat: Option<u16>,
    /// How often it was written.
    pub attempts: u8,
    /// Whether the PLC acknowledged the write (a lost or garbled reply leaves it unknown).
    pub confirmed: bool,
}

/// Where the host and its PLC stand.
#[derive(Debug, Clone, PartialEq)]
pub enum Phase {
    /// No link (or no status block yet); `was` is the phase to go on from when the PLC answers.
    LinkDown {
        /// The phase before the link went down.
        was: Box<Phase>,
        /// When it went down (`None`: never connected).
        since: Option<Instant>,
    },
    /// The heartbeat stands still: nothing is in flight and nothing starts.
    Stalled,
    /// The homed bit is clear: nothing starts until the PLC is homed.
    Unhomed,
    /// The home command was written.
    Homing {
        /// When.
        written: Written,
        /// Whether the PLC was seen in its homing state.
        seen: bool,
        /// Whether the homed bit was set when it was written (then only the homing state seen
        /// proves the routine ran).
        homed_before: bool,
    },
    /// Nothing given to the PLC.
    Idle,
    /// A bank is being written, behind the running start if there is one.
    Uploading {
        /// The running start.
        current: Option<Running>,
        /// What was read since the upload began toward the proof that the PLC scans now.
        proof: Proof,
    },
    /// A start was written while nothing ran; not yet seen taken.
    Starting {
        /// The start.
        start: Planned,
        /// Its write.
        written: Written,
    },
    /// A start runs.
    Running {
        /// It.
        current: Running,
    },
    /// A start runs and the next was written behind it.
    Chained {
        /// The running start.
        current: Running,
        /// The next.
        next: Planned,
        /// The next's write.
        written: Written,
        /// Whether the PLC has shown the next in `waiting`.
        seen_waiting: bool,
    },
    /// A stop was written: the starts in flight end as the PLC shows.
    Stopping {
        /// The start that ran.
        current: Option<Running>,
        /// The start that waited (or was being written).
        next: Option<Planned>,
        /// The stop's write.
        written: Written,
    },
}

impl Written {
    /// Scans since the first status block read after the write, `status` being the latest.
    fn scans(&mut self, status: &Status) -> u16 {
        let now = status.block.heartbeat;
        now.wrapping_sub(*self.beat.get_or_insert(now))
    }
}

impl Phase {
    /// Its name, for status reports.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::LinkDown { .. } => "link-down",
            Self::Stalled => "stalled",
            Self::Unhomed => "unhomed",
            Self::Homing { .. } => "homing",
            Self::Idle => "idle",
            Self::Uploading { .. } => "uploading",
            Self::Starting { .. } => "starting",
            Self::Running { .. } => "running",
            Self::Chained { .. } => "running-chained",
            Self::Stopping { .. } => "stopping",
        }
    }

    /// Every start given to the PLC and not ended, oldest first.
    #[must_use]
    pub fn given(&self) -> Vec<Planned> {
        match self {
            Self::LinkDown { was, .. } => was.given(),
            Self::Uploading {
                current: Some(current),
                ..
            }
            | Self::Running { current } => vec![current.start.clone()],
            Self::Starting { start, .. } => vec![start.clone()],
            Self::Chained { current, next, .. } => vec![current.start.clone(), next.clone()],
            Self::Stopping { current, next, .. } => current
                .iter()
                .map(|c| c.start.clone())
                .chain(next.iter().cloned())
                .collect(),
            _ => Vec::new(),
        }
    }

    /// Takes the starts in flight out of the phase (leaving it without them).
    pub(super) fn take_given(&mut self) -> (Option<Planned>, Option<Planned>) {
        match self {
            Self::LinkDown { was, .. } => return was.take_given(),
            Self::Uploading { current, .. } => return (current.take().map(|c| c.start), None),
            Self::Stopping { current, next, .. } => {
                return (current.take().map(|c| c.start), next.take());
            }
            _ => {}
        }
        match std::mem::replace(self, Self::Idle) {
            Self::Starting { start, .. } => (Some(start), None),
            Self::Running { current } => (Some(current.start), None),
            Self::Chained { current, next, .. } => (Some(current.start), Some(next)),
            other => {
                *self = other;
                (None, None)
            }
        }
    }

    /// Takes the starts in flight out of the phase as a stop sees them: the one seen running,
    /// and one written but not yet seen running.
    pub(super) fn take_in_flight(&mut self) -> (Option<Running>, Option<Planned>) {
        match self {
            Self::LinkDown { was, .. } => return was.take_in_flight(),
            Self::Uploading { current, .. } => return (current.take(), None),
            Self::Stopping { current, next, .. } => return (current.take(), next.take()),
            _ => {}
        }
        match std::mem::replace(self, Self::Idle) {
            Self::Starting { start, .. } => (None, Some(start)),
            Self::Running { current } => (Some(current), None),
            Self::Chained { current, next, .. } => (Some(current), Some(next)),
            other => {
                *self = other;
                (None, None)
            }
        }
    }

    /// The write of a start still waiting to be seen.
    pub(super) fn written_mut(&mut self) -> Option<&mut Written> {
        match self {
            Self::LinkDown { was, .. } => was.written_mut(),
            Self::Starting { written, .. } | Self::Chained { written, .. } => Some(written),
            _ => None,
        }
    }
}

/// The phase after `status`, with what it brought about.
pub(super) fn step(
    phase: Phase,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    match phase {
        Phase::LinkDown { was, .. } => step(*was, status, now, m, events),
        Phase::Stalled | Phase::Unhomed | Phase::Idle => idle(status, m, events),
        Phase::Homing {
            written,
            seen,
            homed_before,
        } => homing(written, seen, homed_before, status, now, m, events),
        Phase::Uploading {
            current: None,
            proof,
        } => Phase::Uploading {
            current: None,
            proof,
        },
        Phase::Uploading {
            current: Some(current),
            proof,
        } => match running(current, status, now, m, events) {
            Phase::Running { current } => Phase::Uploading {
                current: Some(current),
                proof,
            },
            _ => Phase::Uploading {
                current: None,
                proof,
            },
        },
        Phase::Starting { start, written } => starting(start, written, status, now, m, events),
        Phase::Running { current } => running(current, status, now, m, events),
        Phase::Chained {
            current,
            next,
            written,
            seen_waiting,
        } => chained(current, next, written, seen_waiting, status, now, m, events),
        Phase::Stopping {
            current,
            next,
            written,
        } => stopping(current, next, written, status, now, m, events),
    }
}

/// Nothing given: watch for starts the host did not give, and the homed bit.
fn idle(status: &Status, m: &Machine, events: &mut Vec<Event>) -> Phase {
    if status.state == State::Running {
        events.push(Event::FoundRunning {
            seq: status.block.seq,
        });
    }
    if status.block.waiting != 0 {
        events.push(Event::FoundWaiting {
            seq: status.block.waiting,
        });
    }
    let _ = m;
    if status.block.ready & READY_HOMED == 0 {
        Phase::Unhomed
    } else {
        Phase::Idle
    }
}

fn homing(
    mut written: Written,
    seen: bool,
    homed_before: bool,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    let seen = seen || status.state == State::Homing;
    let scans = written.scans(status);
    let homed = status.block.ready & READY_HOMED != 0;
    let settled = scans >= m.settings.start_scans;
    match status.state {
        State::Fault => {
            events.push(Event::HomeFailed {
                fault: status.block.fault,
            });
            return Phase::Unhomed;
        }
        State::Done if homed && (seen || (settled && !homed_before)) => {
            events.push(Event::Homed);
            return Phase::Idle;
        }
        State::Homing => {}
        _ if seen || settled => {
            // Left its homing state (or never entered it) without the homed bit: stopped.
            events.push(Event::HomeFailed {
                fault: status.block.fault,
            });
            return if homed { Phase::Idle } else { Phase::Unhomed };
        }
        _ => {}
    }
    if now.saturating_duration_since(written.at) > m.settings.home_timeout {
        events.push(Event::HomeFailed { fault: 0 });
        events.push(Event::WriteStop);
        return halt(now);
    }
    Phase::Homing {
        written,
        seen,
        homed_before,
    }
}

/// After a watchdog asked for a stop: nothing in flight, waiting for the PLC to stand still (so
/// the start it still shows running is not taken for somebody else's).
fn halt(now: Instant) -> Phase {
    Phase::Stopping {
        current: None,
        next: None,
        written: Written {
            at: now,
            beat: None,
            attempts: 1,
            confirmed: true,
        },
    }
}

/// A fresh start written: seen taken, refused, or not taken within a few scans.
fn starting(
    start: Planned,
    mut written: Written,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    if status.block.seq == start.seq {
        events.push(Event::Started { tag: start.tag });
        let current = Running::new(start, now);
        return running(current, status, now, m, events);
    }
    if status.state == State::Fault {
        events.push(Event::Ended {
            tag: start.tag,
            outcome: Outcome::Refused {
                fault: status.block.fault,
            },
        });
        return Phase::Idle;
    }
    let scans = written.scans(status);
    let estop = crate::contract::Fault::StoppedFromOutside.word();
    if status.state == State::Stopped && status.block.fault == estop && scans >= 2 {
        // Refused while the e-stop input was open: nothing started.
        events.push(Event::Ended {
            tag: start.tag,
            outcome: Outcome::Refused { fault: estop },
        });
        return idle(status, m, events);
    }
    if scans < m.settings.start_scans || status.block.waiting == start.seq {
        return Phase::Starting { start, written };
    }
    if !written.confirmed && written.attempts < 2 {
        events.push(Event::RewriteStart { tag: start.tag });
        return Phase::Starting { start, written };
    }
    // Not taken: it ends, and a stop makes sure a command word left behind never runs.
    events.push(Event::Ended {
        tag: start.tag,
        outcome: Outcome::NotTaken { scans },
    });
    events.push(Event::WriteStop);
    halt(now)
}

/// A start runs: done, stopped, faulted, or still running inside its envelope and its time.
fn running(
    mut current: Running,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    let tag = current.start.tag;
    if status.block.seq != current.start.seq {
        // The PLC shows another start than the one it runs for the host: it restarted, or
        // somebody else drives it. Nothing it does is trusted any more.
        events.push(Event::Ended {
            tag,
            outcome: Outcome::Restarted,
        });
        events.push(Event::WriteStop);
        return halt(now);
    }
    let elapsed = status.block.elapsed;
    match status.state {
        State::Done => {
            events.push(Event::Done {
                tag,
                elapsed: Some(elapsed),
            });
            return idle(status, m, events);
        }
        State::Stopped | State::Fault | State::Idle | State::Homing => {
            events.push(Event::Ended {
                tag,
                outcome: ended(status),
            });
            return idle(status, m, events);
        }
        State::Running => {}
    }
    if let Some(outcome) = watch(&current, &elapsed, now, &m.settings) {
        events.push(Event::Ended { tag, outcome });
        events.push(Event::WriteStop);
        return halt(now);
    }
    let fraction = current.progress(&elapsed, now);
    events.push(Event::Progress {
        tag,
        elapsed,
        fraction,
    });
    Phase::Running { current }
}

/// Why a start that did not end done ended, by the PLC's state.
fn ended(status: &Status) -> Outcome {
    let fault = status.block.fault;
    match status.state {
        State::Stopped => Outcome::Stopped { fault },
        State::Fault => Outcome::Faulted { fault },
        _ => Outcome::WentIdle,
    }
}

/// The watchdogs of a running start: its envelope and its time.
fn watch(
    current: &Running,
    elapsed: &[i32; CHANNELS],
    now: Instant,
    settings: &WatchSettings,
) -> Option<Outcome> {
    let slack = settings.envelope_slack;
    for (channel, (&count, &(min, max))) in elapsed.iter().zip(&current.start.envelope).enumerate()
    {
        if count < min.saturating_sub(slack) || count > max.saturating_add(slack) {
            return Some(Outcome::OutsideEnvelope {
                channel,
                count,
                min,
                max,
            });
        }
    }
    let ran = now.saturating_duration_since(current.since);
    let limit = settings.run_limit(current.start.duration);
    (ran > limit).then_some(Outcome::Overrun { ran, limit })
}

/// A start runs and the next was written behind it.
#[allow(clippy::too_many_arguments)]
fn chained(
    current: Running,
    next: Planned,
    written: Written,
    seen_waiting: bool,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    let seq = status.block.seq;
    if seq == next.seq {
        // The PLC starts a waiting start only once the one before ended done, in the same
        // scan: that one's final counts are exactly the next one's `from`.
        events.push(Event::Done {
            tag: current.start.tag,
            elapsed: None,
        });
        events.push(Event::Started { tag: next.tag });
        let current = Running::new(next, now);
        return running(current, status, now, m, events);
    }
    if seq != current.start.seq {
        for tag in [current.start.tag, next.tag] {
            events.push(Event::Ended {
                tag,
                outcome: Outcome::Restarted,
            });
        }
        events.push(Event::WriteStop);
        return halt(now);
    }
    match status.state {
        State::Done => {
            events.push(Event::Done {
                tag: current.start.tag,
                elapsed: Some(status.block.elapsed),
            });
            // The waiting start is acted on in the next scan (or was never there): its scans
            // are counted from here.
            let written = Written {
                beat: Some(status.block.heartbeat),
                ..written
            };
            starting(next, written, status, now, m, events)
        }
        State::Stopped | State::Fault | State::Idle | State::Homing => {
            events.push(Event::Ended {
                tag: current.start.tag,
                outcome: ended(status),
            });
            events.push(Event::Ended {
                tag: next.tag,
                outcome: Outcome::Dropped,
            });
            idle(status, m, events)
        }
        State::Running => {
            let current_phase = running(current, status, now, m, events);
            let Phase::Running { current } = current_phase else {
                // A watchdog ended the running start and asked for a stop: the next goes too.
                events.push(Event::Ended {
                    tag: next.tag,
                    outcome: Outcome::Dropped,
                });
                return current_phase;
            };
            waiting_next(current, next, written, seen_waiting, status, m, events)
        }
    }
}

/// The next start behind a running one: seen waiting, dropped, or never shown.
fn waiting_next(
    current: Running,
    next: Planned,
    mut written: Written,
    seen_waiting: bool,
    status: &Status,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    let tag = next.tag;
    let waiting = status.block.waiting == next.seq;
    if waiting && !seen_waiting {
        events.push(Event::Waiting { tag });
    }
    if waiting {
        return Phase::Chained {
            current,
            next,
            written,
            seen_waiting: true,
        };
    }
    if seen_waiting {
        // It waited and is gone while the running start goes on: somebody withdrew it.
        events.push(Event::Ended {
            tag,
            outcome: Outcome::Dropped,
        });
        return Phase::Running { current };
    }
    let scans = written.scans(status);
    if scans < m.settings.start_scans {
        return Phase::Chained {
            current,
            next,
            written,
            seen_waiting: false,
        };
    }
    if !written.confirmed && written.attempts < 2 {
        events.push(Event::RewriteStart { tag });
        return Phase::Chained {
            current,
            next,
            written,
            seen_waiting: false,
        };
    }
    events.push(Event::Ended {
        tag,
        outcome: Outcome::NotTaken { scans },
    });
    events.push(Event::Withdraw { tag });
    Phase::Running { current }
}

/// A stop was written: each start in flight ends as the PLC shows (done if it got there first).
fn stopping(
    current: Option<Running>,
    next: Option<Planned>,
    mut written: Written,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    let seq = status.block.seq;
    let (mut current, mut next) = (current, next);
    if let Some(n) = next.take_if(|n| n.seq == seq) {
        if let Some(c) = current.take() {
            events.push(Event::Done {
                tag: c.start.tag,
                elapsed: None,
            });
        }
        events.push(Event::Started { tag: n.tag });
        current = Some(Running::new(n, now));
    }
    if status.state == State::Running {
        if written.scans(status) >= m.settings.start_scans {
            // The stop did not take (lost on the way): a stop is safe to write again.
            events.push(Event::WriteStop);
            let written = Written {
                at: now,
                beat: Some(status.block.heartbeat),
                ..written
            };
            return Phase::Stopping {
                current,
                next,
                written,
            };
        }
        return Phase::Stopping {
            current,
            next,
            written,
        };
    }
    if let Some(c) = current {
        let tag = c.start.tag;
        if seq == c.start.seq && status.state == State::Done {
            events.push(Event::Done {
                tag,
                elapsed: Some(status.block.elapsed),
            });
        } else {
            events.push(Event::Ended {
                tag,
                outcome: Outcome::Stopped {
                    fault: status.block.fault,
                },
            });
        }
    }
    if let Some(n) = next {
        events.push(Event::Ended {
            tag: n.tag,
            outcome: Outcome::Dropped,
        });
    }
    if status.block.ready & READY_HOMED == 0 {
        Phase::Unhomed
    } else {
        Phase::Idle
    }
}

/// What was read since an upload began toward the proof a start needs that the PLC scans now
/// ([`super::Machine::may_start`]): two reads after the upload began (behind a running start,
/// the read before it may be the first) must show the heartbeat changing, and a whole status
/// block must be among them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Proof {
    /// Reads of the heartbeat (alone or in a status block) since the upload began.
    pub reads: u8,
    /// Whether the heartbeat was seen changing between two reads that count.
    pub moved: bool,
    /// Whether a whole status block was read since the upload began.
    pub status_read: bool,
}

impl Proof {
    /// Whether a start may rest on it.
    #[must_use]
    pub fn holds(self) -> bool {
        self.moved && self.status_read
    }
}

/// While the link is down since `since`: the instant [`expire_while_down`] next ends something
/// in `was` (a start past its run limit and the grace, a stop past the grace, a home routine past
/// its limit), if anything is in flight. The worker wakes then, whatever its reconnection
/// backoff, so a move ends by the deadline its report gave.
pub(super) fn expiry_while_down(
    was: &Phase,
    since: Instant,
    settings: &WatchSettings,
) -> Option<Instant> {
    let over =
        |at: Instant, duration: Duration| at + settings.run_limit(duration) + settings.link_grace;
    match was {
        Phase::Running { current }
        | Phase::Uploading {
            current: Some(current),
            ..
        } => Some(over(current.since, current.start.duration)),
        Phase::Starting { start, written } => Some(over(written.at, start.duration)),
        Phase::Chained { current, next, .. } => {
            Some(over(current.since, current.start.duration + next.duration))
        }
        Phase::Stopping { .. } => Some(since + settings.link_grace),
        Phase::Homing { written, .. } => Some(written.at + settings.home_timeout),
        _ => None,
    }
}

/// While the link is down: a start past its planned end (or a start never seen taken past its
/// scans) ends as unknown, a home routine past its limit fails.
pub(super) fn expire_while_down(
    was: &mut Phase,
    now: Instant,
    down: Duration,
    settings: &WatchSettings,
    events: &mut Vec<Event>,
) {
    let lost = Outcome::LinkLost { down };
    let over = |since: Instant, duration: Duration| {
        now.saturating_duration_since(since) >= settings.run_limit(duration) + settings.link_grace
    };
    let phase = std::mem::replace(was, Phase::Idle);
    *was = match phase {
        Phase::Running { current }
        | Phase::Uploading {
            current: Some(current),
            ..
        } if over(current.since, current.start.duration) => {
            events.push(Event::Ended {
                tag: current.start.tag,
                outcome: lost,
            });
            Phase::Idle
        }
        Phase::Starting { start, written } if over(written.at, start.duration) => {
            events.push(Event::Ended {
                tag: start.tag,
                outcome: lost,
            });
            Phase::Idle
        }
        Phase::Chained {
            current,
            next,
            written,
            ..
        } if over(current.since, current.start.duration + next.duration) => {
            let _ = written;
            for tag in [current.start.tag, next.tag] {
                events.push(Event::Ended { tag, outcome: lost });
            }
            Phase::Idle
        }
        Phase::Stopping { current, next, .. } if down >= settings.link_grace => {
            for start in current.map(|c| c.start).into_iter().chain(next) {
                events.push(Event::Ended {
                    tag: start.tag,
                    outcome: lost,
                });
            }
            Phase::Idle
        }
        Phase::Homing { written, .. }
            if now.saturating_duration_since(written.at) >= settings.home_timeout =>
        {
            events.push(Event::HomeFailed { fault: 0 });
            Phase::Unhomed
        }
        other => other,
    };
}
