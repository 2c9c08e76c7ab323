//! Runs of blended move steps: merged into one path op named for their first step, stopped by
//! anything between them, and every blend that cannot run refused naming the step and the
//! limit.

use super::super::tests::{checked, checked_from, counts_at_p1};
use crate::cycle::OpKind;

/// Above the place (100 mm over the taught `in-press`).
const ABOVE_PLACE: &str = "[-1144.43, 659.6, 286.6]";
/// The pick (100 mm under the taught `above-stack`).
const PICK: &str = "[-926.57, 535.03, 50.0]";

/// Pick at P1, up to `above-stack`, across to above the place, down into `in-press`, and
/// back: the approach and the retreat blended by `blend`, the gripper set at each end.
fn pick_and_place(blend: &str) -> String {
    format!(
        r#"
[[step]]
label = "pick"
set = {{ Y1 = true }}
[[step]]
move = {{ position = "above-stack" }}
blend_mm = {blend}
[[step]]
move = {{ to = {ABOVE_PLACE} }}
blend_mm = 20
[[step]]
move = {{ position = "in-press" }}
[[step]]
set = {{ Y1 = false }}
[[step]]
move = {{ to = {ABOVE_PLACE} }}
blend_mm = 20
[[step]]
move = {{ position = "above-stack" }}
blend_mm = 20
[[step]]
move = {{ to = {PICK} }}
[[step]]
loop = {{ to = "pick", until = "stop" }}
"#
    )
}

fn refusal(program: &str) -> String {
    checked(&[("p", program)], "p", false)
        .unwrap_err()
        .to_string()
}

#[test]
fn consecutive_blended_moves_run_as_one_path_named_for_their_first_step() {
    let c = checked(&[("p", &pick_and_place("20"))], "p", false).unwrap();
    let does: Vec<&str> = c.ops.iter().map(|o| o.at.does.as_str()).collect();
    assert_eq!(
        does,
        [
            "set Y1 = true",
            "blended moves, steps 2 to 4: move to @above-stack (blend 20 mm), \
             move to [-1144.43, 659.6, 286.6] (blend 20 mm), move to @in-press",
            "set Y1 = false",
            "blended moves, steps 6 to 8: move to [-1144.43, 659.6, 286.6] (blend 20 mm), \
             move to @above-stack (blend 20 mm), move to [-926.57, 535.03, 50.0]",
            "loop to pick until stopped",
        ]
    );
    let steps: Vec<usize> = c.ops.iter().map(|o| o.at.step).collect();
    assert_eq!(steps, [1, 2, 5, 6, 9]);
    assert_eq!(c.blended, [1, 3]);
    // The path: a line to each target, blended at the ends of all but the last, which stops.
    let OpKind::Path(order) = &c.ops[1].kind else {
        panic!("{:?}", c.ops[1].kind)
    };
    assert_eq!(
        order.path,
        serde_json::json!({"element": [
            {"line": "@above-stack", "blend": 20.0},
            {"line": [-1144.43, 659.6, 286.6], "blend": 20.0},
            {"line": "@in-press", "stop": true},
        ]})
    );
    assert!(matches!(c.ops[4].kind, OpKind::Loop { to: 0, .. }));
}

#[test]
fn a_step_between_two_moves_ends_the_run_and_a_blend_into_it_is_refused() {
    // Without a blend on the move before the set, the moves around it are their own ops.
    let split = format!(
        "[[step]]\nmove = {{ position = \"above-stack\" }}\nblend_mm = 20\n\
         [[step]]\nmove = {{ to = {ABOVE_PLACE} }}\n[[step]]\nset = {{ Y1 = true }}\n\
         [[step]]\nmove = {{ position = \"in-press\" }}\n"
    );
    let c = checked(&[("p", &split)], "p", false).unwrap();
    let kinds: Vec<&str> = c
        .ops
        .iter()
        .map(|o| match o.kind {
            OpKind::Path(_) => "path",
            OpKind::Move(_) => "move",
            OpKind::Set(_) => "set",
            _ => "other",
        })
        .collect();
    assert_eq!(kinds, ["path", "set", "move"]);
    // A blend into the set is refused, not run as a stop.
    let into_set = split.replacen(" }\n[[step]]\nset", " }\nblend_mm = 20\n[[step]]\nset", 1);
    assert_eq!(
        refusal(&into_set),
        "program \"p\" step 2: blend_mm = 20 rounds this move's end into the next step, but \
         step 3 is not a move: only consecutive move steps blend; leave out blend_mm to stop there"
    );
    // Nor into the program's end (round to the next cycle is not a blend either).
    let last = "[[step]]\nmove = { position = \"above-stack\" }\nblend_mm = 20\n";
    assert_eq!(
        refusal(last),
        "program \"p\" step 1: blend_mm = 20 rounds this move's end into the next step, but \
         this is the program's last step; leave out blend_mm to stop there"
    );
}

