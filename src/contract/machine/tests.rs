#![allow(clippy::too_many_lines)] // tables of transitions read best whole

//! Every transition of the host's machine, table-driven: a machine brought into a phase, one
//! status block, the events and the phase that must follow.

use std::sync::Arc;
use std::time::{Duration, Instant};

use super::*;

const HOST: u16 = 0xA5A5;
const FROM: [i32; CHANNELS] = [100, 200, 300, 400];
const TO: [i32; CHANNELS] = [150, 180, 300, 410];

fn settings() -> WatchSettings {
    WatchSettings::default()
}

/// A status block: the contract's magic and version, homed and ready, our host word.
fn status(state: State, seq: u16, heartbeat: u16, elapsed: [i32; CHANNELS]) -> Status {
    crate::testing::status(state, seq, heartbeat, elapsed, HOST)
}

fn with(mut s: Status, change: impl FnOnce(&mut Status)) -> Status {
    change(&mut s);
    s.state = State::from_word(s.block.state).unwrap();
    s.fault = Fault::from_word(s.block.fault).unwrap_or(Fault::None);
    s
}

fn planned(tag: u64, seq: u16, from: [i32; CHANNELS], to: [i32; CHANNELS]) -> Planned {
    Planned {
        tag,
        seq,
        bank: (seq % 2),
        from,
        targets: Some(to),
        envelope: std::array::from_fn(|c| (from[c].min(to[c]), from[c].max(to[c]))),
        duration: Duration::from_secs(1),
        curve: None,
        permit: crate::contract::Permit::NONE,
    }
}

/// A test bed: a machine, the time, the heartbeat.
struct Bed {
    m: Machine,
    t0: Instant,
    now: Instant,
    beat: u16,
}

impl Bed {
    /// A machine that has seen the PLC idle and done, our host word echoed, heartbeat moving.
    fn idle() -> Self {
        let t0 = Instant::now();
        let mut bed = Self {
            m: Machine::new(settings(), HOST),
            t0,
            now: t0,
            beat: 1,
        };
        bed.feed(status(State::Done, 7, 1, FROM));
        assert_eq!(bed.m.phase(), &Phase::Idle);
        bed
    }

    /// The next status block, 10 ms and `scans` heartbeat counts later.
    fn feed_after(&mut self, scans: u16, s: Status) -> Vec<Event> {
        self.now += Duration::from_millis(10);
        self.beat = self.beat.wrapping_add(scans);
        let s = with(s, |s| s.block.heartbeat = self.beat);
        self.m.on_status(&s, self.now)
    }

    fn feed(&mut self, s: Status) -> Vec<Event> {
        self.feed_after(1, s)
    }

    /// Uploads and writes start `p` (confirmed or not) behind whatever runs.
    fn start(&mut self, p: Planned, confirmed: bool) {
        self.m.upload_begun();
        self.m.start_written(p, self.now, confirmed);
    }

    /// Start 8 (tag 1) from FROM to TO, seen running.
    fn running() -> Self {
        let mut bed = Self::idle();
        bed.start(planned(1, 8, FROM, TO), true);
        let events = bed.feed(status(State::Running, 8, 0, FROM));
        assert!(events.contains(&Event::Started { tag: 1 }), "{events:?}");
        bed
    }

    /// Start 8 running, start 9 (tag 2, TO back to FROM) written behind it.
    fn chained() -> Self {
        let mut bed = Self::running();
        bed.start(planned(2, 9, TO, FROM), true);
        bed
    }
}

fn name(m: &Machine) -> &'static str {
    m.phase().name()
}

fn ended(tag: u64, outcome: Outcome) -> Event {
    Event::Ended { tag, outcome }
}

#[test]
fn first_status_with_another_host_word_asks_for_ours_and_does_not_count_as_a_restart() {
    let t0 = Instant::now();
    let mut m = Machine::new(settings(), HOST);
    assert_eq!(m.blocker(t0), Some(Blocker::LinkDown));
    let s = with(status(State::Running, 3, 1, FROM), |s| {
        s.block.host = 0x1111;
    });
    let events = m.on_status(&s, t0);
    assert_eq!(
        events,
        [Event::WriteHost, Event::FoundRunning { seq: 3 }],
        "a daemon restarted: it follows what it finds and writes its word"
    );
    assert_eq!(m.blocker(t0), Some(Blocker::HostUnconfirmed));
}

