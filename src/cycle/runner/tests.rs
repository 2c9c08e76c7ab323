//! The runner without a PLC, a mock or a runtime: each test feeds it what came of its actions
//! and reads the actions it returns, named in words.

use std::time::Instant;

use super::*;
use crate::cycle::tests::{EJECT, PALLETISE, PRESS_LOAD, SLIP, checked};

/// What the runner sees: the control, the incidents, the time.
struct World {
    control: Control,
    incidents: u64,
    last_incident: Option<String>,
    restarts: u64,
    now: Instant,
}

impl World {
    fn new() -> Self {
        Self {
            control: Control::default(),
            incidents: 0,
            last_incident: None,
            restarts: 0,
            now: Instant::now(),
        }
    }

    fn seen(&self) -> Seen {
        Seen {
            control: self.control,
            incidents: self.incidents,
            last_incident: self.last_incident.clone(),
            restarts: self.restarts,
            now: self.now,
        }
    }

    fn incident(&mut self, why: &str) {
        self.incidents += 1;
        self.last_incident = Some(why.to_owned());
    }
}

/// A runner of `program` (with `others` to call), `count` times, and the world it sees.
fn runner(program: &str, others: &[(&str, &str)], count: Option<u64>) -> (Runner<u32>, World) {
    let mut programs = vec![("p", program)];
    programs.extend_from_slice(others);
    let checked = checked(&programs, "p", false).unwrap();
    let world = World::new();
    (Runner::new(checked, count, &world.seen()), world)
}

/// An action, in words.
fn said(action: &Action<u32>) -> String {
    let gates = |p: &[Prepared<u32>]| p.iter().map(|p| p.gate).collect::<Vec<_>>();
    match action {
        Action::Step(at) => format!("step {}", at.does),
        Action::Submit(Motion::Move(..)) => "submit move".to_owned(),
        Action::Submit(Motion::Path(..)) => "submit path".to_owned(),
        Action::Submit(Motion::Pallet { pallet, leg, .. }) => format!("submit {pallet} {leg:?}"),
        Action::Pallet { pallet, act } => format!("pallet {pallet} {act:?}"),
        Action::Prepare { at, .. } => format!("prepare op {at}"),
        Action::Release(gate) => format!("release {gate}"),
        Action::Follow(ids) => format!("follow {ids:?}"),
        Action::Unprepare(p) => format!("unprepare {:?}", gates(p)),
        Action::Wait { until, .. } => format!("wait {until}"),
        Action::Write(w) => format!("write {}", w.len()),
        Action::Dwell(d) => format!("dwell {d:?}"),
        Action::Decide(until) => format!("decide {until}"),
        Action::Pace => "pace".to_owned(),
        Action::CycleDone { done, .. } => format!("cycle {done} done"),
        Action::Pause { why, unprepare } => format!("pause ({why}) {:?}", gates(unprepare)),
        Action::Fault {
            why,
            stop_robot,
            unprepare,
            ..
        } => format!("fault ({why}) stop {stop_robot} {:?}", gates(unprepare)),
        Action::Stand => "stand".to_owned(),
        Action::End {
            state,
            why,
            unprepare,
        } => format!("end {state:?} ({why:?}) {:?}", gates(unprepare)),
    }
}

/// Feeds `event`: the action it brings, in words.
fn feed(r: &mut Runner<u32>, w: &World, event: Event<u32>) -> String {
    said(&r.on(event, &w.seen()))
}

/// Feeds each event in turn: the actions, in words.
fn script(r: &mut Runner<u32>, w: &World, events: Vec<Event<u32>>) -> Vec<String> {
    events.into_iter().map(|e| feed(r, w, e)).collect()
}

fn prepared(id: MoveId, gate: u32) -> Event<u32> {
    Event::Prepared(Some(Prepared {
        ids: vec![id],
        moves: true,
        gate,
    }))
}

