//! The check against a robot and its cell: every malformed program refused before anything
//! runs, naming the program, the step and the value; a press-loading program flattened.

use std::collections::BTreeMap;

use super::*;
use crate::contract::{InputWord, Layout};
use crate::gateway::{AccessList, Address};
use crate::order::permit::PermitNames;
use crate::robot::Position;
use crate::robot::seed_robot;

pub(super) const PRESS_LOAD: &str = r#"
number = 1
description = "load one blank into the press"
[[step]]
label = "pick"
move = { position = "above-stack" }
[[step]]
wait = "part_present"
timeout = "30s"
[[step]]
wait = "press_open & !press_moving"
timeout = "60s"
on_timeout = "pick"
[[step]]
move = { position = "in-press", speed_mm_s = 150 }
permit = "press_open & !press_moving"
[[step]]
set = { press_go = true, DT100 = 7 }
[[step]]
dwell = "200ms"
[[step]]
call = "eject"
[[step]]
loop = { to = "pick", count = 3 }
"#;

pub(super) const EJECT: &str = r"
[[step]]
move = { by = [0, 0, 50] }
[[step]]
set = { press_go = false }
";

struct Cell {
    signals: BTreeMap<String, Address>,
    access: AccessList,
    taught: BTreeMap<String, Position>,
    robot: crate::robot::Robot,
    pallets: BTreeMap<String, crate::pallet::Pattern>,
}

/// A 2 x 2-slot pallet beside the stack (2 layers), each slot entered from 100 mm above at
/// 50 mm/s; a slip sheet between layers; when full, `press_go` set until `part_present`.
/// And `far`: one slot out of the robot's reach.
fn pallets() -> BTreeMap<String, crate::pallet::Pattern> {
    use crate::geometry::Pose;
    use crate::pallet::{Pattern, Slot, Waypoint};
    let slot = |index: usize, x: f64, z: f64| {
        let up = |s| Waypoint {
            pose: Pose::from_mm_deg(x, 535.0, z + 100.0, 0.0),
            speed_mm_s: s,
            blend_mm: None,
        };
        Slot {
            index,
            layer: index / 2,
            row: 0,
            column: index % 2,
            pose: Pose::from_mm_deg(x, 535.0, z, 0.0),
            approach: vec![up(None)],
            slot_speed_mm_s: Some(50.0),
            retreat: vec![up(Some(200.0))],
        }
    };
    let mut out = Pattern::from_slots(
        "out",
        vec![
            slot(0, -926.0, 100.0),
            slot(1, -826.0, 100.0),
            slot(2, -926.0, 150.0),
            slot(3, -826.0, 150.0),
        ],
    )
    .unwrap();
    out.between_layers = Some("slip".to_owned());
    out.when_full = crate::pallet::WhenFull {
        signal: Some("press_go".to_owned()),
        wait_for: Some("part_present".to_owned()),
        call: None,
    };
    let far = Pattern::from_slots("far", vec![slot(0, -9000.0, 100.0)]).unwrap();
    [("out".to_owned(), out), ("far".to_owned(), far)]
        .into_iter()
        .collect()
}

fn cell() -> Cell {
    let signals = [
        ("press_open", "X5"),
        ("press_moving", "X6"),
        ("part_present", "X2"),
        ("press_go", "Y0"),
    ]
    .into_iter()
    .map(|(n, a)| (n.to_owned(), a.parse().unwrap()))
    .collect();
    let ranges = |l: &[&str]| l.iter().map(|r| r.parse().unwrap()).collect();
    let access = AccessList::new(
        ranges(&["DT0-DT199"]),
        ranges(&["Y0-Y7", "DT100-DT199"]),
        &Layout::default(),
    )
    .unwrap();
    let at = |pose: [f64; 4]| Position {
        pose,
        joint_counts: [0; 4],
        saved_unix_s: 0,
        frame: None,
    };
    let taught = [
        ("above-stack", at([-926.57, 535.03, 150.0, 0.0])),
        ("in-press", at([-1144.43, 659.6, 186.6, 0.0])),
    ]
    .into_iter()
    .map(|(n, p)| (n.to_owned(), p))
    .collect();
    Cell {
        signals,
        access,
        taught,
        robot: seed_robot(),
        pallets: pallets(),
    }
}