#[test]
fn idle_transitions() {
    type Case = (&'static str, Status, Vec<Event>, &'static str);
    let idle = status(State::Done, 7, 0, FROM);
    let cases: Vec<Case> = vec![
        ("nothing new", idle, vec![], "idle"),
        (
            "a start nobody here gave",
            with(idle, |s| {
                s.block.state = State::Running.word();
                s.block.seq = 40;
            }),
            vec![Event::FoundRunning { seq: 40 }],
            "idle",
        ),
        (
            "a start waiting nobody here wrote",
            with(idle, |s| s.block.waiting = 41),
            vec![Event::FoundWaiting { seq: 41 }],
            "idle",
        ),
        (
            "homed bit gone",
            with(idle, |s| s.block.ready = 0b110),
            vec![],
            "unhomed",
        ),
        (
            "host word gone: a restart",
            with(idle, |s| {
                s.block.host = 0;
                s.block.ready = 0b110;
                s.block.state = State::Idle.word();
                s.block.seq = 0;
            }),
            vec![Event::Restarted, Event::WriteHost],
            "unhomed",
        ),
    ];
    for (what, s, want, phase) in cases {
        let mut bed = Bed::idle();
        let events = bed.feed(s);
        assert_eq!(events, want, "{what}");
        assert_eq!(name(&bed.m), phase, "{what}");
    }
}

#[test]
fn starting_transitions() {
    type Case = (&'static str, bool, u16, Status, Vec<Event>, &'static str);
    let p = planned(1, 8, FROM, TO);
    let old = status(State::Done, 7, 0, FROM);
    let cases: Vec<Case> = vec![
        (
            "seen running",
            true,
            2,
            status(State::Running, 8, 0, FROM),
            vec![
                Event::Started { tag: 1 },
                Event::Progress {
                    tag: 1,
                    elapsed: FROM,
                    fraction: 0.0,
                },
            ],
            "running",
        ),
        (
            "seen done already",
            true,
            2,
            status(State::Done, 8, 0, TO),
            vec![
                Event::Started { tag: 1 },
                Event::Done {
                    tag: 1,
                    elapsed: Some(TO),
                },
            ],
            "idle",
        ),
        (
            "refused with fault 5",
            true,
            2,
            with(old, |s| {
                s.block.state = State::Fault.word();
                s.block.fault = Fault::NotAtStart.word();
            }),
            vec![ended(1, Outcome::Refused { fault: 5 })],
            "idle",
        ),
        (
            "refused while the e-stop input is open",
            true,
            2,
            with(old, |s| {
                s.block.state = State::Stopped.word();
                s.block.fault = Fault::StoppedFromOutside.word();
            }),
            vec![ended(1, Outcome::Refused { fault: 3 })],
            "idle",
        ),
        ("not yet seen", true, 3, old, vec![], "starting"),
        (
            "not taken though acknowledged",
            true,
            10,
            old,
            vec![ended(1, Outcome::NotTaken { scans: 10 }), Event::WriteStop],
            "stopping",
        ),
        (
            "reply lost and not taken: written again",
            false,
            10,
            old,
            vec![Event::RewriteStart { tag: 1 }],
            "starting",
        ),
    ];
    for (what, confirmed, scans, s, want, phase) in cases {
        let mut bed = Bed::idle();
        bed.start(p.clone(), confirmed);
        assert_eq!(name(&bed.m), "starting", "{what}");
        // Scans are counted from the first status block read after the write.
        assert_eq!(bed.feed(old), [], "{what}");
        let events = bed.feed_after(scans, s);
        assert_eq!(events, want, "{what}");
        assert_eq!(name(&bed.m), phase, "{what}");
    }
}

#[test]
fn a_start_written_again_and_still_not_taken_ends() {
    let mut bed = Bed::idle();
    bed.start(planned(1, 8, FROM, TO), false);
    let old = status(State::Done, 7, 0, FROM);
    assert_eq!(bed.feed_after(3, old), [], "scans counted from here");
    assert_eq!(bed.feed_after(10, old), [Event::RewriteStart { tag: 1 }]);
    bed.m.start_rewritten(bed.now, true);
    assert_eq!(bed.feed_after(5, old), [], "and from here again");
    assert_eq!(bed.feed_after(5, old), []);
    assert_eq!(
        bed.feed_after(10, old),
        [ended(1, Outcome::NotTaken { scans: 15 }), Event::WriteStop]
    );
}