/// The press-loading program's first move submitted and the one after its waits prepared,
/// then `then`.
fn first_move(then: impl IntoIterator<Item = Event<u32>>) -> Vec<Event<u32>> {
    let mut events = vec![
        Event::Go,
        Event::Go,
        Event::Queued(vec![1]),
        prepared(2, 20),
    ];
    events.extend(then);
    events
}

/// [`first_move`] on through its end and the first wait (met after 0.5 s), then `then`.
fn through_the_waits(then: impl IntoIterator<Item = Event<u32>>) -> Vec<Event<u32>> {
    let waits = [
        Event::Followed(MotionEnd::Done),
        Event::Go,
        met(0.5),
        Event::Go,
    ];
    first_move(waits.into_iter().chain(then))
}

/// The palletising program to its place step: the pick done, the slip sheet skipped (not the
/// first slot of a layer), the place begun; then `then`.
fn to_the_place(then: impl IntoIterator<Item = Event<u32>>) -> Vec<Event<u32>> {
    let mut events = vec![
        Event::Go,
        Event::Go,
        Event::Queued(vec![1]),
        Event::Followed(MotionEnd::Done),
        Event::Go,
        Event::Decided(Some(false)),
        Event::Go,
    ];
    events.extend(then);
    events
}

fn met(waited_s: f64) -> Event<u32> {
    Event::Waited {
        end: WaitEnd::Met,
        waited_s,
    }
}

const DWELLS: &str = r#"
[[step]]
label = "a"
dwell = "1s"
[[step]]
loop = { to = "a", count = 3 }
"#;

#[test]
fn a_counted_loop_runs_its_steps_that_often_and_the_run_ends_after_its_cycles() {
    let (mut r, w) = runner(DWELLS, &[], Some(2));
    let mut actions = Vec::new();
    let mut event = Event::Go;
    while !r.ended() {
        let action = r.on(event, &w.seen());
        event = match &action {
            Action::Dwell(_) => Event::Dwelt(true),
            _ => Event::Go,
        };
        actions.push(said(&action));
    }
    let dwells = actions.iter().filter(|a| a.starts_with("dwell")).count();
    assert_eq!(dwells, 6, "{actions:#?}");
    let done: Vec<&String> = actions.iter().filter(|a| a.contains("done")).collect();
    assert_eq!(done, ["cycle 1 done", "cycle 2 done"]);
    assert_eq!(actions.last().unwrap(), "end Done (None) []");
}

#[test]
fn a_loop_whose_steps_take_no_time_goes_round_at_the_pace_of_the_reads() {
    let program = "[[step]]\nlabel = \"a\"\nset = { press_go = true }\n[[step]]\nloop = { to = \"a\", until = \"stop\" }\n";
    let (mut r, w) = runner(program, &[], None);
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Go,
            Event::Go,
            Event::Written(None),
            Event::Go,
            Event::Paced(true),
        ],
    );
    assert_eq!(
        got,
        [
            "step set press_go = true",
            "write 1",
            "step loop to a until stopped",
            "pace",
            "step set press_go = true",
        ]
    );
    // The robot's worker gone: the cycle ends.
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Go,
            Event::Written(None),
            Event::Go,
            Event::Paced(false),
        ],
    );
    assert_eq!(got[3], "end Stopped (Some(\"stopped now by request\")) []");
}

#[test]
fn a_loop_until_a_condition_is_decided_on_the_inputs() {
    let program = "[[step]]\nlabel = \"a\"\ndwell = \"1s\"\n[[step]]\nloop = { to = \"a\", until = \"part_present\" }\n[[step]]\ndwell = \"2s\"\n";
    let (mut r, w) = runner(program, &[], Some(1));
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Go,
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
            Event::Decided(Some(false)),
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
            Event::Decided(Some(true)),
            Event::Go,
        ],
    );
    assert_eq!(
        got,
        [
            "step dwell 1s",
            "dwell 1s",
            "step loop to a until part_present (X2)",
            "decide part_present (X2)",
            // Back without a pace: the dwell takes time.
            "step dwell 1s",
            "dwell 1s",
            "step loop to a until part_present (X2)",
            "decide part_present (X2)",
            "step dwell 2s",
            "dwell 2s",
        ]
    );
}