/// Why a test's program was refused: its TOML, or its check.
#[derive(Debug, thiserror::Error)]
pub(super) enum Refused {
    /// The TOML.
    #[error(transparent)]
    Toml(#[from] toml::de::Error),
    /// The check.
    #[error(transparent)]
    Program(#[from] ProgramError),
}

pub(super) fn checked(
    programs: &[(&str, &str)],
    run: &str,
    require_timeout: bool,
) -> Result<Checked, Refused> {
    checked_from(programs, run, require_timeout, None)
}

pub(super) fn checked_from(
    programs: &[(&str, &str)],
    run: &str,
    require_timeout: bool,
    start: Option<[i64; 4]>,
) -> Result<Checked, Refused> {
    let c = cell();
    let docs: BTreeMap<String, ProgramDoc> = programs
        .iter()
        .map(|(n, t)| Ok(((*n).to_owned(), ProgramDoc::from_toml(t)?)))
        .collect::<Result<_, Refused>>()?;
    let ctx = Context {
        robot: &c.robot,
        taught: &c.taught,
        names: Names {
            permit: PermitNames {
                signals: &c.signals,
                inputs: &InputWord::DEFAULTS,
            },
            access: &c.access,
        },
        programs: &docs,
        broken: &BTreeMap::new(),
        require_wait_timeout: require_timeout,
        start,
        poses_known: true,
        pallets: &c.pallets,
    };
    Ok(check(run, &ctx)?)
}

#[test]
fn a_press_loading_program_flattens_with_its_call_inlined_and_its_jumps_resolved() {
    let c = checked(
        &[("press-load", PRESS_LOAD), ("eject", EJECT)],
        "press-load",
        true,
    )
    .unwrap();
    assert_eq!(c.number, Some(1));
    let does: Vec<String> = c.ops.iter().map(|o| o.at.does.clone()).collect();
    assert_eq!(
        does,
        [
            "move to @above-stack",
            "wait for part_present (X2)",
            "wait for press_open (X5) & !press_moving (X6)",
            "move to @in-press (permit press_open & !press_moving)",
            "set DT100 = 7, press_go = true",
            "dwell 200ms",
            "move by [0.0, 0.0, 50.0]",
            "set press_go = false",
            "loop to pick (3 times in all)",
        ]
    );
    // The called program's steps say where they were called from.
    assert_eq!(c.ops[6].at.program, "eject");
    assert_eq!(c.ops[6].at.step, 1);
    assert_eq!(c.ops[6].at.called_from, ["press-load step 7"]);
    assert!(matches!(
        &c.ops[2].kind,
        OpKind::Wait {
            on_timeout: Some(0),
            ..
        }
    ));
    assert!(matches!(
        &c.ops[8].kind,
        OpKind::Loop {
            to: 0,
            exit: LoopExit::Count(3)
        }
    ));
    let OpKind::Move(order) = &c.ops[3].kind else {
        panic!()
    };
    assert_eq!(order.permit.as_deref(), Some("press_open & !press_moving"));
    // Its permit resolved once, here: it travels with the op (no parse when it runs).
    let c_names = cell();
    let names = PermitNames {
        signals: &c_names.signals,
        inputs: &InputWord::DEFAULTS,
    };
    let resolved = crate::order::permit::resolve("press_open & !press_moving", names).unwrap();
    assert_eq!(c.ops[3].permit, resolved);
    assert!(!resolved.is_none());
    assert!(c.ops[0].permit.is_none(), "a move without a permit");
}

#[test]
fn every_malformed_program_is_refused_naming_the_step_and_the_value() {
    // One-step programs: the step's keys, and words its refusal holds.
    let steps = [
        ("jump = \"pick\"", "unknown field `jump`"),
        (
            "path = { file = \"p.toml\", sped_mm_s = 3 }",
            "unknown field `sped_mm_s`, expected one of `file`, `path`, `speed_mm_s`, \
             `accel_time`, `method`, `period`, `tolerance_mm`, `profile`, `jerk_mm_s3`",
        ),
        (
            "move = { position = \"in-press\", speed_mm_s = \"fast\" }",
            "invalid type: string \"fast\", expected f64",
        ),
        (
            "wait = \"door_shut\"\ntimeout = \"1s\"",
            "step 1: wait: condition \"door_shut\": \"door_shut\" is neither a signal",
        ),
        (
            "set = { Y10 = true }",
            "step 1: set: Y10 = true: Y10 is not in this robot's gateway write list (Y0-Y7, DT100-DT199)",
        ),
        ("set = { X5 = true }", "step 1: set: X5 = true"),
        ("set = { DT100 = true }", "a DT word takes a whole number"),
        ("set = { press_go = 1 }", "a bit takes true or false"),
        (
            "wait = \"press_open\"",
            "step 1: wait = \"press_open\" has no timeout, and [robots.NAME.cell] require_wait_timeout = true",
        ),
        (
            "label = \"a\"\nloop = { to = \"a\" }",
            "step 1 (a): loop to \"a\" has no exit",
        ),
        (
            "loop = { to = \"nowhere\", count = 2 }",
            "step 1: no step is labelled \"nowhere\" in this program",
        ),
        (
            "move = { position = \"nowhere\" }",
            "step 1: move: position",
        ),
        (
            "move = { position = \"in-press\" }\npermit = \"press_open | X7\"",
            "`|` cannot be a permit",
        ),
        ("dwell = \"0s\"", "dwell = \"0s\": must be above 0 s"),
        (
            "dwell = \"1s\"\nmove = { position = \"in-press\" }",
            "has move and dwell actions",
        ),
        ("label = \"x\"", "has no action"),
        (
            "move = { position = \"in-press\", profile = \"s-curve\" }",
            "step 1: move: jerk_mm_s3 = null: profile \"s-curve\" needs the path's jerk",
        ),
        (
            "path = { path = { element = [{ line = [1, 2, 3] }] }, profile = \"trapezoid\", \
             jerk_mm_s3 = 5000 }",
            "step 1: path: jerk_mm_s3 = 5000: only profile \"s-curve\" takes a jerk",
        ),
        (
            "wait = \"press_open\"\ntimeout = \"1s\"\npermit = \"X5\"",
            "permit goes with a move or a path",
        ),
    ];
    // Whole programs.
    let programs = [
        (
            "number = 300\n[[step]]\ndwell = \"1s\"",
            "number = 300: must be 1..=255",
        ),
        ("", "has no step"),
        (
            "[[step]]\nlabel = \"a\"\ndwell = \"1s\"\n[[step]]\nlabel = \"a\"\ndwell = \"1s\"",
            "step 2 (a): label \"a\" is used by an earlier step too",
        ),
    ];
    let one = |(step, words): (&str, &'static str)| (format!("[[step]]\n{step}\n"), words);
    let whole = |(program, words): (&str, &'static str)| (program.to_owned(), words);
    let cases = steps.map(one).into_iter().chain(programs.map(whole));
    for (program, words) in cases {
        let e = checked(&[("p", &program)], "p", true)
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "{program}\n=> {e}");
        // serde's refusals (a key or a value of the wrong type) name the line, not the program.
        if !words.starts_with("unknown field") && !words.starts_with("invalid type") {
            assert!(e.contains("program \"p\""), "{e}");
        }
    }
}

#[test]
fn a_recursion_through_call_is_refused_naming_the_chain() {
    let a = "[[step]]\ncall = \"b\"\n";
    let b = "[[step]]\ndwell = \"1s\"\n[[step]]\ncall = \"a\"\n";
    let e = checked(&[("a", a), ("b", b)], "a", false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("program \"b\" step 2: call = \"a\" is a recursion: a -> b -> a"),
        "{e}"
    );
    let e = checked(&[("a", "[[step]]\ncall = \"zz\"\n")], "a", false)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("call = \"zz\": no such program; there are: a"),
        "{e}"
    );
    let e = checked(&[("a", a)], "main", false).unwrap_err().to_string();
    assert!(
        e.contains("program \"main\": no such program; there are: a"),
        "{e}"
    );
}

/// Issue 44: a copied program that kept `number = 1` made every program refuse.
#[test]
fn two_programs_with_one_number_are_refused_naming_each_other_and_the_rest_run() {
    let p = "number = 4\n[[step]]\ndwell = \"1s\"\n";
    let other = "number = 5\n[[step]]\ndwell = \"1s\"\n";
    let programs = [("a", p), ("b", p), ("c", other)];
    let e = checked(&programs, "a", false).unwrap_err().to_string();
    assert!(
        e.contains("program \"a\": number = 4 is program \"b\"'s number too"),
        "{e}"
    );
    let e = checked(&programs, "b", false).unwrap_err().to_string();
    assert!(
        e.contains("program \"b\": number = 4 is program \"a\"'s number too"),
        "{e}"
    );
    assert!(checked(&programs, "c", false).is_ok());
}

#[test]
fn a_loop_jumps_back_only_and_on_timeout_may_jump_forward() {
    let forward =
        "[[step]]\nloop = { to = \"end\", count = 2 }\n[[step]]\nlabel = \"end\"\ndwell = \"1s\"\n";
    let e = checked(&[("p", forward)], "p", false)
        .unwrap_err()
        .to_string();
    assert!(e.contains("jumps forward"), "{e}");
    let skip = "[[step]]\nwait = \"X5\"\ntimeout = \"1s\"\non_timeout = \"end\"\n[[step]]\ndwell = \"1s\"\n[[step]]\nlabel = \"end\"\ndwell = \"2s\"\n";
    let c = checked(&[("p", skip)], "p", false).unwrap();
    assert!(matches!(
        &c.ops[0].kind,
        OpKind::Wait {
            on_timeout: Some(2),
            ..
        }
    ));
}

/// The seed robot's counts at the seed's P1, the tool at 0 degrees (as the taught positions).
pub(super) fn counts_at_p1() -> [i64; 4] {
    let robot = seed_robot();
    let pose = crate::geometry::Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0);
    robot.counts_of(&crate::kinematics::Kinematics::ik(&robot.kinematics, &pose, None).unwrap())
}

/// Issue 44: a program whose third step went past a joint's limit (z = 900) or onto the base
/// axis was accepted, and faulted at that step with the press half loaded.
#[test]
fn a_target_out_of_reach_or_past_a_limit_is_refused_when_checked_naming_the_step() {
    let beyond = "[[step]]\nmove = { position = \"above-stack\" }\n[[step]]\ndwell = \"1s\"\n\
                  [[step]]\nlabel = \"up\"\nmove = { to = [-926.57, 535.03, 900.0, 0.0] }\n";
    let e = checked(&[("p", beyond)], "p", false)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("program \"p\" step 3 (up): move: "), "{e}");
    assert!(
        e.contains("joint d2 target 900.0000 mm is beyond its limits"),
        "{e}"
    );
    let axis = "[[step]]\nmove = { to = [0.0, 0.0, 100.0] }\n";
    let e = checked(&[("p", axis)], "p", false).unwrap_err().to_string();
    assert!(e.starts_with("program \"p\" step 1: move: "), "{e}");
    // In a called program too, named there.
    let calls = "[[step]]\ncall = \"far\"\n";
    let far = "[[step]]\ndwell = \"1s\"\n[[step]]\nmove = { joints = [0, 900, 600, 0] }\n";
    let e = checked(&[("p", calls), ("far", far)], "p", false)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("program \"far\" step 2: move: "), "{e}");
}

