//! PURE. The host's side of the contract as one state machine: what the host has given the PLC,
//! moved along by every status block it reads. No IO and no clock: `now` is an argument, and what
//! the host must do (write its host word, write a stop, write a start again) comes back as
//! [`Event`]s for the caller to carry out. The daemon's worker and [`crate::plc::exchange`]'s
//! `follow` both drive this one machine, so "what became of start `seq`" is worked out once.
//!
//! ```text
//!                 connect
//!   LinkDown ────────────────> (the phase it was in: the moves in flight are followed on)
//!   Unhomed ──home──> Homing ──homed bit──> Idle
//!   Idle ──upload──> Uploading ──start written──> Starting ──seq seen──> Running ──done──> Idle
//!   Running ──upload of the next──> Uploading ──start written──> Chained ──next seq──> Running
//!   any with moves ──stop written──> Stopping ──PLC idle──> Idle
//!   heartbeat still: Stalled      host word changed / seq went back: every start ends, Unhomed
//! ```
//!
//! Every status block is checked, whatever the phase: the heartbeat (standing still longer than
//! the timeout ends every start in flight and asks for a stop), the `host` word (a PLC that
//! restarted under the host ends every start in flight: nothing is trusted any more) and the homed
//! bit. A running start is watched: its counts must stay inside the start's envelope (plus a
//! pulse), and it must not run much longer than planned. A start written but not seen taken
//! within a few scans is written again only if its reply was lost, else it ends as not taken.

mod phase;
mod progress;
mod step;
#[cfg(test)]
mod tests;

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::{CHANNELS, Fault, INPUT_WORDS, Permit, READY_HOMED, State, StatusBlock};

pub use phase::{AHEAD, Phase, Proof, Running, Written};
pub use progress::{MIN_SCALE, ProgressCurve, THIN};

/// The status block with its words decoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// The raw block.
    pub block: StatusBlock,
    /// Its state.
    pub state: State,
    /// Its fault.
    pub fault: Fault,
}

/// What one start was planned to do: what the host checks the PLC against, and follows its
/// progress by.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Planned {
    /// The caller's name for it (the daemon's move id).
    pub tag: u64,
    /// Its sequence number.
    pub seq: u16,
    /// Its table bank.
    pub bank: u16,
    /// The counts it was planned from (the command block's `from`).
    pub from: [i32; CHANNELS],
    /// The counts it ends at, per channel (`None` for an adopted start whose tables are unknown).
    pub targets: Option<[i32; CHANNELS]>,
    /// Lowest and highest count its tables command per channel.
    pub envelope: [(i32, i32); CHANNELS],
    /// How long it is planned to take.
    pub duration: Duration,
    /// Its planned counts over its time, to tell how far along it is from the counts read
    /// ([`Running::progress`]); `None` for a start whose plan the host does not have (found
    /// running after a restart): its progress is then the clock's.
    pub curve: Option<Arc<ProgressCurve>>,
    /// Its permit over the cell's inputs (written into the command block; none: all 0).
    pub permit: Permit,
}

/// How closely a start is watched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WatchSettings {
    /// A heartbeat that stands still this long means the PLC is stalled (or in PROG mode).
    pub heartbeat_timeout: Duration,
    /// Scans (heartbeat counts) after a start write by which the PLC must show it taken.
    pub start_scans: u16,
    /// A start runs at most its planned duration times this ...
    pub overrun_ratio: f64,
    /// ... plus this.
    pub overrun_margin: Duration,
    /// Counts this far outside a start's envelope mean it runs away.
    pub envelope_slack: i32,
    /// Longest a home routine may take.
    pub home_timeout: Duration,
    /// Ready bits needed before a start (bit 0 homed, 1 drives ready, 2 e-stop clear).
    pub required_ready: u16,
    /// While the link is down, a start is given up this long after its run limit (a link that
    /// comes back in time finds it followed on).
    pub link_grace: Duration,
}