#[test]
fn a_call_runs_the_called_programs_steps_where_it_stands() {
    let program =
        "[[step]]\ndwell = \"1s\"\n[[step]]\ncall = \"eject\"\n[[step]]\ndwell = \"2s\"\n";
    let (mut r, w) = runner(program, &[("eject", EJECT)], Some(1));
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Go,
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
            Event::Queued(vec![1]),
            Event::Followed(MotionEnd::Done),
            Event::Go,
            Event::Written(None),
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
        ],
    );
    assert_eq!(
        got,
        [
            "step dwell 1s",
            "dwell 1s",
            "step move by [0.0, 0.0, 50.0]",
            "submit move",
            // A move by an offset is never prepared ahead; nothing to prepare after it.
            "follow [1]",
            "step set press_go = false",
            "write 1",
            "step dwell 2s",
            "dwell 2s",
            "cycle 1 done",
            "end Done (None) []",
        ]
    );
}

/// The press-loading program to its second cycle, each move after the first prepared ahead.
#[test]
fn the_next_move_is_prepared_ahead_and_released_at_its_step() {
    let (mut r, w) = runner(PRESS_LOAD, &[("eject", EJECT)], None);
    let got = script(
        &mut r,
        &w,
        through_the_waits([
            met(0.25),
            Event::Go,
            Event::Go,
            Event::Followed(MotionEnd::Done),
        ]),
    );
    assert_eq!(
        got,
        [
            "step move to @above-stack",
            "submit move",
            // While the first runs, the one after the waits is uploaded and held.
            "prepare op 3",
            "follow [1]",
            "step wait for part_present (X2)",
            // One that moves is ahead already: nothing more is prepared.
            "wait part_present (X2)",
            "step wait for press_open (X5) & !press_moving (X6)",
            "wait press_open (X5) & !press_moving (X6)",
            "step move to @in-press (permit press_open & !press_moving)",
            "release 20",
            // The move after it is by an offset: not prepared.
            "follow [2]",
            "step set DT100 = 7, press_go = true",
        ]
    );
}

#[test]
fn a_moves_permit_goes_out_as_it_was_resolved_when_the_program_was_checked() {
    use crate::contract::{Permit, PermitBit};
    let (mut r, w) = runner(PRESS_LOAD, &[("eject", EJECT)], None);
    feed(&mut r, &w, Event::Go);
    let Action::Submit(Motion::Move(_, permit)) = r.on(Event::Go, &w.seen()) else {
        panic!("the first move is submitted");
    };
    assert_eq!(permit, Permit::NONE, "a move with no permit");
    let Action::Prepare {
        at,
        motion: Motion::Move(_, permit),
    } = r.on(Event::Queued(vec![1]), &w.seen())
    else {
        panic!("the move after the waits is prepared");
    };
    // press_open & !press_moving: X5 on, X6 off, in the first input word.
    let want = Permit::of(&[
        PermitBit {
            word: 0,
            bit: 5,
            on: true,
        },
        PermitBit {
            word: 0,
            bit: 6,
            on: false,
        },
    ])
    .expect("two bits");
    assert_eq!((at, permit), (3, want));
}

#[test]
fn a_prepared_move_cancelled_before_its_start_runs_afresh_at_its_step() {
    let (mut r, w) = runner(PRESS_LOAD, &[("eject", EJECT)], None);
    script(&mut r, &w, through_the_waits([met(0.25), Event::Go]));
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Go,
            Event::Followed(MotionEnd::NotStarted),
            Event::Go,
            Event::Queued(vec![3]),
        ],
    );
    assert_eq!(
        got,
        [
            "follow [2]",
            "step move to @in-press (permit press_open & !press_moving)",
            "submit move",
            "follow [3]",
        ]
    );
    assert_eq!(r.pc(), 3);
}

