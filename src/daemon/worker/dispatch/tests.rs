//! The dispatcher's decisions, without a mock PLC or a runtime: a machine fed status blocks by
//! hand, the time passed in.

use nalgebra::Vector3;

use super::*;
use crate::contract::machine::WatchSettings;
use crate::contract::{CommandBlock, Fault, PermitBit, State, StatusBlock};
use crate::order::Target;

const HOST: u16 = 0xA5A5;
const FROM: [i32; CHANNELS] = [100, 200, 300, 400];
const TO: [i32; CHANNELS] = [150, 180, 300, 410];
const START_WITHIN: Duration = Duration::from_secs(5);

/// A status block: the contract's magic and version, homed and ready, our host word.
fn status(state: State, seq: u16, heartbeat: u16, elapsed: [i32; CHANNELS]) -> Status {
    crate::testing::status(state, seq, heartbeat, elapsed, HOST)
}

fn planned(tag: MoveId, seq: u16, from: [i32; CHANNELS], to: [i32; CHANNELS]) -> Planned {
    Planned {
        tag,
        seq,
        bank: seq % 2,
        from,
        targets: Some(to),
        envelope: std::array::from_fn(|c| (from[c].min(to[c]), from[c].max(to[c]))),
        duration: Duration::from_secs(1),
        curve: None,
        permit: Permit::NONE,
    }
}

/// The status block read every 50 ms at the busy pace, the PLC's scan 10 ms.
const PACE: PollPace = PollPace {
    poll_interval: Duration::from_millis(50),
    scan_time: Duration::from_millis(10),
};

/// A dispatcher whose machine has seen nothing of the PLC yet.
fn dispatcher() -> Dispatcher {
    Dispatcher::new(
        Machine::new(WatchSettings::default(), HOST),
        START_WITHIN,
        PACE,
    )
}

/// A dispatcher whose machine has seen the PLC idle at `FROM` (start 7 done), heartbeat moving.
fn idle(t0: Instant) -> Dispatcher {
    let mut d = dispatcher();
    d.machine.on_status(&status(State::Done, 7, 1, FROM), t0);
    d.machine.on_status(
        &status(State::Done, 7, 2, FROM),
        t0 + Duration::from_millis(10),
    );
    assert_eq!(d.blocker(true, t0 + Duration::from_millis(10)), None);
    d
}

/// `idle`, then start 8 (move 1, `FROM` to `TO`) written and seen running.
fn running(t0: Instant) -> Dispatcher {
    let mut d = idle(t0);
    d.machine.upload_begun();
    d.machine.start_written(
        planned(1, 8, FROM, TO),
        t0 + Duration::from_millis(20),
        true,
    );
    let events = d.machine.on_status(
        &status(State::Running, 8, 3, FROM),
        t0 + Duration::from_millis(30),
    );
    assert!(events.contains(&Event::Started { tag: 1 }), "{events:?}");
    d
}

fn order(permit: Permit) -> CheckedOrder {
    CheckedOrder {
        target: Target::By {
            delta_mm: Vector3::new(10.0, 0.0, 0.0),
            delta_a_rad: 0.0,
        },
        motion: crate::robot::seed_robot().motion,
        permit,
        accepted: None,
    }
}

fn queued(id: MoveId, gate: Option<Gate>, accepted: Instant) -> Queued {
    Queued {
        id,
        order: order(Permit::NONE),
        gate,
        epoch: None,
        accepted,
        preload: None,
        lead: Lead::Unjudged,
    }
}

fn ids(ends: &[Finish]) -> Vec<(MoveId, Stage)> {
    ends.iter().map(|e| (e.id, e.stage)).collect()
}

use crate::contract::machine::Event;

#[test]
fn a_head_that_cannot_start_within_its_time_fails_and_the_rest_are_cancelled() {
    let t0 = Instant::now();
    let mut d = dispatcher();
    d.push(queued(1, None, t0));
    d.push(queued(2, None, t0));
    // The link is down: the time counts from when the head was accepted.
    assert!(d.expire(false, t0).is_empty());
    assert!(d.expire(false, t0 + START_WITHIN).is_empty());
    let ends = d.expire(false, t0 + START_WITHIN + Duration::from_millis(1));
    assert_eq!(ids(&ends), [(1, Stage::Failed), (2, Stage::Cancelled)]);
    assert_eq!(
        ends[0].error.as_deref(),
        Some(format!("did not start within 5 s: {}", Blocker::LinkDown).as_str())
    );
    assert_eq!(
        ends[1].error.as_deref(),
        Some("cancelled: the move before it did not start")
    );
    assert!(d.queue().is_empty());
}

