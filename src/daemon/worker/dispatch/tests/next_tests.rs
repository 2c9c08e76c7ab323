//! What the worker does next ([`Dispatcher::next`]), step by step, with no mock PLC or runtime:
//! the order of its steps, the status read's pace and turns with the gateway, the link's
//! backoff, a held bank and a proof read.

use super::*;
use crate::plc::exchange::VerifiedBank;

/// The link up, nothing taken in.
fn up() -> Seen {
    Seen {
        link_up: true,
        ..Seen::default()
    }
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// The action's name, and the move it is about where it names one.
fn what(action: &Action) -> (&'static str, Option<MoveId>) {
    match action {
        Action::ShutDown => ("shut down", None),
        Action::Connect => ("connect", None),
        Action::Stop => ("stop", None),
        Action::Commands => ("commands", None),
        Action::Finish(ends) => ("finish", ends.first().map(|e| e.id)),
        Action::ReadMode => ("read mode", None),
        Action::JudgeLead { id, .. } => ("judge", Some(*id)),
        Action::PreloadAhead(due) => ("preload ahead", Some(due.id)),
        Action::AheadStep { ahead, .. } => ("ahead step", Some(ahead.id)),
        Action::Begin(q) => ("begin", Some(q.id)),
        Action::UploadStep { uploading, .. } => ("upload", Some(uploading.turn.id)),
        Action::ProveRead(u) => ("prove", Some(u.turn.id)),
        Action::WriteStart(u) => ("start", Some(u.turn.id)),
        Action::Unprepare { id, .. } => ("unprepare", Some(*id)),
        Action::Gateway => ("gateway", None),
        Action::Poll => ("poll", None),
        Action::Wait { .. } => ("wait", None),
        Action::Pause { .. } => ("pause", None),
    }
}

/// Move 4's bank, verified: held behind `gate`, or to be started from rest.
fn uploaded(gate: Option<Gate>) -> Box<Uploaded> {
    let mode = match gate {
        Some(gate) => StartMode::Gated { gate, ahead: None },
        None => StartMode::FromRest,
    };
    Box::new(Uploaded {
        turn: Turn {
            id: 4,
            order: order(Permit::NONE),
            mode,
            from: FROM,
            preload: None,
        },
        planned: planned(4, 8, FROM, TO),
        bank: VerifiedBank {
            block: CommandBlock::default(),
            words: 0,
            on_preload: false,
        },
        upload_s: 0.1,
    })
}

#[test]
fn shutdown_then_a_stop_overtake_commands_and_the_queue() {
    let t0 = Instant::now();
    let now = t0 + ms(30);
    let mut d = idle(t0);
    d.push(queued(1, None, t0));
    let all = Seen {
        shutting_down: true,
        stop: true,
        commands: true,
        gateway: true,
        ..up()
    };
    assert_eq!(what(&d.next(all, now)), ("shut down", None));
    let taken = Seen {
        shutting_down: false,
        ..all
    };
    assert_eq!(what(&d.next(taken, now)), ("stop", None));
    let commands = Seen {
        stop: false,
        ..taken
    };
    assert_eq!(what(&d.next(commands, now)), ("commands", None));
    // The head begins on the status block just read (fresh), before the gateway.
    let gateway = Seen {
        commands: false,
        ..commands
    };
    assert_eq!(what(&d.next(gateway, now)), ("begin", Some(1)));
    assert!(d.queue().is_empty());
    assert_eq!(d.next_poll(), None, "read at once after a turn");
}

#[test]
fn the_status_read_and_the_gateway_take_turns_and_the_worker_waits_between_reads() {
    let t0 = Instant::now();
    let now = t0 + ms(30);
    let mut d = idle(t0);
    let gateway = Seen {
        gateway: true,
        ..up()
    };
    // Both due, the read first (the gateway's turn comes after a read).
    assert_eq!(what(&d.next(gateway, now)), ("poll", None));
    d.polled(now, Some(now), false);
    // At rest: the next read a quarter of a second later.
    assert_eq!(d.next_poll(), Some(now + ms(250)));
    assert_eq!(what(&d.next(gateway, now)), ("gateway", None));
    // The read not due: the gateway is served on.
    assert_eq!(what(&d.next(gateway, now + ms(10))), ("gateway", None));
    // Both due: the gateway had its turn, the read comes first, then the gateway again.
    let due = now + ms(250);
    assert_eq!(what(&d.next(gateway, due)), ("poll", None));
    d.polled(due, Some(now), false);
    assert_eq!(what(&d.next(gateway, due)), ("gateway", None));
    // Nothing to do: a wait until the next read.
    let Action::Wait { until, gate } = d.next(up(), due + ms(1)) else {
        panic!("nothing to do: a wait");
    };
    assert_eq!((until, gate.is_none()), (due + ms(250), true));
    // A request came (the read asked for at once).
    d.poll_now();
    assert_eq!(what(&d.next(up(), due + ms(2))), ("poll", None));
}

#[test]
fn the_mode_is_read_after_a_read_at_rest_when_it_is_old() {
    let t0 = Instant::now();
    let now = t0 + ms(30);
    let mut d = idle(t0);
    d.polled(now, None, false);
    assert_eq!(what(&d.next(up(), now)), ("read mode", None));
    assert_eq!(what(&d.next(up(), now)), ("wait", None), "once");
    d.polled(now, Some(t0), false);
    assert_eq!(what(&d.next(up(), now)), ("wait", None), "read 30 ms ago");
    // Running, it is not read.
    let mut d = running(t0);
    d.polled(now + ms(10), None, false);
    assert_ne!(what(&d.next(up(), now + ms(10))).0, "read mode");
}

#[test]
fn a_busy_robot_is_read_at_the_busy_pace_and_a_scan_apart_near_its_end() {
    let t0 = Instant::now();
    let mut d = running(t0);
    let now = t0 + ms(40);
    d.polled(now, Some(now), false);
    assert_eq!(d.next_poll(), Some(now + PACE.poll_interval));
    // Start 8 runs 1 s from t0 + 30 ms: within two polls of its end, a scan apart.
    let late = t0 + ms(950);
    d.polled(late, Some(now), false);
    assert_eq!(d.next_poll(), Some(late + PACE.scan_time));
    // At rest with inputs watched (a cycle's wait): the busy pace.
    let mut d = idle(t0);
    d.polled(now, Some(now), true);
    assert_eq!(d.next_poll(), Some(now + PACE.poll_interval));
}

#[test]
fn a_link_down_is_opened_at_once_and_after_a_failed_attempt_its_backoff_ends_in_answers() {
    let t0 = Instant::now();
    let mut d = dispatcher();
    d.push(queued(1, None, t0));
    let down = Seen {
        stop: true,
        commands: true,
        gateway: true,
        ..Seen::default()
    };
    // Just lost (or never opened): an attempt first, whatever waits.
    assert_eq!(what(&d.next(down, t0)), ("connect", None));
    d.connect_failed(t0, ms(100));
    let Action::Wait { until, .. } = d.next(down, t0) else {
        panic!("the backoff");
    };
    assert_eq!(until, t0 + ms(100));
    // Woken (by the stop, or at the backoff's end): what came is answered, then an attempt.
    assert_eq!(what(&d.next(down, t0 + ms(10))), ("stop", None));
    let down = Seen {
        stop: false,
        ..down
    };
    assert_eq!(what(&d.next(down, t0 + ms(10))), ("commands", None));
    let down = Seen {
        commands: false,
        ..down
    };
    assert_eq!(what(&d.next(down, t0 + ms(10))), ("gateway", None));
    assert_eq!(
        what(&d.next(Seen::default(), t0 + ms(10))),
        ("connect", None)
    );
    // A queue that waited too long expires while the link is down, after a backoff (its time
    // counted from when its turn could first have come: the first look at it, at 10 ms).
    d.connect_failed(t0 + ms(20), ms(100));
    let late = t0 + ms(10) + START_WITHIN + ms(1);
    assert_eq!(what(&d.next(Seen::default(), late)), ("finish", Some(1)));
    assert_eq!(what(&d.next(Seen::default(), late)), ("connect", None));
}

#[test]
fn a_held_bank_is_read_and_waits_on_its_gate_then_starts_on_a_fresh_read() {
    let t0 = Instant::now();
    let now = t0 + ms(20);
    let mut d = idle(t0);
    let gate = Gate::new();
    d.machine.upload_begun();
    // Two reads since its upload began show the heartbeat moving: the PLC may take its start.
    d.machine
        .on_status(&status(State::Done, 7, 3, FROM), t0 + ms(12));
    d.machine
        .on_status(&status(State::Done, 7, 4, FROM), t0 + ms(15));
    d.activity = Activity::Holding(uploaded(Some(gate.clone())));
    // The gateway is served and the status block read while it is held.
    let gateway = Seen {
        gateway: true,
        ..up()
    };
    assert_eq!(what(&d.next(gateway, now)), ("gateway", None));
    assert_eq!(what(&d.next(up(), now)), ("poll", None));
    d.polled(now, Some(now), false);
    let Action::Wait { gate: waits_on, .. } = d.next(up(), now) else {
        panic!("held: a wait");
    };
    assert!(waits_on.is_some(), "woken by its gate");
    assert!(matches!(d.activity, Activity::Holding(_)));
    // Its gate opens on a fresh read: started on it.
    gate.open();
    assert_eq!(what(&d.next(up(), now)), ("start", Some(4)));
    // On a stale read: a proof read first.
    d.activity = Activity::Holding(uploaded(Some(gate.clone())));
    assert_eq!(what(&d.next(up(), now + ms(500))), ("prove", Some(4)));
}

#[test]
fn a_held_bank_is_cancelled_by_a_stop_a_command_or_its_gate_shut() {
    let t0 = Instant::now();
    let now = t0 + ms(20);
    let cases = [
        (
            Seen {
                stop_pending: true,
                ..up()
            },
            "a stop was asked for",
        ),
        (
            Seen {
                commands: true,
                ..up()
            },
            "a command came (home, clear-fault)",
        ),
        (
            Seen {
                shutting_down: true,
                ..up()
            },
            "the daemon is shutting down",
        ),
    ];
    for (seen, want) in cases {
        let mut d = idle(t0);
        d.machine.upload_begun();
        d.activity = Activity::Holding(uploaded(Some(Gate::new())));
        let Action::Unprepare { id, why } = d.next(seen, now) else {
            panic!("{want}: cancelled");
        };
        assert_eq!((id, why.as_str()), (4, want));
        assert!(matches!(d.activity, Activity::Idle));
    }
    let mut d = idle(t0);
    d.machine.upload_begun();
    let gate = Gate::new();
    d.activity = Activity::Holding(uploaded(Some(gate.clone())));
    gate.shut();
    let Action::Unprepare { why, .. } = d.next(up(), now) else {
        panic!("shut: cancelled");
    };
    assert_eq!(why, CYCLE_WENT_ON);
}

#[test]
fn a_held_bank_is_cancelled_when_a_read_shows_the_plc_changed_under_it() {
    let t0 = Instant::now();
    let mut d = idle(t0);
    d.machine.upload_begun();
    d.activity = Activity::Holding(uploaded(Some(Gate::new())));
    // The PLC restarted: its host word cleared.
    let mut restarted = status(State::Idle, 0, 3, FROM);
    restarted.block.host = 0;
    let now = t0 + ms(30);
    d.machine.on_status(&restarted, now);
    // Only the worker's own read of it decides (a read made for the upload does not).
    assert_eq!(what(&d.next(up(), now)), ("poll", None));
    d.polled(now, Some(now), false);
    let Action::Unprepare { why, .. } = d.next(up(), now) else {
        panic!("cancelled");
    };
    assert_eq!(why, "the PLC changed under it");
}

#[test]
fn a_proof_read_that_does_not_prove_is_made_again_half_a_scan_later() {
    let t0 = Instant::now();
    let now = t0 + ms(20);
    let mut d = idle(t0);
    d.activity = Activity::Proving(uploaded(None), None);
    let Action::ProveRead(u) = d.next(up(), now) else {
        panic!("a proof read");
    };
    assert!(d.proven(u, false, now).is_none());
    let Action::Pause { until } = d.next(up(), now + ms(1)) else {
        panic!("half a scan");
    };
    assert_eq!(until, now + PACE.scan_time / 2);
    let Action::ProveRead(u) = d.next(up(), until) else {
        panic!("read again");
    };
    assert_eq!(d.proven(u, true, until).map(|u| u.turn.id), Some(4));
}

/// A path cut into parts queued behind a running start: its first part waits for rest until the
/// worker judged it against that start. Judged from rest, it waits (and is not judged again
/// behind the same start); judged behind it, it begins chained to it, planned from its targets
/// into the other bank; behind another start it is judged again.
#[test]
fn a_paths_first_part_behind_a_running_start_is_judged_once_and_begins_behind_it_if_judged_so() {
    let t0 = Instant::now();
    let now = t0 + ms(40);
    let mut d = running(t0);
    d.push_order((2..).zip(super::section_parts(3)).collect(), None, None, t0);
    let Action::JudgeLead { id, behind } = d.next(up(), now) else {
        panic!("the first part is judged first");
    };
    assert_eq!((id, behind.seq, behind.targets), (2, 8, Some(TO)));
    assert!(!d.has_room(now), "unjudged, it waits for rest");
    d.judged(
        2,
        Lead::FromRest {
            seq: 8,
            ahead: false,
        },
    );
    assert!(!d.has_room(now));
    // From rest: its second part is preloaded ahead, once, behind start 8.
    let Action::PreloadAhead(due) = d.next(up(), now) else {
        panic!("its second part is preloaded ahead");
    };
    assert_eq!((due.id, due.behind.seq), (3, 8));
    assert!(due.first.leads_parts());
    let next = what(&d.next(up(), now)).0;
    assert!(
        !["judge", "preload ahead"].contains(&next),
        "{next}: once behind start 8"
    );
    assert!(
        d.expire(true, now + START_WITHIN * 2).is_empty(),
        "waiting for rest never expires"
    );
    d.judged(2, Lead::Behind { seq: 8 });
    assert!(d.has_room(now));
    let head = d.queue.pop_front().expect("the first part");
    let TurnDecision::Begin(turn) = d.turn(head, now) else {
        panic!("judged behind start 8: it begins");
    };
    let StartMode::Chained(ahead) = &turn.mode else {
        panic!("chained behind start 8: {:?}", turn.mode);
    };
    assert_eq!((ahead.seq, turn.from), (8, TO));
    assert_eq!(d.next_bank(Some(ahead.bank)), 1 - ahead.bank);
    // Judged behind start 8, it is judged again behind any other.
    d.push_front(*queued_lead(2, Lead::Behind { seq: 7 }, t0));
    assert!(!d.has_room(now));
    assert_eq!(what(&d.next(up(), now)), ("judge", Some(2)));
}

/// Move `id`, the first part of a path cut into 3, judged `lead`.
fn queued_lead(id: MoveId, lead: Lead, accepted: Instant) -> Box<Queued> {
    Box::new(Queued {
        order: super::section_parts(3).remove(0),
        lead,
        ..queued(id, None, accepted)
    })
}

/// A path's second part preloaded ahead into the bank the running start does not use: its first
/// part, from rest, goes into the bank that start ran from, and a start from rest into that
/// bank keeps the preload (any other bank would drop it, as every other preload is dropped).
#[test]
fn a_second_part_preloaded_ahead_sends_its_first_part_into_the_other_bank_and_is_kept() {
    let t0 = Instant::now();
    let now = t0 + ms(40);
    let mut d = running(t0);
    let running_bank = d.machine.chain_behind().expect("start 8 runs").bank;
    d.push_order((2..).zip(super::section_parts(3)).collect(), None, None, t0);
    d.judged(
        2,
        Lead::FromRest {
            seq: 8,
            ahead: false,
        },
    );
    let Action::PreloadAhead(due) = d.next(up(), now) else {
        panic!("its second part is preloaded ahead");
    };
    assert_eq!(due.behind.bank, running_bank);
    d.preloaded(3, Preload::empty(1 - running_bank), ms(500));
    assert_eq!(d.preload_of(3).map(|p| p.took), Some(ms(500)));
    // Start 8 ends: the first part's turn, from rest.
    d.machine
        .on_status(&status(State::Done, 8, 4, TO), t0 + ms(1_100));
    let head = d.queue.pop_front().expect("the first part");
    let TurnDecision::Begin(turn) = d.turn(head, t0 + ms(1_110)) else {
        panic!("at rest: it begins");
    };
    assert!(turn.mode.ahead().is_none(), "from rest");
    assert_eq!(d.next_bank(None), running_bank, "the bank start 8 ran from");
    d.forget_preloads_but_ahead(1 - running_bank);
    assert!(d.preload_of(3).is_none(), "a start into its bank drops it");
    d.preloaded(3, Preload::empty(1 - running_bank), ms(500));
    d.forget_preloads_but_ahead(running_bank);
    assert!(d.preload_of(3).is_some(), "kept behind its first part");
    assert!(d.preload_of(4).is_none());
}