#[test]
fn a_wait_that_times_out_jumps_to_its_label_or_faults() {
    let (mut r, w) = runner(PRESS_LOAD, &[("eject", EJECT)], None);
    script(&mut r, &w, through_the_waits([]));
    let timed_out = |waited_s| Event::Waited {
        end: WaitEnd::TimedOut,
        waited_s,
    };
    // The press wait's on_timeout is "pick": back to the first step, the held move dropped.
    let got = script(&mut r, &w, vec![timed_out(60.0), Event::Go, Event::Go]);
    assert_eq!(
        got,
        ["unprepare [20]", "step move to @above-stack", "submit move"]
    );
    // The part wait has no on_timeout: the cycle faults, naming it.
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Queued(vec![3]),
            prepared(4, 21),
            Event::Followed(MotionEnd::Done),
            Event::Go,
            timed_out(30.0),
        ],
    );
    assert_eq!(
        got[4],
        "fault (wait for part_present (X2) timed out after 30.0 s) stop true [21]"
    );
}

#[test]
fn a_pause_takes_effect_at_the_steps_end_and_a_resume_goes_on_there() {
    let (mut r, mut w) = runner(DWELLS, &[], None);
    script(&mut r, &w, vec![Event::Go, Event::Go]);
    w.control.pause_asked();
    let got = script(&mut r, &w, vec![Event::Dwelt(true), Event::Changed]);
    assert_eq!(got, ["pause (paused by request) []", "stand"]);
    w.control.resume(None);
    let got = script(&mut r, &w, vec![Event::Changed, Event::Go]);
    assert_eq!(got, ["step loop to a (3 times in all)", "step dwell 1s"]);
}

#[test]
fn a_hold_pauses_a_move_to_a_pose_and_faults_one_by_an_offset() {
    let held = || {
        Event::Followed(MotionEnd::Held {
            why: "held by the PLC: X5 is off".to_owned(),
        })
    };
    let (mut r, w) = runner(PRESS_LOAD, &[("eject", EJECT)], None);
    let got = script(&mut r, &w, first_move([held()]));
    assert_eq!(got[4], "pause (held by the PLC: X5 is off) [20]");
    let program = "[[step]]\nmove = { by = [0, 0, 5] }\n";
    let (mut r, w) = runner(program, &[], None);
    let got = script(
        &mut r,
        &w,
        vec![Event::Go, Event::Go, Event::Queued(vec![1]), held()],
    );
    assert!(
        got[3]
            .starts_with("fault (held by the PLC: X5 is off; a move `by` an offset is not resumed"),
        "{got:?}"
    );
}

#[test]
fn a_stop_ends_the_cycle_at_the_steps_end_with_the_prepared_moves_unprepared() {
    let (mut r, mut w) = runner(PRESS_LOAD, &[("eject", EJECT)], None);
    script(&mut r, &w, first_move([]));
    w.control.stop(false);
    let got = feed(&mut r, &w, Event::Followed(MotionEnd::Done));
    assert_eq!(got, "end Stopped (Some(\"stopped by request\")) [20]");
    assert!(r.ended());
}