#[test]
fn the_time_a_move_ahead_runs_does_not_count_toward_a_turn() {
    let t0 = Instant::now();
    let mut d = running(t0);
    // Start 9 chained behind start 8: the PLC is full.
    d.machine.upload_begun();
    d.machine.start_written(
        planned(2, 9, TO, FROM),
        t0 + Duration::from_millis(40),
        true,
    );
    // Accepted long ago, behind moves that ran all that time.
    let long_ago = t0.checked_sub(10 * START_WITHIN).expect("the clock runs");
    d.push(queued(3, None, long_ago));
    let now = t0 + Duration::from_millis(50);
    assert_eq!(d.blocker(true, now), Some(Blocker::Full));
    assert!(d.expire(true, now).is_empty());
    assert_eq!(d.queue().len(), 1);
}

#[test]
fn a_turn_starts_from_rest_chained_or_gated_by_what_runs() {
    let t0 = Instant::now();
    let now = t0 + Duration::from_millis(30);
    let mut d = idle(t0);
    let TurnDecision::Begin(turn) = d.turn(queued(1, None, t0), now) else {
        panic!("idle: it begins");
    };
    assert!(matches!(turn.mode, StartMode::FromRest));
    assert_eq!(turn.from, FROM, "from the counts the PLC reports");

    let mut d = running(t0);
    let now = t0 + Duration::from_millis(40);
    let TurnDecision::Begin(turn) = d.turn(queued(2, None, t0), now) else {
        panic!("running: it chains");
    };
    assert!(matches!(&turn.mode, StartMode::Chained(ahead) if ahead.tag == 1));
    assert_eq!(
        turn.from, TO,
        "from the targets of the start it chains behind"
    );
    assert_eq!(d.next_bank(turn.mode.ahead().map(|a| a.bank)), 1);

    let gate = Gate::new();
    let TurnDecision::Begin(turn) = d.turn(queued(3, Some(gate), t0), now) else {
        panic!("running: a prepared move is uploaded behind it");
    };
    let StartMode::Gated { ahead, .. } = &turn.mode else {
        panic!("gated: {:?}", turn.mode);
    };
    assert_eq!(ahead.as_ref().map(|a| a.tag), Some(1));
    assert!(turn.mode.gate().is_some());
}

#[test]
fn a_turn_whose_permit_does_not_hold_ends_before_anything_is_written() {
    let t0 = Instant::now();
    let now = t0 + Duration::from_millis(30);
    let mut d = idle(t0);
    let permit = Permit::of(&[PermitBit {
        word: 0,
        bit: 3,
        on: true,
    }])
    .expect("one bit");
    let mut q = queued(1, None, t0);
    q.order = order(permit);
    let decision = d.turn(q, now);
    assert!(
        matches!(
            decision,
            TurnDecision::PermitNotMet(1, Blocker::PermitNotMet { .. })
        ),
        "{decision:?}"
    );
    // A prepared move's permit is checked when its gate opens.
    let mut q = queued(2, Some(Gate::new()), t0);
    q.order = order(permit);
    assert!(matches!(d.turn(q, now), TurnDecision::Begin(_)));
}

#[test]
fn a_turn_the_plc_cannot_take_stays_at_the_head() {
    let t0 = Instant::now();
    let mut d = dispatcher();
    d.push(queued(2, None, t0));
    assert!(matches!(
        d.turn(queued(1, None, t0), t0),
        TurnDecision::Wait
    ));
    let order: Vec<MoveId> = d.queue().iter().map(|q| q.id).collect();
    assert_eq!(order, [1, 2]);
}