#[test]
fn running_transitions() {
    type Case = (&'static str, Status, Vec<Event>, &'static str);
    let mid = [120, 190, 300, 405];
    let run = status(State::Running, 8, 0, mid);
    let progress = |elapsed| Event::Progress {
        tag: 1,
        elapsed,
        fraction: 0.01,
    };
    let cases: Vec<Case> = vec![
        ("inside its envelope", run, vec![progress(mid)], "running"),
        (
            "one pulse past its envelope is still inside",
            with(run, |s| s.block.elapsed[0] = 151),
            vec![progress([151, 190, 300, 405])],
            "running",
        ),
        (
            "runs away",
            with(run, |s| s.block.elapsed[0] = 152),
            vec![
                ended(
                    1,
                    Outcome::OutsideEnvelope {
                        channel: 0,
                        count: 152,
                        min: 100,
                        max: 150,
                    },
                ),
                Event::WriteStop,
            ],
            "stopping",
        ),
        (
            "a channel that should stand still moves",
            with(run, |s| s.block.elapsed[2] = 302),
            vec![
                ended(
                    1,
                    Outcome::OutsideEnvelope {
                        channel: 2,
                        count: 302,
                        min: 300,
                        max: 300,
                    },
                ),
                Event::WriteStop,
            ],
            "stopping",
        ),
        (
            "done",
            status(State::Done, 8, 0, TO),
            vec![Event::Done {
                tag: 1,
                elapsed: Some(TO),
            }],
            "idle",
        ),
        (
            "stopped by the e-stop input",
            with(run, |s| {
                s.block.state = State::Stopped.word();
                s.block.fault = 3;
            }),
            vec![ended(1, Outcome::Stopped { fault: 3 })],
            "idle",
        ),
        (
            "a pulse instruction fault",
            with(run, |s| {
                s.block.state = State::Fault.word();
                s.block.fault = 4;
            }),
            vec![ended(1, Outcome::Faulted { fault: 4 })],
            "idle",
        ),
        (
            "another seq: trusted no more",
            with(run, |s| s.block.seq = 3),
            vec![ended(1, Outcome::Restarted), Event::WriteStop],
            "stopping",
        ),
        (
            "the PLC restarted (host word 0, counts 0)",
            with(run, |s| {
                s.block.host = 0;
                s.block.seq = 0;
                s.block.state = State::Idle.word();
                s.block.ready = 0b110;
                s.block.elapsed = [0; 4];
            }),
            vec![
                ended(1, Outcome::Restarted),
                Event::Restarted,
                Event::WriteHost,
            ],
            "unhomed",
        ),
    ];
    for (what, s, want, phase) in cases {
        let mut bed = Bed::running();
        let events = bed.feed(s);
        assert_eq!(events, want, "{what}");
        assert_eq!(name(&bed.m), phase, "{what}");
    }
}

#[test]
fn a_start_running_past_its_limit_is_stopped() {
    let mut bed = Bed::running();
    // Planned 1 s: the limit is 1.25 s + 1 s.
    bed.now += Duration::from_millis(2_240);
    assert!(matches!(
        bed.feed(status(State::Running, 8, 0, FROM))[..],
        [Event::Progress { .. }]
    ));
    let events = bed.feed(status(State::Running, 8, 0, FROM));
    assert!(
        matches!(
            events[..],
            [
                Event::Ended {
                    tag: 1,
                    outcome: Outcome::Overrun { .. }
                },
                Event::WriteStop
            ]
        ),
        "{events:?}"
    );
}

#[test]
fn a_heartbeat_standing_still_ends_everything_and_asks_for_a_stop() {
    let mut bed = Bed::chained();
    let s = status(State::Running, 8, 0, FROM);
    let _ = bed.feed(s);
    bed.now += Duration::from_millis(600);
    let events = bed.feed_after(0, s);
    let still = Duration::from_millis(610);
    assert_eq!(
        events,
        [
            ended(1, Outcome::Stalled { still }),
            ended(2, Outcome::Stalled { still }),
            Event::Stalled { still },
            Event::WriteStop
        ]
    );
    assert_eq!(name(&bed.m), "stalled");
    assert_eq!(bed.m.blocker(bed.now), Some(Blocker::Stalled));
    // It moves again: nothing is left in flight, and moves may start.
    let _ = bed.feed(status(State::Stopped, 8, 0, FROM));
    assert_eq!(name(&bed.m), "idle");
    assert_eq!(bed.m.blocker(bed.now), None);
}