/// Each kind of step, begun: what an incident during it does.
#[test]
fn an_incident_at_every_kind_of_step_faults_the_cycle_and_only_a_resume_goes_on() {
    let program = r#"
[[step]]
move = { position = "above-stack" }
[[step]]
path = { path = { element = [{ line = [-900, 500, 150] }] } }
[[step]]
wait = "part_present"
[[step]]
set = { press_go = true }
[[step]]
dwell = "1s"
[[step]]
label = "l"
loop = { to = "l", until = "part_present" }
"#;
    for op in 0..6 {
        let (mut r, mut w) = runner(program, &[], None);
        let seen_op = |r: &mut Runner<u32>, w: &World| {
            let mut got = feed(r, w, Event::Go);
            // Through the ops before `op`, each answered as done.
            while r.pc() < op || got.starts_with("step") {
                let event = match got.as_str() {
                    g if g.starts_with("submit") => Event::Queued(vec![1]),
                    g if g.starts_with("follow") => Event::Followed(MotionEnd::Done),
                    g if g.starts_with("wait") => met(0.0),
                    g if g.starts_with("write") => Event::Written(None),
                    g if g.starts_with("dwell") => Event::Dwelt(true),
                    g if g.starts_with("prepare") => Event::Prepared(None),
                    _ => Event::Go,
                };
                got = feed(r, w, event);
            }
            got
        };
        let doing = seen_op(&mut r, &w);
        assert!(!doing.starts_with("step"), "{doing}");
        w.incident("the PLC restarted");
        let got = feed(&mut r, &w, Event::Incident("the PLC restarted".to_owned()));
        assert_eq!(
            got, "fault (the PLC restarted) stop true []",
            "op {op}: {doing}"
        );
        assert_eq!(r.incident_mark(), 1);
        // Standing: a second incident names itself without stopping the robot again.
        assert_eq!(feed(&mut r, &w, Event::Changed), "stand");
        w.incident("the link was lost past a move's end");
        let got = feed(&mut r, &w, Event::Incident("the link was lost".to_owned()));
        assert_eq!(got, "fault (the link was lost) stop false []");
        // A resume after the clear at incident 2: that op again, acting under it.
        w.control.resume(Some(2));
        let got = feed(&mut r, &w, Event::Changed);
        assert!(got.starts_with("step"), "op {op}: {got}");
        assert_eq!((r.pc(), r.epoch()), (op, 2));
    }
}

#[test]
fn an_incident_seen_at_the_top_faults_and_a_stop_while_standing_ends_it() {
    let (mut r, mut w) = runner(DWELLS, &[], None);
    w.incident("the PLC stalls");
    assert_eq!(
        feed(&mut r, &w, Event::Go),
        "fault (the PLC stalls) stop true []"
    );
    // A resume without a clear keeps the epoch: the same incident faults it again.
    w.control.resume(None);
    assert_eq!(
        feed(&mut r, &w, Event::Changed),
        "fault (the PLC stalls) stop true []"
    );
    w.control.stop(true);
    assert_eq!(
        feed(&mut r, &w, Event::Changed),
        "end Stopped (Some(\"stopped by request\")) []"
    );
}

/// Whether a fault makes the pallets' slots in progress unsure: only when the PLC restarted
/// since the cycle began or last faulted (a place under way may have been cut short), not for
/// an incident of another kind, nor twice for one restart.
#[test]
fn a_fault_after_a_restart_of_the_plc_makes_the_slots_in_progress_unsure_once() {
    let interrupted = |action: Action<u32>| match action {
        Action::Fault { interrupted, .. } => interrupted,
        other => panic!("not a fault: {}", said(&other)),
    };
    // A restart before the cycle began is not one under it.
    let mut w = World::new();
    w.incident("the PLC restarted");
    w.restarts = 1;
    let checked = checked(&[("p", DWELLS)], "p", false).unwrap();
    let mut r = Runner::<u32>::new(checked, None, &w.seen());
    assert_eq!(feed(&mut r, &w, Event::Go), "step dwell 1s");
    assert_eq!(feed(&mut r, &w, Event::Go), "dwell 1s");
    w.incident("the PLC stalls");
    assert!(!interrupted(
        r.on(Event::Incident("stall".to_owned()), &w.seen())
    ));
    // Standing: a restart now is one under the cycle, named once.
    assert_eq!(feed(&mut r, &w, Event::Changed), "stand");
    w.incident("the PLC restarted");
    w.restarts = 2;
    let restart = || Event::Incident("the PLC restarted".to_owned());
    assert!(interrupted(r.on(restart(), &w.seen())));
    w.incident("the link was lost");
    assert!(!interrupted(r.on(restart(), &w.seen())));
    // Resumed after a clear; a restart mid-dwell faults with the slots made unsure.
    w.control.resume(Some(w.incidents));
    assert_eq!(feed(&mut r, &w, Event::Changed), "step dwell 1s");
    assert_eq!(feed(&mut r, &w, Event::Go), "dwell 1s");
    w.incident("the PLC restarted");
    w.restarts = 3;
    assert!(interrupted(r.on(restart(), &w.seen())));
}

