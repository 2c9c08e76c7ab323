//! The transition each status block makes from each phase, with the events it brings about.

use std::time::Instant;

use super::phase::{Phase, Running, Written};
use super::{Event, Machine, Outcome, Planned, Status, WatchSettings};
use crate::contract::{CHANNELS, READY_HOMED, State};

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
        Phase::Uploading { current, proof } => {
            let current = current.and_then(|c| still_running(c, status, now, m, events));
            Phase::Uploading { current, proof }
        }
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

/// The start `current` that ran while an upload goes on, after `status`: `None` once it ended.
fn still_running(
    current: Running,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Option<Running> {
    match running(current, status, now, m, events) {
        Phase::Running { current } => Some(current),
        _ => None,
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
        return next_began(&current, next, status, now, m, events);
    }
    if seq != current.start.seq {
        return restarted(&current, &next, now, events);
    }
    match status.state {
        State::Done => {
            events.push(Event::Done {
                tag: current.start.tag,
                elapsed: Some(status.block.elapsed),
            });
            // The waiting start is acted on in the next scan (or was never there): its scans
            // are counted from here.
            let beat = Some(status.block.heartbeat);
            starting(next, Written { beat, ..written }, status, now, m, events)
        }
        State::Stopped | State::Fault | State::Idle | State::Homing => {
            ended_with_next(&current, &next, status, m, events)
        }
        State::Running => {
            let current_phase = running(current, status, now, m, events);
            let Phase::Running { current } = current_phase else {
                // A watchdog ended the running start and asked for a stop: the next goes too.
                dropped(&next, events);
                return current_phase;
            };
            waiting_next(current, next, written, seen_waiting, status, m, events)
        }
    }
}

/// The running start ended otherwise than done (`status`): it ends so, the next is dropped.
fn ended_with_next(
    current: &Running,
    next: &Planned,
    status: &Status,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    events.push(Event::Ended {
        tag: current.start.tag,
        outcome: ended(status),
    });
    dropped(next, events);
    idle(status, m, events)
}

/// The PLC began the waiting start `next`: it starts one only once the one before (`current`)
/// ended done, in the same scan, so that one's final counts are exactly `next`'s `from`.
fn next_began(
    current: &Running,
    next: Planned,
    status: &Status,
    now: Instant,
    m: &Machine,
    events: &mut Vec<Event>,
) -> Phase {
    events.push(Event::Done {
        tag: current.start.tag,
        elapsed: None,
    });
    events.push(Event::Started { tag: next.tag });
    running(Running::new(next, now), status, now, m, events)
}

/// A seq that is neither the running start's nor the next's: another host started something.
/// Both end restarted, and a stop is written.
fn restarted(current: &Running, next: &Planned, now: Instant, events: &mut Vec<Event>) -> Phase {
    for tag in [current.start.tag, next.tag] {
        events.push(Event::Ended {
            tag,
            outcome: Outcome::Restarted,
        });
    }
    events.push(Event::WriteStop);
    halt(now)
}

/// The next start is dropped.
fn dropped(next: &Planned, events: &mut Vec<Event>) {
    events.push(Event::Ended {
        tag: next.tag,
        outcome: Outcome::Dropped,
    });
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
        return Phase::chained(current, next, written, true);
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
        return Phase::chained(current, next, written, false);
    }
    if !written.confirmed && written.attempts < 2 {
        events.push(Event::RewriteStart { tag });
        return Phase::chained(current, next, written, false);
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
            written = Written {
                at: now,
                beat: Some(status.block.heartbeat),
                ..written
            };
        }
        return Phase::Stopping {
            current,
            next,
            written,
        };
    }
    end_stopped(current, next, status, events);
    if status.block.ready & READY_HOMED == 0 {
        Phase::Unhomed
    } else {
        Phase::Idle
    }
}

/// The starts in flight once the PLC stopped: the running one done if it got there first, else
/// stopped; the next dropped.
fn end_stopped(
    current: Option<Running>,
    next: Option<Planned>,
    status: &Status,
    events: &mut Vec<Event>,
) {
    let seq = status.block.seq;
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
}