#[test]
fn a_shut_gate_cancels_its_move_and_every_move_behind_it() {
    let t0 = Instant::now();
    let mut d = idle(t0);
    let gate = Gate::new();
    d.push(queued(1, None, t0));
    d.push(queued(2, Some(gate.clone()), t0));
    d.push(queued(3, None, t0));
    assert!(d.drop_shut().is_empty(), "a closed gate waits");
    gate.shut();
    let ends = d.drop_shut();
    assert_eq!(ids(&ends), [(2, Stage::Cancelled), (3, Stage::Cancelled)]);
    assert_eq!(
        ends[0].error.as_deref(),
        Some(format!("{PREPARED_CANCELLED}: {CYCLE_WENT_ON}").as_str())
    );
    assert_eq!(d.queue().len(), 1);
}

/// A path section cut into `parts` starts chained at speed, as the handle queues it.
pub(super) fn section_parts(parts: usize) -> Vec<CheckedOrder> {
    use crate::geometry::{Corner, Element, Path, PathSpec, Pose};
    use crate::order::{SectionOrder, SectionPart};
    let pose = |x: f64| Pose {
        position_mm: Vector3::new(x, 500.0, 150.0),
        a_rad: 0.0,
    };
    let spec = PathSpec {
        start: pose(-900.0),
        elements: vec![(Element::Line { to: pose(-800.0) }, Corner::Stop)],
    };
    let section = Arc::new(SectionOrder {
        path: Path::build(&spec).expect("a line"),
        path_accel_mm_s2: 1_000.0,
        accepted: Vec::new(),
        planned: std::sync::OnceLock::new(),
    });
    (0..parts)
        .map(|part| CheckedOrder {
            target: Target::Section(SectionPart {
                section: Arc::clone(&section),
                part,
                parts,
            }),
            ..order(Permit::NONE)
        })
        .collect()
}

/// A cycle's path prepared ahead while a move runs: only its first part waits for the gate;
/// that part (which leads parts chained at speed) begins only from rest, gated, with the parts
/// behind it there to be preloaded around it as for a path from rest.
#[test]
fn a_prepared_paths_first_part_alone_is_gated_and_begins_from_rest_with_its_parts_behind() {
    let t0 = Instant::now();
    let mut d = running(t0);
    let gate = Gate::new();
    let starts = (2..).zip(section_parts(3)).collect();
    d.push_order(starts, Some(gate.clone()), Some(0), t0);
    let gated: Vec<bool> = d.queue().iter().map(|q| q.gate.is_some()).collect();
    assert_eq!(gated, [true, false, false]);
    assert!(d.queue().iter().all(|q| q.epoch == Some(0)));
    // Move 1 runs: its parts cannot be preloaded in both banks yet.
    let now = t0 + Duration::from_millis(40);
    assert!(!d.has_room(now));
    // Move 1 ends: the first part's turn comes, gated, from rest.
    d.machine.on_status(
        &status(State::Done, 8, 4, TO),
        t0 + Duration::from_millis(1_100),
    );
    let now = t0 + Duration::from_millis(1_110);
    assert!(d.has_room(now));
    let head = d.queue.pop_front().expect("the first part");
    let TurnDecision::Begin(turn) = d.turn(head, now) else {
        panic!("at rest: it begins");
    };
    assert!(
        matches!(&turn.mode, StartMode::Gated { ahead: None, .. }),
        "{:?}",
        turn.mode
    );
    assert_eq!(turn.from, TO, "from the counts the PLC reports");
    let (_, behind) = d.section_behind().expect("its parts behind it");
    assert_eq!(behind.iter().map(|(id, _)| *id).collect::<Vec<_>>(), [3, 4]);
}

/// The gate of a prepared path shut before its first part's turn: every part of it ends, the
/// first cancelled before its start (the cycle runs it afresh), the rest behind it.
#[test]
fn a_shut_gate_ends_every_part_of_a_prepared_path() {
    let t0 = Instant::now();
    let mut d = running(t0);
    let gate = Gate::new();
    d.push_order(
        (2..).zip(section_parts(3)).collect(),
        Some(gate.clone()),
        None,
        t0,
    );
    gate.shut();
    let ends = d.drop_shut();
    assert_eq!(
        ids(&ends),
        [
            (2, Stage::Cancelled),
            (3, Stage::Cancelled),
            (4, Stage::Cancelled)
        ]
    );
    assert_eq!(ends[0].end, Some(EndReason::CancelledBeforeStart));
    assert!(ends[1..].iter().all(|e| e.end.is_none()));
    assert!(d.queue().is_empty());
}