#[test]
fn a_stop_now_during_a_dwell_ends_the_cycle_now() {
    let (mut r, w) = runner(DWELLS, &[], None);
    let got = script(&mut r, &w, vec![Event::Go, Event::Go, Event::Dwelt(false)]);
    assert_eq!(got[2], "end Stopped (Some(\"stopped now by request\")) []");
}

/// A place as the runner steps it: the between-layers skip decided, the counter's changes
/// answered, the legs followed; a counter that refuses (a slot unsure after a restart) faults
/// the cycle on the place step before anything moves.
#[test]
fn a_place_runs_its_counter_changes_and_legs_in_order_and_a_refused_begin_faults() {
    let (mut r, w) = runner(PALLETISE, &[("slip", SLIP)], None);
    let got = script(
        &mut r,
        &w,
        to_the_place([
            Event::Counted(None),
            Event::Go,
            Event::Queued(vec![2]),
            Event::Followed(MotionEnd::Done),
            Event::Go,
            Event::Counted(None),
            Event::Go,
            Event::Written(None),
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
            Event::Counted(None),
            Event::Go,
            Event::Queued(vec![3]),
            Event::Followed(MotionEnd::Done),
            Event::Go,
            // Not full: the when-full block is skipped.
            Event::Decided(Some(false)),
            Event::Go,
        ]),
    );
    let want = [
        "step move to @above-stack",
        "submit move",
        "follow [1]",
        "step unless pallet.out begins a layer: skip",
        "decide pallet.out begins a layer",
        "step place on out: next slot in progress",
        "pallet out Begin",
        "step place on out: approach",
        "submit out In",
        "follow [2]",
        "step place on out: at the slot",
        "pallet out Arrived",
        "step set Y1 = false",
        "write 1",
        "step dwell 150ms",
        "dwell 150ms",
        "step place on out: slot done",
        "pallet out SlotDone",
        "step place on out: retreat",
        "submit out Out",
        "follow [3]",
        "step unless pallet.out.full: skip",
        "decide pallet.out.full",
        "step loop to pick until pallet.out.index == 0",
        "decide pallet.out.index == 0",
    ];
    assert_eq!(got, want);
    let (mut r, w) = runner(PALLETISE, &[("slip", SLIP)], None);
    let why = "pallet \"out\": the place at slot 3 was interrupted";
    let got = script(
        &mut r,
        &w,
        to_the_place([Event::Counted(Some(why.to_owned()))]),
    );
    assert_eq!(got.last().unwrap(), &format!("fault ({why}) stop true []"));
}

/// A pick and place as blended runs: the gripper's dwell, up from the pick, across and down
/// to the place (one path op), the gripper's dwell, up, across and down to the pick (another).
const BLENDED: &str = r#"
[[step]]
dwell = "100ms"
[[step]]
move = { position = "above-stack" }
blend_mm = 20
[[step]]
move = { to = [-1144.43, 659.6, 286.6] }
blend_mm = 20
[[step]]
move = { position = "in-press" }
[[step]]
dwell = "100ms"
[[step]]
move = { to = [-1144.43, 659.6, 286.6] }
blend_mm = 20
[[step]]
move = { position = "above-stack" }
blend_mm = 20
[[step]]
move = { to = [-926.57, 535.03, 50.0] }
"#;