#[test]
fn chained_transitions() {
    type Case = (&'static str, u16, Status, Vec<Event>, &'static str);
    let run = status(State::Running, 8, 0, [140, 185, 300, 408]);
    let progress = |elapsed| Event::Progress {
        tag: 1,
        elapsed,
        fraction: 0.02,
    };
    let cases: Vec<Case> = vec![
        (
            "shown waiting",
            1,
            with(run, |s| s.block.waiting = 9),
            vec![progress(run.block.elapsed), Event::Waiting { tag: 2 }],
            "running-chained",
        ),
        (
            "not yet shown",
            2,
            run,
            vec![progress(run.block.elapsed)],
            "running-chained",
        ),
        (
            "never shown waiting: withdrawn",
            10,
            run,
            vec![
                progress(run.block.elapsed),
                ended(2, Outcome::NotTaken { scans: 10 }),
                Event::Withdraw { tag: 2 },
            ],
            "running",
        ),
        (
            "the next already runs: the first ended done at its from",
            1,
            status(State::Running, 9, 0, TO),
            vec![
                Event::Done {
                    tag: 1,
                    elapsed: None,
                },
                Event::Started { tag: 2 },
                Event::Progress {
                    tag: 2,
                    elapsed: TO,
                    fraction: 0.0,
                },
            ],
            "running",
        ),
        (
            "the first done, the next waits one more scan",
            1,
            with(status(State::Done, 8, 0, TO), |s| s.block.waiting = 9),
            vec![Event::Done {
                tag: 1,
                elapsed: Some(TO),
            }],
            "starting",
        ),
        (
            "the first stopped: the next is dropped",
            1,
            with(run, |s| s.block.state = State::Stopped.word()),
            vec![
                ended(1, Outcome::Stopped { fault: 0 }),
                ended(2, Outcome::Dropped),
            ],
            "idle",
        ),
        (
            "the first runs away: the next goes with it",
            1,
            with(run, |s| s.block.elapsed[1] = 100),
            vec![
                ended(
                    1,
                    Outcome::OutsideEnvelope {
                        channel: 1,
                        count: 100,
                        min: 180,
                        max: 200,
                    },
                ),
                Event::WriteStop,
                ended(2, Outcome::Dropped),
            ],
            "stopping",
        ),
    ];
    for (what, scans, s, want, phase) in cases {
        let mut bed = Bed::chained();
        // The first status block after the write: the next is not yet shown waiting.
        let _ = bed.feed(run);
        let events = bed.feed_after(scans, s);
        assert_eq!(events, want, "{what}");
        assert_eq!(name(&bed.m), phase, "{what}");
    }
}

#[test]
fn a_waiting_start_that_disappears_was_dropped() {
    let mut bed = Bed::chained();
    let run = status(State::Running, 8, 0, FROM);
    let _ = bed.feed(with(run, |s| s.block.waiting = 9));
    let events = bed.feed(run);
    assert!(events.contains(&ended(2, Outcome::Dropped)), "{events:?}");
    assert_eq!(name(&bed.m), "running");
}

#[test]
fn a_refused_waiting_start_ends_refused_after_the_first_ends_done() {
    let mut bed = Bed::chained();
    let _ = bed.feed(with(status(State::Done, 8, 0, TO), |s| s.block.waiting = 9));
    let refused = with(status(State::Fault, 8, 0, TO), |s| s.block.fault = 5);
    assert_eq!(bed.feed(refused), [ended(2, Outcome::Refused { fault: 5 })]);
}

#[test]
fn stopping_transitions() {
    type Case = (&'static str, fn() -> Bed, Status, Vec<Event>, &'static str);
    let stopped = with(status(State::Stopped, 8, 0, [120, 190, 300, 405]), |_| {});
    let cases: Vec<Case> = vec![
        (
            "the running start stops",
            Bed::running,
            stopped,
            vec![ended(1, Outcome::Stopped { fault: 0 })],
            "idle",
        ),
        (
            "it got there first",
            Bed::running,
            status(State::Done, 8, 0, TO),
            vec![Event::Done {
                tag: 1,
                elapsed: Some(TO),
            }],
            "idle",
        ),
        (
            "the waiting start never runs",
            Bed::chained,
            stopped,
            vec![
                ended(1, Outcome::Stopped { fault: 0 }),
                ended(2, Outcome::Dropped),
            ],
            "idle",
        ),
        (
            "not yet acted on",
            Bed::running,
            status(State::Running, 8, 0, FROM),
            vec![],
            "stopping",
        ),
    ];
    for (what, bed, s, want, phase) in cases {
        let mut bed = bed();
        bed.m.stop_written(bed.now);
        let events = bed.feed(s);
        assert_eq!(events, want, "{what}");
        assert_eq!(name(&bed.m), phase, "{what}");
    }
}