#[test]
fn a_move_in_place_with_nothing_running_is_done_at_once() {
    let mut d = idle(Instant::now());
    let at = [100, 200, 300, 401];
    let done = d.in_place(5, FROM, at, None).expect("nothing to wait for");
    assert_eq!((done.id, done.stage), (5, Stage::Done));
    assert_eq!(done.final_error, Some([0, 0, 0, -1]));
}

#[test]
fn a_follower_ends_done_only_with_its_lead_done_at_its_targets() {
    let mut d = running(Instant::now());
    assert!(
        d.in_place(2, TO, TO, Some(1)).is_none(),
        "it waits for move 1"
    );
    assert!(d.in_place(3, TO, TO, Some(1)).is_none());
    let followers = d.finished(1);
    assert_eq!(followers.len(), 2);
    assert!(d.finished(1).is_empty(), "the record went with its end");

    let lead = TO.map(i64::from);
    let reached = lead.map(|c| c + 1);
    let ends = follower_ends(
        1,
        &followers,
        Stage::Done,
        None,
        Some((Some(reached), lead)),
    );
    assert_eq!(ids(&ends), [(2, Stage::Done), (3, Stage::Done)]);
    assert_eq!(ends[0].final_error, Some([1; CHANNELS]));

    let ends = follower_ends(
        1,
        &followers,
        Stage::Stopped,
        Some("held"),
        Some((Some(reached), lead)),
    );
    assert_eq!(ids(&ends), [(2, Stage::Cancelled), (3, Stage::Cancelled)]);
    assert_eq!(
        ends[0].error.as_deref(),
        Some(
            "cancelled: it had no motion of its own and was to end with move 1, which ended \
             stopped (held)"
        )
    );

    // A lead done elsewhere than the follower's targets: not done.
    let elsewhere = lead.map(|c| c + 50);
    let ends = follower_ends(
        1,
        &followers,
        Stage::Done,
        None,
        Some((Some(reached), elsewhere)),
    );
    assert_eq!(ids(&ends)[0], (2, Stage::Cancelled));

    // A lead whose end was learnt from the start the PLC took behind it (no counts read at
    // it): done, with no final error claimed.
    let ends = follower_ends(1, &followers, Stage::Done, None, Some((None, lead)));
    assert_eq!(ids(&ends), [(2, Stage::Done), (3, Stage::Done)]);
    assert_eq!(ends[0].final_error, None);
}

#[test]
fn only_the_last_start_written_is_written_again() {
    let mut d = running(Instant::now());
    let bank = |words| VerifiedBank {
        block: CommandBlock::default(),
        words,
        on_preload: false,
    };
    d.start_written(1, Permit::NONE, bank(10));
    assert_eq!(d.start_of(1).map(|b| b.words), Some(10));
    d.start_written(2, Permit::NONE, bank(20));
    assert!(d.start_of(1).is_none());
    assert_eq!(d.start_of(2).map(|b| b.words), Some(20));
    d.forget_starts();
    assert!(d.start_of(2).is_none());
}

#[test]
fn a_stopped_move_settles_on_a_later_block_with_its_channels_still() {
    let t0 = Instant::now();
    let mut d = running(t0);
    let permit = Permit::of(&[PermitBit {
        word: 0,
        bit: 1,
        on: true,
    }])
    .expect("one bit");
    d.start_written(
        1,
        permit,
        VerifiedBank {
            block: CommandBlock::default(),
            words: 1,
            on_preload: false,
        },
    );
    assert_eq!(d.permit(1), Some(&permit));
    d.settling(1, Stage::Stopped, "held".into(), 9, t0);
    assert!(d.any_settling());
    let mask = 0b1111;
    let same_block = status(State::Fault, 8, 9, TO);
    assert!(d.settled(Some(&same_block), mask, t0).is_empty());
    let busy = StatusBlock {
        busy: 0b0001,
        ..status(State::Fault, 8, 10, TO).block
    };
    let busy = Status {
        block: busy,
        ..same_block
    };
    assert!(
        d.settled(Some(&busy), mask, t0).is_empty(),
        "a channel still moves"
    );
    assert!(d.settled_late(t0 + SETTLE_LIMIT).is_empty());
    let late = d.settled_late(t0 + SETTLE_LIMIT + Duration::from_millis(1));
    assert_eq!(
        late,
        [Settled {
            id: 1,
            stage: Stage::Stopped,
            why: "held".into()
        }]
    );
    assert!(!d.any_settling());
}