/// A path of `ids` prepared behind `gate`.
fn prepared_path(ids: &[MoveId], gate: u32) -> Event<u32> {
    Event::Prepared(Some(Prepared {
        ids: ids.to_vec(),
        moves: true,
        gate,
    }))
}

/// [`BLENDED`] to its first path running: the dwell before it, nothing to prepare behind the
/// path that is uploaded during that dwell, the path queued as its three starts, and the path
/// after the second dwell prepared behind it as starts 4 to 6; then `then`.
fn first_path(then: impl IntoIterator<Item = Event<u32>>) -> Vec<Event<u32>> {
    let mut events = vec![
        Event::Go,
        Event::Go,
        prepared_path(&[1, 2, 3], 20),
        Event::Dwelt(true),
        Event::Go,
        Event::Go,
        prepared_path(&[4, 5, 6], 21),
    ];
    events.extend(then);
    events
}

#[test]
fn a_path_after_a_dwell_is_prepared_during_the_dwell_and_released_at_its_step() {
    let (mut r, w) = runner(BLENDED, &[], None);
    let got = script(
        &mut r,
        &w,
        first_path([
            Event::Followed(MotionEnd::Done),
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
            Event::Go,
            prepared_path(&[7, 8, 9], 22),
        ]),
    );
    let first = "step blended moves, steps 2 to 4: move to @above-stack (blend 20 mm), move to \
                 [-1144.43, 659.6, 286.6] (blend 20 mm), move to @in-press";
    let second = "step blended moves, steps 6 to 8: move to [-1144.43, 659.6, 286.6] (blend 20 \
                  mm), move to @above-stack (blend 20 mm), move to [-926.57, 535.03, 50.0]";
    assert_eq!(
        got,
        [
            "step dwell 100ms",
            // Nothing runs: the path after the dwell is uploaded during it.
            "prepare op 1",
            "dwell 100ms",
            first,
            "release 20",
            // The path after the next dwell is prepared behind it, from where it ends.
            "prepare op 3",
            "follow [1, 2, 3]",
            "step dwell 100ms",
            // Prepared already: the dwell begins at once.
            "dwell 100ms",
            second,
            "release 21",
            // Round to the next cycle: its first path, after its dwell, behind this one.
            "prepare op 1",
            "follow [4, 5, 6]",
        ]
    );
}

#[test]
fn a_prepared_path_cancelled_before_its_start_runs_afresh_at_its_step() {
    let (mut r, w) = runner(BLENDED, &[], None);
    script(&mut r, &w, first_path([Event::Followed(MotionEnd::Done)]));
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
            Event::Go,
            Event::Prepared(None),
            Event::Followed(MotionEnd::NotStarted),
            Event::Go,
            Event::Queued(vec![7, 8, 9]),
        ],
    );
    assert_eq!(
        &got[2..5],
        ["release 21", "prepare op 1", "follow [4, 5, 6]"]
    );
    // Its gate shut before it started: planned again from where the robot is, at its step.
    assert!(
        got[5].starts_with("step blended moves, steps 6 to 8"),
        "{got:?}"
    );
    assert_eq!(&got[6..], ["submit path", "prepare op 1"]);
    assert_eq!(r.pc(), 3);
}

/// A change of the control, asked for by a test.
type AskFor = fn(&mut Control);