#[test]
fn a_stop_that_does_not_take_is_written_again() {
    let mut bed = Bed::running();
    bed.m.stop_written(bed.now);
    let run = status(State::Running, 8, 0, FROM);
    assert_eq!(bed.feed_after(10, run), []);
    assert_eq!(bed.feed_after(10, run), [Event::WriteStop]);
    assert_eq!(bed.feed_after(2, run), []);
}

#[test]
fn homing_transitions() {
    let unhomed = || {
        let mut bed = Bed::idle();
        let _ = bed.feed(with(status(State::Idle, 0, 0, [0; 4]), |s| {
            s.block.ready = 0b110;
        }));
        assert_eq!(name(&bed.m), "unhomed");
        assert_eq!(bed.m.blocker(bed.now), Some(Blocker::NotHomed));
        bed.m.home_written(bed.now);
        bed
    };
    let homing = with(status(State::Homing, 0, 0, [0; 4]), |s| {
        s.block.ready = 0b110;
    });
    let mut bed = unhomed();
    assert_eq!(bed.feed(homing), []);
    assert_eq!(name(&bed.m), "homing");
    assert_eq!(bed.feed(status(State::Done, 0, 0, FROM)), [Event::Homed]);
    assert_eq!(name(&bed.m), "idle");
    assert_eq!(bed.m.blocker(bed.now), None);

    let mut bed = unhomed();
    let failed = with(homing, |s| {
        s.block.state = State::Fault.word();
        s.block.fault = 7;
    });
    assert_eq!(bed.feed(failed), [Event::HomeFailed { fault: 7 }]);

    // A home routine done within a scan shows only its homed bit.
    let mut bed = unhomed();
    assert_eq!(bed.feed_after(3, status(State::Done, 0, 0, FROM)), []);
    assert_eq!(
        bed.feed_after(10, status(State::Done, 0, 0, FROM)),
        [Event::Homed]
    );

    // Already homed, and the command never shows: not taken for homed.
    let mut bed = Bed::idle();
    bed.m.home_written(bed.now);
    assert_eq!(bed.feed_after(10, status(State::Done, 7, 0, FROM)), []);
    assert_eq!(
        bed.feed_after(10, status(State::Done, 7, 0, FROM)),
        [Event::HomeFailed { fault: 0 }]
    );
}

#[test]
fn a_link_that_comes_back_to_the_same_host_word_follows_on() {
    let mut bed = Bed::running();
    bed.m.link_lost(bed.now);
    assert_eq!(name(&bed.m), "link-down");
    assert_eq!(bed.m.blocker(bed.now), Some(Blocker::LinkDown));
    assert_eq!(bed.m.given().len(), 1);
    let events = bed.feed(status(State::Done, 8, 0, TO));
    assert_eq!(
        events,
        [Event::Done {
            tag: 1,
            elapsed: Some(TO)
        }]
    );
}

#[test]
fn a_link_that_comes_back_to_a_restarted_plc_ends_everything() {
    let mut bed = Bed::chained();
    bed.m.link_lost(bed.now);
    let restarted = with(status(State::Idle, 0, 0, [0; 4]), |s| {
        s.block.host = 0;
        s.block.ready = 0b110;
    });
    assert_eq!(
        bed.feed(restarted),
        [
            ended(1, Outcome::Restarted),
            ended(2, Outcome::Restarted),
            Event::Restarted,
            Event::WriteHost
        ]
    );
    assert_eq!(bed.m.blocker(bed.now), Some(Blocker::NotHomed));
}

#[test]
fn while_the_link_is_down_a_start_past_its_end_is_given_up() {
    let mut bed = Bed::running();
    bed.m.link_lost(bed.now);
    // Planned 1 s: its limit is 2.25 s, and the link gets 5 s more to come back.
    assert_eq!(bed.m.tick(bed.now + Duration::from_secs(7)), []);
    let events = bed.m.tick(bed.now + Duration::from_secs(8));
    assert!(
        matches!(
            events[..],
            [Event::Ended {
                tag: 1,
                outcome: Outcome::LinkLost { .. }
            }]
        ),
        "{events:?}"
    );
    assert!(bed.m.given().is_empty());
}

