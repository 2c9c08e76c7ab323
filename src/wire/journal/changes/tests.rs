use super::*;
use crate::contract::State;
use crate::wire::{FaceRefusal, StepAt};

fn up(fault: Option<u16>) -> RobotState {
    let mut s = RobotState {
        name: "r".into(),
        state: Some(State::Idle),
        fault,
        ..RobotState::default()
    };
    s.link.connected = true;
    s
}

fn with_cycle(state: CycleState, done: u64) -> RobotState {
    let mut status = CycleStatus::starting("main", Some(3));
    status.state = state;
    status.done = done;
    status.last_cycle_s = (done > 0).then_some(4.5);
    if state == CycleState::Paused {
        status.reason = Some("paused by request".into());
    }
    if state == CycleState::Faulted {
        status.reason = Some("move 12 failed".into());
        status.step = Some(StepAt {
            program: "main".into(),
            step: 3,
            label: None,
            does: "move to @in-press".into(),
            called_from: vec![],
        });
    }
    RobotState {
        cycle: Some(status),
        ..up(None)
    }
}

fn run(states: &[RobotState]) -> Vec<Kind> {
    let mut follow = Follow::default();
    states.iter().flat_map(|s| follow.observe(s)).collect()
}

fn names(kinds: &[Kind]) -> Vec<&'static str> {
    kinds.iter().map(Kind::name).collect()
}

#[test]
fn a_fault_is_journaled_with_its_meaning_and_its_clearing() {
    let got = run(&[up(None), up(Some(3)), up(Some(3)), up(None)]);
    assert_eq!(
        got,
        vec![
            Kind::Fault {
                code: Some(3),
                reason: "stopped from outside (e-stop input)".into()
            },
            Kind::FaultCleared { code: 3 },
        ]
    );
}

#[test]
fn a_fault_is_not_cleared_by_the_link_going_down_and_up() {
    let mut down = up(None);
    down.link.connected = false;
    down.link.error = Some("timeout".into());
    let got = run(&[up(Some(7)), down.clone(), up(Some(7))]);
    assert_eq!(
        names(&got),
        vec!["fault", "link-lost", "link-restored"],
        "{got:?}"
    );
    assert_eq!(
        got[1],
        Kind::LinkLost {
            error: Some("timeout".into())
        }
    );
}

#[test]
fn a_run_of_three_cycles_journals_each_start_and_end() {
    let got = run(&[
        up(None),
        with_cycle(CycleState::Running, 0),
        with_cycle(CycleState::Waiting, 0),
        with_cycle(CycleState::Running, 1),
        // Two cycles ended between two looks: both are journaled.
        with_cycle(CycleState::Done, 3),
    ]);
    assert_eq!(
        names(&got).join(" "),
        "cycle-started cycle-ended cycle-started cycle-ended cycle-started cycle-ended"
    );
    assert_eq!(
        got[5],
        Kind::CycleEnded {
            program: "main".into(),
            cycle: 3,
            outcome: CycleOutcome::Done,
            cycle_s: Some(4.5)
        }
    );
    assert_eq!(
        got[1],
        Kind::CycleEnded {
            program: "main".into(),
            cycle: 1,
            outcome: CycleOutcome::Done,
            cycle_s: Some(4.5)
        }
    );
}

#[test]
fn hold_resume_fault_and_stop_of_a_cycle() {
    use CycleState::{Faulted, Paused, Running, Stopped};
    // The same stopped status twice (nothing new the second time), then a new run after it.
    let states = [Running, Paused, Running, Faulted, Stopped, Stopped, Running];
    let got = run(&states.map(|state| with_cycle(state, 0)));
    assert_eq!(
        names(&got).join(" "),
        "cycle-started hold resume fault cycle-ended cycle-started"
    );
    assert_eq!(
        got[1],
        Kind::Hold {
            reason: Some("paused by request".into())
        }
    );
    assert_eq!(
        got[3],
        Kind::Fault {
            code: None,
            reason: "cycle main step 3 (move to @in-press): move 12 failed".into()
        }
    );
    assert!(matches!(
        got[4],
        Kind::CycleEnded {
            cycle: 1,
            outcome: CycleOutcome::Stopped,
            ..
        }
    ));
}

#[test]
fn a_mode_change_is_journaled_but_not_the_first_mode_seen() {
    let remote = RobotState {
        mode: Mode::Remote,
        ..up(None)
    };
    assert_eq!(
        run(&[remote.clone(), up(None), remote]),
        vec![
            Kind::ModeChanged { mode: Mode::Local },
            Kind::ModeChanged { mode: Mode::Remote }
        ]
    );
}

#[test]
fn the_face_s_rising_edges_are_commands_from_the_face() {
    let face = |commands, refused: Option<u16>| RobotState {
        face: Some(FaceState {
            program: 3,
            program_name: Some("press".into()),
            enabled: true,
            commands,
            refused: refused.map(|code| FaceRefusal {
                code,
                meaning: "not remote".into(),
            }),
        }),
        ..up(None)
    };
    let got = run(&[
        face(bit::ENABLE, None),
        face(bit::ENABLE | bit::STROBE | bit::START, None),
        face(bit::ENABLE | bit::STROBE | bit::START, None),
        face(bit::STOP, Some(2)),
    ]);
    let actions: Vec<(String, Option<String>)> = got
        .iter()
        .map(|k| match k {
            Kind::Command {
                source: Source::Face,
                action,
                refused,
                ..
            } => (action.clone(), refused.clone()),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        actions,
        vec![
            ("select program 3 (press)".into(), None),
            ("start program 3 (press)".into(), None),
            ("stop".into(), None),
            ("enable off".into(), Some("not remote (2)".into())),
        ]
    );
}

#[test]
fn changes_between_two_states_is_the_follower_s_second_look() {
    assert_eq!(
        changes(&up(None), &up(Some(9))),
        vec![Kind::Fault {
            code: Some(9),
            reason: "permit dropped while moving".into()
        }]
    );
    assert!(changes(&up(None), &up(None)).is_empty());
}