#[test]
fn a_step_a_jump_can_land_on_is_never_run_inside_a_blend() {
    // Labelled in the middle of the run: a loop to it would begin mid-path.
    let labelled = format!(
        "[[step]]\nmove = {{ position = \"above-stack\" }}\nblend_mm = 20\n\
         [[step]]\nlabel = \"across\"\nmove = {{ to = {ABOVE_PLACE} }}\n\
         [[step]]\nloop = {{ to = \"across\", count = 2 }}\n"
    );
    assert_eq!(
        refusal(&labelled),
        "program \"p\" step 1: blend_mm = 20 rounds this move's end into the next step, but \
         step 2 is labelled \"across\": a jump could land there, in the middle of the blended \
         path; leave out blend_mm to stop there"
    );
    // Labelled at its first step, the jump lands on the path's start.
    let first = labelled.replace("label = \"across\"\n", "").replacen(
        "[[step]]\n",
        "[[step]]\nlabel = \"across\"\n",
        1,
    );
    let c = checked(&[("p", &first)], "p", false).unwrap();
    assert!(matches!(c.ops[0].kind, OpKind::Path(_)), "{:?}", c.ops);
    assert!(
        matches!(c.ops[1].kind, OpKind::Loop { to: 0, .. }),
        "{:?}",
        c.ops
    );
}

#[test]
fn a_blend_larger_than_half_the_moves_beside_it_is_refused_naming_the_step_and_the_limit() {
    // The corner above the place: 285.7 mm across into it, 100 mm down out of it.
    let e = refusal(&pick_and_place("20").replacen(
        "blend_mm = 20\n[[step]]\nmove = { position = \"in-press\" }",
        "blend_mm = 60\n[[step]]\nmove = { position = \"in-press\" }",
        1,
    ));
    assert_eq!(
        e,
        "program \"p\" step 3: blend_mm = 60 is more than this corner allows: at most 50.0 mm, \
         half the shorter of the moves beside it (this move 285.7 mm, step 4's 100.0 mm)"
    );
    // The first corner of a run, once its start is known (the run's, and round from the pick):
    // 100 mm up from the pick into it.
    let wide = pick_and_place("70");
    let e = checked_from(&[("p", &wide)], "p", false, Some(counts_at_p1()))
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "program \"p\" step 2: blend_mm = 70 is more than this corner allows: at most 50.0 mm, \
         half the shorter of the moves beside it (this move 100.0 mm, step 3's 285.7 mm)"
    );
    // Not known (the robot's pose at the run): its start depends on the run, checked then.
    let c = checked(&[("p", &wide)], "p", false).unwrap();
    assert!(
        c.unchecked.iter().any(|u| u.starts_with("p step 2: ")),
        "{:?}",
        c.unchecked
    );
    // Within the limit, from the known start: accepted, and planned.
    checked_from(
        &[("p", &pick_and_place("45"))],
        "p",
        false,
        Some(counts_at_p1()),
    )
    .unwrap();
}