#[test]
fn blockers() {
    let bed = Bed::idle();
    assert_eq!(bed.m.blocker(bed.now), None);
    assert_eq!(bed.m.chain_behind(), None);
    let bed = Bed::running();
    assert_eq!(
        bed.m.blocker(bed.now),
        None,
        "chains behind the running start"
    );
    assert_eq!(bed.m.chain_behind().map(|p| p.seq), Some(8));
    let bed = Bed::chained();
    assert_eq!(bed.m.blocker(bed.now), Some(Blocker::Full));
    let mut bed = Bed::idle();
    let _ = bed.feed(with(status(State::Fault, 7, 0, FROM), |s| {
        s.block.fault = 2;
    }));
    assert_eq!(bed.m.blocker(bed.now), Some(Blocker::Faulted { fault: 2 }));
    let mut bed = Bed::idle();
    let _ = bed.feed(with(status(State::Done, 7, 0, FROM), |s| {
        s.block.ready = 0b011;
    }));
    assert_eq!(
        bed.m.blocker(bed.now),
        Some(Blocker::NotReady {
            ready: 0b011,
            required: 0b111
        })
    );
    let bed = Bed::idle();
    assert_eq!(
        bed.m.blocker(bed.now + Duration::from_millis(600)),
        Some(Blocker::Stalled)
    );
    let _ = bed.t0;
}

#[test]
fn a_start_is_written_only_from_the_counts_it_was_planned_from() {
    let mut bed = Bed::idle();
    let elsewhere = planned(1, 8, [101, 200, 300, 400], TO);
    bed.m.upload_begun();
    assert_eq!(
        bed.m.may_start(&planned(1, 8, FROM, TO), bed.now),
        Err(Blocker::Unproven),
        "no status read since the upload"
    );
    let idle = status(State::Done, 7, 0, FROM);
    let _ = bed.feed(idle);
    assert_eq!(
        bed.m.may_start(&planned(1, 8, FROM, TO), bed.now),
        Err(Blocker::Unproven),
        "one read: the heartbeat moved during the upload, perhaps not now"
    );
    let _ = bed.feed(idle);
    assert_eq!(
        bed.m.may_start(&elsewhere, bed.now),
        Err(Blocker::NotAtFrom {
            channel: 0,
            count: 100,
            from: 101
        })
    );
    assert_eq!(bed.m.may_start(&planned(1, 8, FROM, TO), bed.now), Ok(()));

    // A heartbeat that stands still between the two reads proves nothing.
    let mut bed = Bed::idle();
    bed.m.upload_begun();
    let _ = bed.feed(idle);
    let _ = bed.feed_after(0, idle);
    assert_eq!(
        bed.m.may_start(&planned(1, 8, FROM, TO), bed.now),
        Err(Blocker::Unproven)
    );

    // Chained: only from the running start's targets, while the PLC shows it running. The read
    // that saw it running (10 ms before) counts as the first: one read after the upload will do.
    let mut bed = Bed::running();
    bed.m.upload_begun();
    let run = status(State::Running, 8, 0, FROM);
    let _ = bed.feed(run);
    assert_eq!(bed.m.may_start(&planned(2, 9, TO, FROM), bed.now), Ok(()));
    assert_eq!(
        bed.m.may_start(&planned(2, 9, FROM, TO), bed.now),
        Err(Blocker::Full)
    );
    // ... but not a read before it further back than the heartbeat timeout, nor a heartbeat
    // that stood still.
    let mut late = Bed::running();
    late.m.upload_begun();
    late.now += Duration::from_millis(600);
    let _ = late.feed(run);
    assert_eq!(
        late.m.may_start(&planned(2, 9, TO, FROM), late.now),
        Err(Blocker::Unproven)
    );
    let mut still = Bed::running();
    still.m.upload_begun();
    let _ = still.feed_after(0, run);
    assert_eq!(
        still.m.may_start(&planned(2, 9, TO, FROM), still.now),
        Err(Blocker::Unproven)
    );
    let _ = bed.feed(with(run, |s| s.block.waiting = 33));
    assert_eq!(
        bed.m.may_start(&planned(2, 9, TO, FROM), bed.now),
        Err(Blocker::Full),
        "something already waits"
    );
}