impl Default for WatchSettings {
    fn default() -> Self {
        Self {
            heartbeat_timeout: Duration::from_millis(500),
            start_scans: 10,
            overrun_ratio: 1.25,
            overrun_margin: Duration::from_secs(1),
            envelope_slack: 1,
            home_timeout: Duration::from_secs(60),
            required_ready: 0b111,
            link_grace: Duration::from_secs(5),
        }
    }
}

impl WatchSettings {
    /// The longest a start planned to take `duration` may run.
    #[must_use]
    pub fn run_limit(&self, duration: Duration) -> Duration {
        duration.mul_f64(self.overrun_ratio) + self.overrun_margin
    }
}

/// Why a start ended without reaching its targets (or never ran).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// The PLC stopped it (a stop command, the e-stop input, PROG mode).
    Stopped {
        /// The fault word (3: the e-stop input).
        fault: u16,
    },
    /// The PLC latched a fault while it ran.
    Faulted {
        /// The fault word.
        fault: u16,
    },
    /// The PLC refused it: nothing moved.
    Refused {
        /// The fault word.
        fault: u16,
    },
    /// It was waiting behind a start that did not end done, and the PLC dropped it: nothing moved.
    Dropped,
    /// The PLC never showed it taken.
    NotTaken {
        /// Heartbeat counts waited.
        scans: u16,
    },
    /// The heartbeat stood still.
    Stalled {
        /// For how long.
        still: Duration,
    },
    /// The PLC restarted (its `host` word or its `seq` changed under the host).
    Restarted,
    /// A channel's count left the start's envelope.
    OutsideEnvelope {
        /// Pulse channel.
        channel: usize,
        /// The count read.
        count: i32,
        /// The envelope's low end.
        min: i32,
        /// The envelope's high end.
        max: i32,
    },
    /// It ran much longer than planned.
    Overrun {
        /// How long it had run.
        ran: Duration,
        /// The limit.
        limit: Duration,
    },
    /// The link was down past its planned end: what became of it is unknown.
    LinkLost {
        /// How long the link had been down.
        down: Duration,
    },
    /// The PLC shows the start's `seq` but went idle without ending it.
    WentIdle,
}

/// What a status block (or a tick, or the caller's own action) brought about.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// The PLC took start `tag` and runs it.
    Started {
        /// The start's tag.
        tag: u64,
    },
    /// Start `tag` waits behind the running one (the PLC shows it in `waiting`).
    Waiting {
        /// The start's tag.
        tag: u64,
    },
    /// The running start's counts.
    Progress {
        /// The start's tag.
        tag: u64,
        /// Counts per channel.
        elapsed: [i32; CHANNELS],
        /// Share of its planned duration elapsed, 0 to 1.
        fraction: f64,
    },
    /// Start `tag` ended done.
    Done {
        /// The start's tag.
        tag: u64,
        /// The final counts (`None` when the next start began in the same scan: it began from
        /// exactly the counts it was planned from).
        elapsed: Option<[i32; CHANNELS]>,
    },
    /// Start `tag` ended without getting done.
    Ended {
        /// The start's tag.
        tag: u64,
        /// Why.
        outcome: Outcome,
    },
    /// The PLC restarted under the host: every start it was given has ended (events before this
    /// one) and nothing starts until it is homed again.
    Restarted,
    /// The heartbeat stands still.
    Stalled {
        /// For how long.
        still: Duration,
    },
    /// A running start was found that the host did not give (a daemon restarted): describe it
    /// (read its command block and tables) and [`Machine::adopt`] it.
    FoundRunning {
        /// Its sequence number.
        seq: u16,
    },
    /// A start waits on the PLC that the host did not give: withdraw it (`command = 0`).
    FoundWaiting {
        /// Its sequence number.
        seq: u16,
    },
    /// Write the host word now.
    WriteHost,
    /// Write a stop now (a watchdog tripped).
    WriteStop,
    /// Write start `tag`'s command word again: its reply was lost and the PLC has not shown it
    /// taken.
    RewriteStart {
        /// The start's tag.
        tag: u64,
    },
    /// Withdraw start `tag` (`command = 0`): it was written behind a running start and the PLC
    /// never showed it waiting.
    Withdraw {
        /// The start's tag.
        tag: u64,
    },
    /// The home routine ended with the homed bit set.
    Homed,
    /// The home routine failed.
    HomeFailed {
        /// The fault word (0 when the host gave up waiting).
        fault: u16,
    },
}