#[test]
fn every_blend_that_cannot_run_is_refused_naming_the_step_and_the_value() {
    let two = |first: &str, second: &str| format!("[[step]]\n{first}\n[[step]]\n{second}\n");
    let above = "move = { position = \"above-stack\" }";
    let cases = [
        (
            two(
                &format!("{above}\nblend_mm = 0"),
                "move = { position = \"in-press\" }",
            ),
            "program \"p\" step 1: blend_mm = 0: must be a number of mm above 0 (leave it out \
             to stop at the move's end)",
        ),
        (
            two(
                &format!("{above}\nblend_mm = -2"),
                "move = { position = \"in-press\" }",
            ),
            "program \"p\" step 1: blend_mm = -2: must be a number of mm above 0",
        ),
        (
            two("dwell = \"1s\"\nblend_mm = 20", above),
            "program \"p\" step 1: blend_mm goes with a move (a path's corners are blended in \
             its document)",
        ),
        (
            two(
                &format!("{above}\nblend_mm = 20"),
                "move = { by = [0, 0, 50] }",
            ),
            "program \"p\" step 2: move by cannot run in a blended run: its moves are lines to \
             a pose or a taught position (to, position)",
        ),
        (
            two(
                &format!("{above}\nblend_mm = 20"),
                "move = { position = \"in-press\", speed_mm_s = 100 }",
            ),
            "program \"p\" step 2: this move's speed_mm_s (100) differs from step 1's (not \
             given): the moves of a blended run are one path with one motion and one permit",
        ),
        (
            two(
                &format!("{above}\nblend_mm = 20"),
                "move = { position = \"in-press\" }\npermit = \"press_open\"",
            ),
            "program \"p\" step 2: this move's permit (press_open) differs from step 1's",
        ),
        (
            format!(
                "[[step]]\n{above}\nblend_mm = 20\n[[step]]\nmove = {{ to = {PICK} }}\n\
                 blend_mm = 20\n[[step]]\n{above}\n"
            ),
            "program \"p\" step 2: blend_mm = 20: step 3 turns back by 180.0 deg from this \
             move: no blend can round that",
        ),
        (
            format!(
                "[[step]]\nmove = {{ to = {PICK} }}\nblend_mm = 20\n[[step]]\n{above}\n\
                 blend_mm = 20\n[[step]]\n{above}\n"
            ),
            "program \"p\" step 2: blend_mm = 20: step 3 ends where this move ends",
        ),
    ];
    for (program, expected) in cases {
        let e = refusal(&program);
        assert!(e.starts_with(expected), "{e}\nexpected: {expected}");
    }
}

#[test]
fn a_runs_path_accel_is_given_on_its_first_move_and_goes_into_its_path() {
    let with = pick_and_place("20").replacen(
        "blend_mm = 20\n",
        "blend_mm = 20\npath_accel = \"3000mm/s2\"\n",
        1,
    );
    let c = checked(&[("p", &with)], "p", false).unwrap();
    let OpKind::Path(order) = &c.ops[1].kind else {
        panic!("{:?}", c.ops[1].kind)
    };
    assert_eq!(order.path["path_accel"], "3000mm/s2");
    // The other run has none: its corners take the default (speed over acceleration time).
    let OpKind::Path(other) = &c.ops[3].kind else {
        panic!("{:?}", c.ops[3].kind)
    };
    assert!(other.path.get("path_accel").is_none(), "{}", other.path);
}

#[test]
fn a_path_accel_anywhere_but_a_runs_first_move_or_not_a_number_is_refused_naming_the_step() {
    // On the run's second move.
    let second = pick_and_place("20").replacen(
        &format!("move = {{ to = {ABOVE_PLACE} }}\nblend_mm = 20\n"),
        &format!("move = {{ to = {ABOVE_PLACE} }}\nblend_mm = 20\npath_accel = 3000\n"),
        1,
    );
    assert_eq!(
        refusal(&second),
        "program \"p\" step 3: path_accel goes on the first move of a blended run (step 2): \
         the run is one path, with one acceleration"
    );
    // On a move that stops at its end.
    let stopped = "[[step]]\nmove = { position = \"above-stack\" }\npath_accel = 3000\n";
    assert!(
        refusal(stopped).contains("step 1: path_accel goes with a move that has blend_mm"),
        "{}",
        refusal(stopped)
    );
    // Not an acceleration.
    for (value, why) in [
        ("\"fast\"", "'fast' is not a number of mm/s2"),
        ("-5", "-5 mm/s2 must be a number above 0"),
    ] {
        let bad = pick_and_place("20").replacen(
            "blend_mm = 20\n",
            &format!("blend_mm = 20\npath_accel = {value}\n"),
            1,
        );
        let r = refusal(&bad);
        assert!(r.contains("step 2") && r.contains(why), "{value}: {r}");
    }
}