#[test]
fn the_first_of_the_two_heartbeat_reads_may_be_of_its_word_alone() {
    let idle = status(State::Done, 7, 0, FROM);
    let p = planned(1, 8, FROM, TO);
    // Nothing ran during the upload: two reads are wanted, the first may be the word alone.
    let mut bed = Bed::idle();
    assert!(!bed.m.proof_wants_two_reads(bed.now), "not uploading");
    bed.m.upload_begun();
    assert!(bed.m.proof_wants_two_reads(bed.now));
    bed.beat = bed.beat.wrapping_add(1);
    bed.m.heartbeat_read(bed.beat, bed.now);
    assert!(!bed.m.proof_wants_two_reads(bed.now), "one read made");
    assert_eq!(bed.m.may_start(&p, bed.now), Err(Blocker::Unproven));
    let _ = bed.feed(idle);
    assert_eq!(bed.m.may_start(&p, bed.now), Ok(()));
    // A heartbeat that stood still between the word and the block proves nothing.
    let mut still = Bed::idle();
    still.m.upload_begun();
    still.m.heartbeat_read(still.beat, still.now);
    let _ = still.feed_after(0, idle);
    assert_eq!(still.m.may_start(&p, still.now), Err(Blocker::Unproven));
    // Nor does the word alone, however it moved: a status read must follow.
    let mut alone = Bed::idle();
    alone.m.upload_begun();
    for k in 1..=3 {
        alone
            .m
            .heartbeat_read(alone.beat.wrapping_add(k), alone.now);
    }
    assert_eq!(alone.m.may_start(&p, alone.now), Err(Blocker::Unproven));
    // Behind a running start whose read before the upload is recent, one read will do.
    let mut bed = Bed::running();
    bed.m.upload_begun();
    assert!(!bed.m.proof_wants_two_reads(bed.now));
    bed.now += Duration::from_millis(600);
    assert!(
        bed.m.proof_wants_two_reads(bed.now),
        "that read is too old now"
    );
}

/// The counts planned `t_s` into a 1 s start from FROM: channel 0 out 1000 pulses and back,
/// channel 1 on 2000 and channel 3 on 500 at a steady pace, channel 2 still.
fn out_and_back(t_s: f64) -> [i32; CHANNELS] {
    let t = t_s.clamp(0.0, 1.0);
    let offset = [
        1_000.0 * (1.0 - (2.0 * t - 1.0).abs()),
        2_000.0 * t,
        0.0,
        500.0 * t,
    ];
    std::array::from_fn(|c| FROM[c] + offset[c].round() as i32)
}

/// Start 8 (tag 1) along [`out_and_back`], its curve sampled every 10 ms.
fn out_and_back_start() -> Planned {
    let points: Vec<(Duration, [i32; CHANNELS])> = (0..=100_u32)
        .map(|i| {
            let at = Duration::from_millis(u64::from(i) * 10);
            (at, out_and_back(at.as_secs_f64()))
        })
        .collect();
    let curve = ProgressCurve::new(&points).unwrap();
    let to = out_and_back(1.0);
    Planned {
        envelope: std::array::from_fn(|c| {
            let along = points.iter().map(|(_, p)| p[c]);
            (along.clone().min().unwrap(), along.max().unwrap())
        }),
        curve: Some(Arc::new(curve)),
        ..planned(1, 8, FROM, to)
    }
}

/// A machine running `p`, seen running at FROM, and when it was seen.
fn along(p: Planned) -> (Bed, Instant) {
    let mut bed = Bed::idle();
    bed.start(p, true);
    let events = bed.feed(status(State::Running, 8, 0, FROM));
    assert!(events.contains(&Event::Started { tag: 1 }), "{events:?}");
    let since = bed.now;
    (bed, since)
}

/// The progress shown for `counts` read `ms` after the start was seen running.
fn progress_at(bed: &mut Bed, since: Instant, ms: u64, counts: [i32; CHANNELS]) -> f64 {
    // `feed_after` reads 10 ms on.
    bed.now = since + Duration::from_millis(ms - 10);
    let events = bed.feed_after(1, status(State::Running, 8, 0, counts));
    match events[..] {
        [Event::Progress { fraction, .. }] => fraction,
        _ => panic!("{events:?}"),
    }
}