/// Each way the cycle goes other than on to the prepared path's step takes it back: its gate
/// named in the action that ends, pauses or faults the cycle.
#[test]
fn a_fault_a_hold_a_pause_or_a_stop_unprepares_a_prepared_path() {
    let done = || Event::Followed(MotionEnd::Done);
    // An incident while the path before it runs.
    let (mut r, mut w) = runner(BLENDED, &[], None);
    script(&mut r, &w, first_path([]));
    w.incident("the PLC restarted");
    let got = feed(&mut r, &w, Event::Incident("the PLC restarted".to_owned()));
    assert_eq!(got, "fault (the PLC restarted) stop true [21]");
    // The path before it held by the PLC: a path is not resumed mid-way, the cycle faults.
    let (mut r, w) = runner(BLENDED, &[], None);
    script(&mut r, &w, first_path([]));
    let held = MotionEnd::Held {
        why: "held by the PLC: X5 is off".to_owned(),
    };
    let got = feed(&mut r, &w, Event::Followed(held));
    assert!(
        got.starts_with("fault (held by the PLC: X5 is off; a path is not resumed")
            && got.ends_with("stop true [21]"),
        "{got}"
    );
    // A pause, a hold from outside the PLC, a stop: at the end of the path before it.
    let asks: [(AskFor, &str); 3] = [
        (Control::pause_asked, "pause (paused by request) [21]"),
        (
            |c| c.hold_asked("move-enable dropped"),
            "pause (move-enable dropped) [21]",
        ),
        (
            |c| c.stop(false),
            "end Stopped (Some(\"stopped by request\")) [21]",
        ),
    ];
    for (ask, want) in asks {
        let (mut r, mut w) = runner(BLENDED, &[], None);
        script(&mut r, &w, first_path([]));
        ask(&mut w.control);
        assert_eq!(feed(&mut r, &w, done()), want);
    }
    // A hold asked during the dwell before it: at the top of the path's step.
    let (mut r, mut w) = runner(BLENDED, &[], None);
    script(&mut r, &w, first_path([done(), Event::Go]));
    w.control.hold_asked("move-enable dropped");
    let got = feed(&mut r, &w, Event::Dwelt(true));
    assert_eq!(got, "pause (move-enable dropped) [21]");
}

#[test]
fn a_path_is_prepared_only_once_the_motion_it_begins_after_is_queued() {
    // During the wait the move `by` an offset cannot be prepared (its target depends on where
    // it begins), so neither can the path after it: that one begins where the move ends.
    let program = r#"
[[step]]
wait = "part_present"
[[step]]
move = { by = [0, 0, 50] }
[[step]]
dwell = "100ms"
[[step]]
path = { path = { element = [{ line = [-900, 500, 150] }] } }
"#;
    let (mut r, w) = runner(program, &[], Some(1));
    let got = script(
        &mut r,
        &w,
        vec![
            Event::Go,
            Event::Go,
            met(0.1),
            Event::Go,
            Event::Queued(vec![1]),
            prepared_path(&[2], 20),
            Event::Followed(MotionEnd::Done),
            Event::Go,
            Event::Dwelt(true),
            Event::Go,
        ],
    );
    assert_eq!(
        got,
        [
            "step wait for part_present (X2)",
            "wait part_present (X2)",
            "step move by [0.0, 0.0, 50.0]",
            "submit move",
            // Queued: it ends where it is planned to, the path is planned from there.
            "prepare op 3",
            "follow [1]",
            "step dwell 100ms",
            "dwell 100ms",
            "step path",
            "release 20",
        ]
    );
    // A move to a pose before it: prepared during the wait, and the path only once that
    // move is released (queued for good), not while it is only held.
    let program = program.replace("{ by = [0, 0, 50] }", "{ position = \"above-stack\" }");
    let (mut r, w) = runner(&program, &[], Some(1));
    let got = script(
        &mut r,
        &w,
        vec![Event::Go, Event::Go, prepared(1, 20), met(0.1), Event::Go],
    );
    assert_eq!(
        got,
        [
            "step wait for part_present (X2)",
            "prepare op 1",
            "wait part_present (X2)",
            "step move to @above-stack",
            "release 20",
        ]
    );
    assert_eq!(feed(&mut r, &w, Event::Go), "prepare op 3");
}