/// Why the host cannot start a move now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Blocker {
    /// No link to the PLC.
    LinkDown,
    /// The heartbeat stands still.
    Stalled,
    /// The homed bit is clear.
    NotHomed,
    /// The home routine runs.
    Homing,
    /// A fault is latched.
    Faulted {
        /// The fault word.
        fault: u16,
    },
    /// Ready bits are missing.
    NotReady {
        /// The ready word.
        ready: u16,
        /// The bits needed.
        required: u16,
    },
    /// The host's word is not yet echoed by the PLC.
    HostUnconfirmed,
    /// A stop is being carried out.
    Stopping,
    /// Room for no more starts: one runs and one waits (or an upload is under way).
    Full,
    /// The heartbeat has not been seen moving between two reads since the upload began (behind
    /// a running start: since the read just before it).
    Unproven,
    /// The start's permit does not hold on the inputs of the last status read.
    PermitNotMet {
        /// The permit.
        permit: Permit,
        /// The inputs read.
        inputs: [u16; INPUT_WORDS],
    },
    /// A channel is not at the count the tables were planned from.
    NotAtFrom {
        /// Pulse channel.
        channel: usize,
        /// Its count.
        count: i32,
        /// The plan's `from`.
        from: i32,
    },
}

impl Blocker {
    /// Whether a new order is refused for it (rather than queued until it passes).
    #[must_use]
    pub fn refuses_orders(&self) -> bool {
        !matches!(
            self,
            Self::HostUnconfirmed
                | Self::Stopping
                | Self::Full
                | Self::Unproven
                | Self::NotAtFrom { .. }
        )
    }
}

/// What the host knows of the PLC's `host` word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HostWord {
    /// Not seen holding ours since this host began or the PLC restarted. `written`: the PLC's
    /// heartbeat when ours was last written (`None`: not written over this link yet), so it is
    /// written again only once the PLC has had scans enough to take it.
    Unconfirmed {
        /// The heartbeat at the last write of ours.
        written: Option<u16>,
    },
    /// Seen holding ours: another word there now means the PLC restarted.
    Echoed,
}

/// The host's side of the contract for one PLC.
#[derive(Debug, Clone)]
pub struct Machine {
    settings: WatchSettings,
    phase: Phase,
    host: u16,
    /// What the PLC's `host` word is known to hold.
    host_word: HostWord,
    /// The heartbeat last read and when it last changed.
    heartbeat: Option<(u16, Instant)>,
    last: Option<Status>,
    /// When the last status block was read.
    read_at: Option<Instant>,
}

impl Machine {
    /// A machine for a host whose word is `host` (nonzero), before any status block.
    #[must_use]
    pub fn new(settings: WatchSettings, host: u16) -> Self {
        Self {
            settings,
            phase: Phase::LinkDown {
                was: Box::new(Phase::Idle),
                since: None,
            },
            host: host.max(1),
            host_word: HostWord::Unconfirmed { written: None },
            heartbeat: None,
            last: None,
            read_at: None,
        }
    }