#[test]
fn a_start_never_takes_the_seq_the_plc_latched() {
    let t0 = Instant::now();
    let mut d = idle(t0);
    // The PLC latched 7; the next in turn is 1.
    assert_eq!(d.next_seq(), 1);
    d.spent(6, 0);
    assert_eq!(d.next_seq(), 8, "7 is latched: skipped");
    assert_eq!(d.next_bank(None), 1);
    d.spent(u16::MAX, 1);
    assert_eq!(d.next_seq(), 1, "0 is never a seq");
    assert_eq!(d.next_bank(None), 0);
}

#[test]
fn a_move_stopped_soon_after_a_stop_was_stopped_by_request() {
    let t0 = Instant::now();
    let mut d = idle(t0);
    assert!(!d.stopped_by_request(t0));
    d.stop_asked(t0);
    assert!(d.stopped_by_request(t0 + Duration::from_millis(1_999)));
    assert!(!d.stopped_by_request(t0 + STOP_ASKED_WINDOW));
}

#[test]
fn a_held_bank_starts_from_rest_once_its_gate_opens_and_anything_else_cancels_it() {
    assert_eq!(Hold::on_gate(GateState::Closed, false), Hold::Wait);
    assert_eq!(
        Hold::on_gate(GateState::Open, true),
        Hold::Wait,
        "never chained"
    );
    assert_eq!(Hold::on_gate(GateState::Open, false), Hold::Release);
    assert_eq!(
        Hold::on_gate(GateState::Shut, true),
        Hold::Cancel(CYCLE_WENT_ON)
    );
    assert_eq!(Hold::on_requests(false, false, false), Hold::Wait);
    assert_eq!(
        Hold::on_requests(true, true, true),
        Hold::Cancel("the daemon is shutting down")
    );
    assert_eq!(
        Hold::on_requests(false, true, true),
        Hold::Cancel("a stop was asked for")
    );
    assert_eq!(
        Hold::on_requests(false, false, true),
        Hold::Cancel("a command came (home, clear-fault)")
    );
}

#[test]
fn a_stopped_move_is_named_for_what_stopped_it() {
    let stopped = |fault: Fault| Outcome::Stopped {
        fault: fault.word(),
    };
    let held = Some("held by the PLC: its permit stopped holding (x0)".to_owned());
    let cases: [(Outcome, Option<String>, bool, Stage, &str); 6] = [
        (
            stopped(Fault::StoppedFromOutside),
            held.clone(),
            true,
            Stage::Stopped,
            "stopped by the e-stop input",
        ),
        (
            stopped(Fault::PermitDropped),
            held.clone(),
            true,
            Stage::Stopped,
            "held by the PLC: its permit stopped holding (x0)",
        ),
        (
            stopped(Fault::PermitDropped),
            None,
            true,
            Stage::Stopped,
            "stopped by request",
        ),
        (
            Outcome::Stopped { fault: 0 },
            None,
            false,
            Stage::Stopped,
            "stopped by the PLC (PROG mode, or its program)",
        ),
        (
            Outcome::Dropped,
            None,
            true,
            Stage::Cancelled,
            "cancelled by a stop request",
        ),
        (Outcome::WentIdle, None, true, Stage::Failed, "start 8 "),
    ];
    for (k, (outcome, held, asked, stage, why)) in cases.into_iter().enumerate() {
        let (got_stage, got_why) = end_of(outcome, held, asked, "start 8");
        assert_eq!(got_stage, stage, "case {k}");
        assert!(got_why.starts_with(why), "case {k}: {got_why}");
    }
    assert!(moved(Outcome::WentIdle));
    assert!(!moved(Outcome::Dropped));
}

#[test]
fn a_cycles_move_asked_for_before_an_incident_is_stale() {
    let t0 = Instant::now();
    let mut q = queued(1, None, t0);
    assert_eq!(q.stale(3, Some("the PLC restarted")), None, "not a cycle's");
    q.epoch = Some(3);
    assert_eq!(q.stale(3, Some("the PLC restarted")), None);
    assert_eq!(
        q.stale(4, Some("the PLC restarted")).as_deref(),
        Some("cancelled: the PLC restarted since its cycle asked for it")
    );
}

mod next_tests;