#[test]
fn a_move_by_an_offset_is_checked_from_where_the_moves_before_it_end() {
    let up = "[[step]]\nmove = { position = \"in-press\" }\n[[step]]\nwait = \"X5\"\n\
              [[step]]\nmove = { by = [0, 0, 800] }\n";
    let e = checked(&[("p", up)], "p", false).unwrap_err().to_string();
    assert!(
        e.starts_with("program \"p\" step 3: move from where the steps before it end (-1144.4, 659.6, 186.6, 0.0): "),
        "{e}"
    );
    // A small one is fine, and nothing is left to check when the run begins.
    let fine = up.replace("800", "20");
    let c = checked(&[("p", &fine)], "p", false).unwrap();
    assert!(c.unchecked.is_empty(), "{:?}", c.unchecked);
}

#[test]
fn a_motion_whose_start_depends_on_the_run_is_named_as_checked_when_it_runs() {
    // The first step's start is where the robot stands: unknown before the run, known at it.
    let by =
        "[[step]]\nmove = { by = [0, 0, 20] }\n[[step]]\nmove = { position = \"above-stack\" }\n";
    let c = checked(&[("p", by)], "p", false).unwrap();
    assert_eq!(
        c.unchecked,
        [
            "p step 1: move by [0.0, 0.0, 20.0] from where the robot stands when it begins: checked when it runs"
        ]
    );
    // From the robot's counts at the run, and round to the next cycle from above-stack: two
    // starts, so it still depends on the run.
    let c = checked_from(&[("p", by)], "p", false, Some(counts_at_p1())).unwrap();
    assert_eq!(c.unchecked.len(), 1, "{:?}", c.unchecked);
    // A jog up 800 mm from P1 (and back, so each cycle begins there) is planned from the
    // run's start, and refused.
    let far = "[[step]]\nmove = { by = [0, 0, 800] }\n[[step]]\nmove = { by = [0, 0, -800] }\n";
    let e = checked_from(&[("p", far)], "p", false, Some(counts_at_p1()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("step 1: move from where the steps before it end"),
        "{e}"
    );
    // A loop that jogs the same way each time: its start differs each time round.
    let loops = "[[step]]\nmove = { position = \"above-stack\" }\n[[step]]\nlabel = \"jog\"\n\
                 move = { by = [0, 0, 5] }\n[[step]]\nloop = { to = \"jog\", count = 3 }\n";
    let c = checked(&[("p", loops)], "p", false).unwrap();
    assert_eq!(c.unchecked.len(), 1, "{:?}", c.unchecked);
    assert!(
        c.unchecked[0].starts_with("p step 2 (jog): move by"),
        "{:?}",
        c.unchecked
    );
}

pub(super) const PALLETISE: &str = r#"
[[step]]
label = "pick"
move = { position = "above-stack" }
[[step]]
place = { pallet = "out", at_slot = [{ set = { Y1 = false } }, { dwell = "150ms" }] }
[[step]]
loop = { to = "pick", until = "pallet.out.index == 0" }
"#;

pub(super) const SLIP: &str = "[[step]]\ndwell = \"1s\"\n";

#[test]
fn a_place_step_flattens_into_its_slot_s_ops_between_layers_and_when_full() {
    let c = checked(&[("p", PALLETISE), ("slip", SLIP)], "p", false).unwrap();
    let does: Vec<String> = c.ops.iter().map(|o| o.at.does.clone()).collect();
    assert_eq!(
        does,
        [
            "move to @above-stack",
            "unless pallet.out begins a layer: skip",
            "dwell 1s",
            "place on out: next slot in progress",
            "place on out: approach",
            "place on out: at the slot",
            "set Y1 = false",
            "dwell 150ms",
            "place on out: slot done",
            "place on out: retreat",
            "unless pallet.out.full: skip",
            "out full: set press_go = true",
            "out full: wait for part_present (X2)",
            "out full: set press_go = false",
            "out full: the next pallet from slot 0",
            "loop to pick until pallet.out.index == 0",
        ]
    );
    // The skips jump past their blocks; every op names the place step (or the slip sheet's).
    assert!(matches!(c.ops[1].kind, OpKind::Skip { to: 3, .. }));
    assert!(matches!(c.ops[10].kind, OpKind::Skip { to: 15, .. }));
    assert_eq!(c.ops[2].at.program, "slip");
    assert_eq!(c.ops[2].at.called_from, ["p step 2"]);
    assert!(c.ops[3..15].iter().all(|o| o.at.step == 2));
}

#[test]
fn a_place_written_without_advance_leaves_it_to_an_advance_step() {
    let program = "[[step]]\nplace = { pallet = \"out\", advance = false }\n\
                   [[step]]\nadvance = \"out\"\n";
    let c = checked(&[("p", program), ("slip", SLIP)], "p", false).unwrap();
    let acts: Vec<&OpKind> = c.ops.iter().map(|o| &o.kind).collect();
    let advances = acts
        .iter()
        .filter(|k| {
            matches!(
                k,
                OpKind::Pallet {
                    act: check::PalletAct::Advance,
                    ..
                }
            )
        })
        .count();
    assert_eq!(advances, 1);
    let advance = c
        .ops
        .iter()
        .position(|o| {
            matches!(
                o.kind,
                OpKind::Pallet {
                    act: check::PalletAct::Advance,
                    ..
                }
            )
        })
        .unwrap();
    assert_eq!(c.ops[advance].at.step, 2);
}

#[test]
fn pallet_steps_that_cannot_run_are_refused_naming_the_pallet_the_slot_or_the_step() {
    let cases = [
        (
            "[[step]]\nplace = { pallet = \"nope\" }\n",
            "step 1: no pallet \"nope\"; there are: far, out",
        ),
        (
            "[[step]]\nplace = { pallet = \"far\" }\n",
            "pallet \"far\" slot 0 (layer 0): the slot [-9000.0, 535.0, 100.0, 0.0] cannot be reached",
        ),
        (
            "[[step]]\nplace = { pallet = \"out\", at_slot = [{ move = { position = \"in-press\" } }] }\n",
            "at_slot step 1: runs with the robot at the slot",
        ),
        (
            "[[step]]\nplace = { pallet = \"out\", at_slot = [{ dwell = \"1s\", set = { Y1 = true } }] }\n",
            "at_slot step 1: has set and dwell actions",
        ),
        (
            "[[step]]\nwait = \"pallet.in.full\"\n",
            "condition reads pallet \"in\", which the robot does not have (pallets: far, out)",
        ),
        ("[[step]]\nadvance = \"in\"\n", "no pallet \"in\""),
        (
            "[[step]]\nplace = { pallet = \"out\" }\npick = { pallet = \"out\" }\n",
            "has place and pick actions",
        ),
    ];
    for (program, words) in cases {
        let e = checked(&[("p", program), ("slip", SLIP)], "p", false)
            .unwrap_err()
            .to_string();
        assert!(e.contains(words), "{program}\n=> {e}");
    }
}