#[test]
fn a_start_whose_counts_stand_still_shows_no_progress_as_time_goes_on() {
    let (mut bed, since) = along(out_and_back_start());
    let held = out_and_back(0.3);
    let shown: Vec<f64> = [300, 500, 800, 1_200, 1_800, 2_200]
        .into_iter()
        .map(|ms| progress_at(&mut bed, since, ms, held))
        .collect();
    assert!(shown.iter().all(|f| (f - 0.3).abs() < 0.005), "{shown:?}");
    // Released, it goes on from there.
    let f = progress_at(&mut bed, since, 2_240, out_and_back(0.4));
    assert!((f - 0.4).abs() < 0.005, "{f}");
}

#[test]
fn counts_half_way_along_the_plan_show_about_one_half_whatever_the_clock() {
    for ms in [100, 500, 900, 2_000] {
        let (mut bed, since) = along(out_and_back_start());
        let f = progress_at(&mut bed, since, ms, out_and_back(0.5));
        assert!((f - 0.5).abs() < 0.005, "{ms} ms: {f}");
    }
    // Between two points of the curve too.
    let (mut bed, since) = along(out_and_back_start());
    let f = progress_at(&mut bed, since, 600, out_and_back(0.555));
    assert!((f - 0.555).abs() < 0.005, "{f}");
}

#[test]
fn a_start_is_never_shown_further_ahead_of_its_clock_than_a_read_can_be_late() {
    // Counts at 0.9 s, read 0.1 s after the start was seen: the PLC cannot be that far ahead
    // (a path that passes again near where it was is not taken for its second pass).
    let (mut bed, since) = along(out_and_back_start());
    let f = progress_at(&mut bed, since, 100, out_and_back(0.9));
    let ahead = (Duration::from_millis(100) + AHEAD).as_secs_f64();
    assert!((f - ahead).abs() < 0.005, "{f}");
    let f = progress_at(&mut bed, since, 400, out_and_back(0.9));
    assert!((f - 0.9).abs() < 0.005, "{f}");
}

#[test]
fn a_joint_that_reverses_does_not_take_the_progress_back() {
    // Channel 0 is at +500 both 0.25 s and 0.75 s in, going out and coming back: the other
    // channels tell the two apart.
    let (mut bed, since) = along(out_and_back_start());
    assert_eq!(out_and_back(0.25)[0], out_and_back(0.75)[0]);
    let f = progress_at(&mut bed, since, 250, out_and_back(0.25));
    assert!((f - 0.25).abs() < 0.005, "{f}");
    let f = progress_at(&mut bed, since, 750, out_and_back(0.75));
    assert!((f - 0.75).abs() < 0.005, "{f}");
    // A read with channel 0 where it was on the way out, the others a little behind: the plan
    // is searched only on from where the start was found, so it holds there.
    let mut behind = out_and_back(0.7);
    behind[0] = out_and_back(0.2)[0];
    let f = progress_at(&mut bed, since, 800, behind);
    assert!((f - 0.75).abs() < 0.005, "{f}");
    // Channel 0 on its way back alone tells nothing of where the start is (its share of its
    // way falls); the share shown goes on with the others.
    let f = progress_at(&mut bed, since, 900, out_and_back(0.9));
    assert!((f - 0.9).abs() < 0.005, "{f}");
}

#[test]
fn the_progress_never_decreases_on_a_slow_and_unsteady_plc() {
    // The PLC plays the plan at a pace that wanders between standing still and the planned
    // pace, with reads a couple of pulses off; the progress follows the plan's time, and never
    // goes back.
    let (mut bed, since) = along(out_and_back_start());
    let mut random = 0x2545_F491_u32;
    let mut next = move || {
        random ^= random << 13;
        random ^= random >> 17;
        random ^= random << 5;
        random
    };
    let envelope = out_and_back_start().envelope;
    let (mut planned_s, mut last) = (0.0_f64, 0.0_f64);
    for read in 1..=200_u64 {
        planned_s = (planned_s + f64::from(next() % 11) / 1_000.0).min(1.0);
        let mut counts = out_and_back(planned_s);
        for (c, count) in counts.iter_mut().enumerate() {
            let noise = (next() % 5) as i32 - 2;
            *count = (*count + noise).clamp(envelope[c].0, envelope[c].1);
        }
        let f = progress_at(&mut bed, since, read * 10, counts);
        assert!(f >= last, "read {read}: {f} after {last}");
        assert!(
            (f - planned_s).abs() < 0.01,
            "read {read}: {f} at {planned_s}"
        );
        last = f;
    }
    assert!(planned_s > 0.8, "{planned_s}");
}