    /// The phase.
    #[must_use]
    pub fn phase(&self) -> &Phase {
        &self.phase
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> &WatchSettings {
        &self.settings
    }

    /// The host's word.
    #[must_use]
    pub fn host(&self) -> u16 {
        self.host
    }

    /// The status block last read.
    #[must_use]
    pub fn last(&self) -> Option<&Status> {
        self.last.as_ref()
    }

    /// When the last status block was read (`None` before any).
    #[must_use]
    pub fn read_at(&self) -> Option<Instant> {
        self.read_at
    }

    /// How long the heartbeat has stood still at `now` (`None` before any status).
    #[must_use]
    pub fn heartbeat_age(&self, now: Instant) -> Option<Duration> {
        self.heartbeat
            .map(|(_, at)| now.saturating_duration_since(at))
    }

    /// Whether the homed bit was set in the last status block.
    #[must_use]
    pub fn homed(&self) -> bool {
        self.last.is_some_and(|s| s.block.ready & READY_HOMED != 0)
    }

    /// Every start the PLC has been given and not ended, oldest first.
    #[must_use]
    pub fn given(&self) -> Vec<Planned> {
        self.phase.given()
    }

    /// Why a new start cannot be written now, or `None` when it can: a fresh start when nothing
    /// runs, or a chained one behind the running start.
    #[must_use]
    pub fn blocker(&self, now: Instant) -> Option<Blocker> {
        let phase_blocker = match &self.phase {
            Phase::LinkDown { .. } => return Some(Blocker::LinkDown),
            Phase::Stalled => return Some(Blocker::Stalled),
            Phase::Unhomed => return Some(Blocker::NotHomed),
            Phase::Homing { .. } => return Some(Blocker::Homing),
            Phase::Stopping { .. } => return Some(Blocker::Stopping),
            Phase::Idle => None,
            Phase::Running { current } if current.start.targets.is_some() => None,
            Phase::Running { .. }
            | Phase::Uploading { .. }
            | Phase::Starting { .. }
            | Phase::Chained { .. } => Some(Blocker::Full),
        };
        let last = match self.plc_blocker(now) {
            Ok(last) => last,
            Err(blocker) => return Some(blocker),
        };
        if phase_blocker.is_some() {
            return phase_blocker;
        }
        let chaining = matches!(self.phase, Phase::Running { .. });
        (!plc_takes(last, chaining)).then_some(Blocker::Full)
    }

    /// Whether the start `start`, uploaded since [`Self::upload_begun`], may be written now: the
    /// PLC as a start needs it (alive, host echoed, homed, ready, no fault), and either it chains
    /// behind the running start from exactly that start's targets, or nothing runs and every
    /// channel is at `start.from`.
    pub fn may_start(&self, start: &Planned, now: Instant) -> Result<(), Blocker> {
        let last = self.plc_blocker(now)?;
        let Phase::Uploading { current, proof } = &self.phase else {
            return Err(Blocker::Full);
        };
        if !proof.holds() {
            return Err(Blocker::Unproven);
        }
        if !start.permit.holds(&last.block.inputs) {
            return Err(Blocker::PermitNotMet {
                permit: start.permit,
                inputs: last.block.inputs,
            });
        }
        match current {
            Some(current) => {
                let behind = current.start.targets == Some(start.from)
                    && last.block.seq == current.start.seq;
                if behind && plc_takes(last, true) {
                    Ok(())
                } else {
                    Err(Blocker::Full)
                }
            }
            None if !plc_takes(last, false) => Err(Blocker::Full),
            None => match (0..CHANNELS).find(|&c| last.block.elapsed[c] != start.from[c]) {
                Some(channel) => Err(Blocker::NotAtFrom {
                    channel,
                    count: last.block.elapsed[channel],
                    from: start.from[channel],
                }),
                None => Ok(()),
            },
        }
    }

    /// The last status block if the PLC, as it shows, takes starts at all.
    fn plc_blocker(&self, now: Instant) -> Result<&Status, Blocker> {
        let Some(last) = &self.last else {
            return Err(Blocker::LinkDown);
        };
        if self.heartbeat_age(now) > Some(self.settings.heartbeat_timeout) {
            return Err(Blocker::Stalled);
        }
        if last.state == State::Fault {
            return Err(Blocker::Faulted {
                fault: last.block.fault,
            });
        }
        if last.block.ready & READY_HOMED == 0 {
            return Err(Blocker::NotHomed);
        }
        let required = self.settings.required_ready;
        if last.block.ready & required != required {
            return Err(Blocker::NotReady {
                ready: last.block.ready,
                required,
            });
        }
        if self.host_word != HostWord::Echoed {
            return Err(Blocker::HostUnconfirmed);
        }
        Ok(last)
    }

    /// The running start a new one would chain behind (its targets are the new plan's `from`),
    /// when [`Self::blocker`] is `None` and one runs.
    #[must_use]
    pub fn chain_behind(&self) -> Option<&Planned> {
        match &self.phase {
            Phase::Running { current } => Some(&current.start),
            _ => None,
        }
    }

    /// Whether the start running alone (none chained behind it) is due to end within `within`
    /// of `now`, or was due to within `within` before it: where its counts were last found along
    /// its plan, the rest of its plan's time after that read (at most its planned time after it
    /// was seen running). Its end is then worth reading for at once.
    #[must_use]
    pub fn near_planned_end(&self, now: Instant, within: Duration) -> bool {
        let (Phase::Running { current }
        | Phase::Uploading {
            current: Some(current),
            ..
        }) = &self.phase
        else {
            return false;
        };
        let duration = current.start.duration;
        let by_time = current.since + duration;
        let end = self.read_at.map_or(by_time, |at| {
            by_time.min(at + duration.saturating_sub(current.reached))
        });
        now + within >= end && now <= end + within
    }

    /// While a bank is written: the start still running that the new one chains behind, if
    /// the status block still shows it running.
    #[must_use]
    pub fn uploading_behind(&self) -> Option<&Planned> {
        match &self.phase {
            Phase::Uploading {
                current: Some(current),
                ..
            } => Some(&current.start),
            _ => None,
        }
    }

    /// The caller begins writing a bank (nothing is given to the PLC yet).
    pub fn upload_begun(&mut self) {
        let current = match std::mem::replace(&mut self.phase, Phase::Idle) {
            Phase::Running { current } => Some(current),
            other => {
                self.phase = other;
                if !matches!(self.phase, Phase::Idle) {
                    return;
                }
                None
            }
        };
        self.phase = Phase::Uploading {
            current,
            proof: Proof::default(),
        };
    }

    /// The upload ended without a start (failed or abandoned).
    pub fn upload_ended(&mut self) {
        if let Phase::Uploading { current, .. } = &mut self.phase {
            self.phase = match current.take() {
                Some(current) => Phase::Running { current },
                None => Phase::Idle,
            };
        }
    }

    /// The start command for `start` was written at `now`; `confirmed` is false when its reply
    /// was lost or garbled (the PLC may or may not have it).
    pub fn start_written(&mut self, start: Planned, now: Instant, confirmed: bool) {
        let written = Written {
            at: now,
            beat: None,
            attempts: 1,
            confirmed,
        };
        self.phase = match std::mem::replace(&mut self.phase, Phase::Idle) {
            Phase::Uploading {
                current: Some(current),
                ..
            } => Phase::Chained {
                current,
                next: start,
                written,
                seen_waiting: false,
            },
            Phase::LinkDown { was, since } => Phase::LinkDown {
                was: Box::new(match *was {
                    Phase::Uploading {
                        current: Some(current),
                        ..
                    } => Phase::Chained {
                        current,
                        next: start,
                        written,
                        seen_waiting: false,
                    },
                    _ => Phase::Starting { start, written },
                }),
                since,
            },
            _ => Phase::Starting { start, written },
        };
    }

    /// A start's command word was written again at `now` after [`Event::RewriteStart`].
    pub fn start_rewritten(&mut self, now: Instant, confirmed: bool) {
        if let Some(written) = self.phase.written_mut() {
            written.at = now;
            written.beat = None;
            written.attempts += 1;
            written.confirmed = confirmed;
        }
    }

    /// A stop was written at `now` (by request): the starts in flight end as the PLC shows.
    pub fn stop_written(&mut self, now: Instant) {
        let written = Written {
            at: now,
            beat: None,
            attempts: 1,
            confirmed: true,
        };
        let (current, next) = self.phase.take_in_flight();
        self.phase = match std::mem::replace(&mut self.phase, Phase::Idle) {
            Phase::LinkDown { since, .. } => Phase::LinkDown {
                was: Box::new(Phase::Stopping {
                    current,
                    next,
                    written,
                }),
                since,
            },
            _ => Phase::Stopping {
                current,
                next,
                written,
            },
        };
    }

    /// The home command was written at `now`.
    pub fn home_written(&mut self, now: Instant) {
        let written = Written {
            at: now,
            beat: None,
            attempts: 1,
            confirmed: true,
        };
        self.phase = Phase::Homing {
            written,
            seen: false,
            homed_before: self.homed(),
        };
    }

    /// Follows a start found running (after [`Event::FoundRunning`]), as if it had started at
    /// `now`.
    pub fn adopt(&mut self, start: Planned, now: Instant) {
        if matches!(self.phase, Phase::Idle | Phase::Unhomed) {
            self.phase = Phase::Running {
                current: Running::new(start, now),
            };
        }
    }

    /// The link failed at `now`: the starts in flight are kept, to be followed on if the PLC
    /// comes back without having restarted.
    pub fn link_lost(&mut self, now: Instant) {
        if matches!(self.phase, Phase::LinkDown { .. }) {
            return;
        }
        let was = std::mem::replace(&mut self.phase, Phase::Idle);
        let was = match was {
            Phase::Uploading { current, .. } => match current {
                Some(current) => Phase::Running { current },
                None => Phase::Idle,
            },
            Phase::Stalled => Phase::Idle,
            other => other,
        };
        self.phase = Phase::LinkDown {
            was: Box::new(was),
            since: Some(now),
        };
        self.heartbeat = None;
        // A write over the lost link may not have landed: write it again when it is due.
        if let HostWord::Unconfirmed { written } = &mut self.host_word {
            *written = None;
        }
    }

    /// Time passing without a status block (the link is down): a start in flight past its
    /// planned end ends as unknown; a home routine past its limit fails.
    pub fn tick(&mut self, now: Instant) -> Vec<Event> {
        let mut events = Vec::new();
        let Phase::LinkDown { was, since } = &mut self.phase else {
            return events;
        };
        let down = since.map_or(Duration::ZERO, |s| now.saturating_duration_since(s));
        phase::expire_while_down(was, now, down, &self.settings, &mut events);
        events
    }

    /// While the link is down: when [`Self::tick`] next ends something in flight (a start past
    /// its run limit and the link's grace), if anything is.
    #[must_use]
    pub fn expires_while_down(&self) -> Option<Instant> {
        let Phase::LinkDown {
            was,
            since: Some(since),
        } = &self.phase
        else {
            return None;
        };
        phase::expiry_while_down(was, *since, &self.settings)
    }

    /// Moves the machine along by a status block read at `now`.
    pub fn on_status(&mut self, status: &Status, now: Instant) -> Vec<Event> {
        let mut events = Vec::new();
        if let Phase::LinkDown { was, .. } = &mut self.phase {
            let was = std::mem::replace(was.as_mut(), Phase::Idle);
            self.phase = was;
        }
        self.note_heartbeat(status.block.heartbeat, now);
        if self.check_host(status, &mut events) {
            self.last = Some(*status);
            return events;
        }
        let still = self.heartbeat_age(now).unwrap_or_default();
        if still > self.settings.heartbeat_timeout {
            if !matches!(self.phase, Phase::Stalled) {
                let homing = matches!(self.phase, Phase::Homing { .. });
                let in_flight = homing || !self.phase.given().is_empty();
                self.end_all(Outcome::Stalled { still }, &mut events);
                if homing {
                    events.push(Event::HomeFailed { fault: 0 });
                }
                events.push(Event::Stalled { still });
                if in_flight {
                    // A PLC whose heartbeat froze may still scan: whatever it runs is stopped.
                    events.push(Event::WriteStop);
                }
                self.phase = Phase::Stalled;
            }
            self.last = Some(*status);
            return events;
        }
        let phase = std::mem::replace(&mut self.phase, Phase::Idle);
        self.phase = step::step(phase, status, now, self, &mut events);
        self.last = Some(*status);
        events
    }

    /// Whether the start being uploaded has no read toward its heartbeat proof yet, and the
    /// read before the upload will not count: two reads are still needed, and the first may be
    /// of the heartbeat word alone ([`Self::heartbeat_read`]).
    #[must_use]
    pub fn proof_wants_two_reads(&self, now: Instant) -> bool {
        let Phase::Uploading { current, proof } = &self.phase else {
            return false;
        };
        proof.reads == 0 && !self.before_upload_counts(current.is_some(), now)
    }

    /// Whether the status read before the upload counts as the first of the proof's two:
    /// behind a running start (watched until it ends), if no further back than the heartbeat
    /// timeout.
    fn before_upload_counts(&self, behind_a_start: bool, now: Instant) -> bool {
        behind_a_start
            && self.read_at.is_some_and(|at| {
                now.saturating_duration_since(at) <= self.settings.heartbeat_timeout
            })
    }

    /// A status block's heartbeat, read at `now`.
    fn note_heartbeat(&mut self, value: u16, now: Instant) {
        self.heartbeat_read(value, now);
        self.read_at = Some(now);
        if let Phase::Uploading { proof, .. } = &mut self.phase {
            proof.status_read = true;
        }
    }

    /// The heartbeat word read at `now`, alone or in a status block. Alone, while a bank is
    /// written or just after, it counts toward the proof a start needs ([`Self::may_start`]) as
    /// a status read does, and tells nothing else (the next status read checks the rest).
    pub fn heartbeat_read(&mut self, value: u16, now: Instant) {
        let counts_first = match &self.phase {
            Phase::Uploading { current, .. } => self.before_upload_counts(current.is_some(), now),
            _ => false,
        };
        let heartbeat = self.heartbeat;
        if let Phase::Uploading { proof, .. } = &mut self.phase {
            let changed = heartbeat.is_some_and(|(last, _)| last != value);
            // Two reads after the upload began must show the heartbeat changing: the PLC scans
            // now, not only before the upload (a start written to a PLC that froze during it
            // would wait there, to be acted on whenever the PLC resumes). Behind a running
            // start, which is watched until it ends and stopped if the heartbeat stands still,
            // the read before the upload (the one that saw it running) counts as the first, if
            // no further back than the heartbeat timeout: a chained part's turn is short.
            let first = proof.reads >= 1 || counts_first;
            proof.moved |= first && changed;
            proof.reads = proof.reads.saturating_add(1);
        }
        match self.heartbeat {
            Some((last, _)) if last == value => {}
            _ => self.heartbeat = Some((value, now)),
        }
    }

    /// The `host` word: echoed (all well), another word before ours was ever echoed (write ours),
    /// or another word after ours was echoed (the PLC restarted: true, everything ended).
    fn check_host(&mut self, status: &Status, events: &mut Vec<Event>) -> bool {
        let echoed = status.block.host;
        if echoed == self.host {
            self.host_word = HostWord::Echoed;
            return false;
        }
        let restarted = self.host_word == HostWord::Echoed;
        if restarted {
            self.end_all(Outcome::Restarted, events);
            if let Phase::Homing { .. } = self.phase {
                events.push(Event::HomeFailed { fault: 0 });
            }
            events.push(Event::Restarted);
            self.phase = Phase::Unhomed;
        }
        let beat = status.block.heartbeat;
        let due = match self.host_word {
            HostWord::Unconfirmed { written: Some(at) } => {
                beat.wrapping_sub(at) >= self.settings.start_scans / 2
            }
            _ => true,
        };
        // (After a restart it is always due: the word was echoed until now.)
        if due {
            events.push(Event::WriteHost);
            self.host_word = HostWord::Unconfirmed {
                written: Some(beat),
            };
        }
        restarted
    }

    /// Ends every start in flight with `outcome`.
    fn end_all(&mut self, outcome: Outcome, events: &mut Vec<Event>) {
        let (current, next) = self.phase.take_given();
        for start in current.into_iter().chain(next) {
            events.push(Event::Ended {
                tag: start.tag,
                outcome,
            });
        }
        if !matches!(self.phase, Phase::Homing { .. }) {
            self.phase = Phase::Idle;
        }
    }
}

/// Whether the PLC, as `last` shows it, takes a start now: behind its running start (`chaining`)
/// or with nothing running; in both cases with nothing waiting.
fn plc_takes(last: &Status, chaining: bool) -> bool {
    last.block.waiting == 0
        && if chaining {
            last.state == State::Running
        } else {
            matches!(last.state, State::Idle | State::Done | State::Stopped)
        }
}
