//! The machine's phases, and what time passing while the link is down does to them (the
//! transition each status block makes is in [`super::step`]).

use std::time::{Duration, Instant};

use super::{Event, Outcome, Planned, Status, WatchSettings};
use crate::contract::CHANNELS;

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
    pub(super) fn scans(&mut self, status: &Status) -> u16 {
        let now = status.block.heartbeat;
        now.wrapping_sub(*self.beat.get_or_insert(now))
    }
}

impl Phase {
    /// A start runs and `next` was written behind it.
    pub(super) fn chained(
        current: Running,
        next: Planned,
        written: Written,
        seen_waiting: bool,
    ) -> Self {
        Self::Chained {
            current,
            next,
            written,
            seen_waiting,
        }
    }

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
    if let Phase::Homing { written, .. } = was
        && now.saturating_duration_since(written.at) >= settings.home_timeout
    {
        events.push(Event::HomeFailed { fault: 0 });
        *was = Phase::Unhomed;
    } else if let Some(tags) = expired_tags(was, now, down, settings) {
        let outcome = Outcome::LinkLost { down };
        events.extend(tags.into_iter().map(|tag| Event::Ended { tag, outcome }));
        *was = Phase::Idle;
    }
}

/// The tags of the starts `phase` holds that end as unknown, the link down for `down` at
/// `now`, when they do: a start past its planned end (or never seen taken past its scans), or
/// the starts of a stop once the link's grace has passed.
fn expired_tags(
    phase: &Phase,
    now: Instant,
    down: Duration,
    settings: &WatchSettings,
) -> Option<Vec<u64>> {
    let over = |since: Instant, duration: Duration| {
        now.saturating_duration_since(since) >= settings.run_limit(duration) + settings.link_grace
    };
    match phase {
        Phase::Running { current }
        | Phase::Uploading {
            current: Some(current),
            ..
        } if over(current.since, current.start.duration) => Some(vec![current.start.tag]),
        Phase::Starting { start, written } if over(written.at, start.duration) => {
            Some(vec![start.tag])
        }
        Phase::Chained { current, next, .. }
            if over(current.since, current.start.duration + next.duration) =>
        {
            Some(vec![current.start.tag, next.tag])
        }
        Phase::Stopping { current, next, .. } if down >= settings.link_grace => {
            let current = current.as_ref().map(|c| c.start.tag);
            Some(
                current
                    .into_iter()
                    .chain(next.as_ref().map(|n| n.tag))
                    .collect(),
            )
        }
        _ => None,
    }
}
