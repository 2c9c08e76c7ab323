//! Patterns worked by hand, frames moved, slots out of reach, bad values.

use std::collections::BTreeMap;

use nalgebra::{Rotation3, Vector3};

use super::doc::{FrameDoc, PalletDoc};
use super::*;
use crate::robot::{Position, seed_robot};

fn doc(text: &str) -> PalletDoc {
    toml::from_str(text).unwrap()
}

fn pallets(frames: &str, pallets: &str) -> Result<RobotPallets, PalletError> {
    let frames: BTreeMap<String, FrameDoc> = toml::from_str(frames).unwrap();
    let pallets: BTreeMap<String, PalletDoc> = toml::from_str(pallets).unwrap();
    RobotPallets::check(&frames, &pallets)
}

fn position(x: f64, y: f64, z: f64) -> Position {
    Position {
        pose: [x, y, z, 0.0],
        joint_counts: [0; 4],
        saved_unix_s: 0,
        frame: None,
    }
}

fn close(a: &Pose, b: [f64; 4]) -> bool {
    let [x, y, z, a_deg] = a.to_mm_deg();
    let da = (a_deg - b[3]).rem_euclid(360.0);
    (x - b[0]).abs() < 1e-9
        && (y - b[1]).abs() < 1e-9
        && (z - b[2]).abs() < 1e-9
        && (da < 1e-9 || 360.0 - da < 1e-9)
}

const BRICK: &str = r#"
origin_mm = [700, 0, 100]
rows = 2
columns = 3
pitch_mm = [300, 200]
layer_height_mm = 80
layers = ["A", "B", "A", "B"]
kinds.A = { odd_rows_shift_mm = 150 }
kinds.B = { turn_deg = 180, shift_mm = [150, 0] }
"#;

#[test]
fn every_slot_of_a_brick_pallet_is_where_the_hand_worked_formula_puts_it() {
    let layout = Layout::check("brick", &doc(BRICK)).unwrap();
    let slots = layout.slots(
        &Frame::world(),
        Vector3::new(700.0, 0.0, 100.0),
        nalgebra::Vector2::new(300.0, 200.0),
    );
    assert_eq!(slots.len(), 4 * 6);
    let mut expected = Vec::new();
    for layer in 0..4 {
        let z = 100.0 + 80.0 * layer as f64;
        for r in 0..2 {
            for c in 0..3 {
                let [x, y, a] = if layer % 2 == 0 {
                    // Brick rows: row 1 half a column pitch along.
                    [
                        700.0 + 300.0 * c as f64 + if r == 1 { 150.0 } else { 0.0 },
                        200.0 * r as f64,
                        0.0,
                    ]
                } else {
                    // Turned half a turn: slot (r, c) lies where grid slot (1 - r, 2 - c) would,
                    // then the layer moves 150 mm along x; the tool turned half a turn.
                    [
                        700.0 + 300.0 * (2 - c) as f64 + 150.0,
                        200.0 * (1 - r) as f64,
                        180.0,
                    ]
                };
                expected.push((layer, r, c, [x, y, z, a]));
            }
        }
    }
    for (slot, (layer, row, column, pose)) in slots.iter().zip(&expected) {
        assert_eq!((slot.layer, slot.row, slot.column), (*layer, *row, *column));
        assert!(
            close(&slot.pose, *pose),
            "slot {}: {:?} != {pose:?}",
            slot.index,
            slot.pose.to_mm_deg()
        );
    }
}

#[test]
fn a_quarter_turned_and_mirrored_layer_and_the_snake_order_are_as_worked_by_hand() {
    let text = "rows = 2\ncolumns = 3\npitch_mm = [300, 200]\nlayer_height_mm = 100\n\
                layers = [\"T\", \"M\"]\norder = \"snake-rows\"\na_deg = 10\n\
                kinds.T = { turn_deg = 90 }\nkinds.M = { mirror = \"x\" }\n";
    let layout = Layout::check("t", &doc(text)).unwrap();
    let slots = layout.slots(
        &Frame::world(),
        Vector3::zeros(),
        nalgebra::Vector2::new(300.0, 200.0),
    );
    // Snake: row 0 columns 0, 1, 2; row 1 columns 2, 1, 0.
    let order: Vec<(usize, usize)> = slots[..6].iter().map(|s| (s.row, s.column)).collect();
    assert_eq!(order, [(0, 0), (0, 1), (0, 2), (1, 2), (1, 1), (1, 0)]);
    // Turned 90 about the centre (300, 100): (x, y) -> (300 - (y - 100), 100 + (x - 300)).
    assert!(
        close(&slots[0].pose, [400.0, -200.0, 0.0, 100.0]),
        "{:?}",
        slots[0].pose.to_mm_deg()
    );
    assert!(
        close(&slots[3].pose, [200.0, 400.0, 0.0, 100.0]),
        "{:?}",
        slots[3].pose.to_mm_deg()
    );
    // Mirrored across x = 300: column 0 lands on column 2's place, the angle mirrored.
    assert!(
        close(&slots[6].pose, [600.0, 0.0, 100.0, -10.0]),
        "{:?}",
        slots[6].pose.to_mm_deg()
    );
}

#[test]
fn a_listed_layer_keeps_its_slots_and_angles_in_the_frame() {
    let text = "origin_mm = [0, 1000, 50]\nlayer_height_mm = 100\nlayers = [\"X\"]\n\
                kinds.X = { slots = [[0, 0, 90], [250, 0, 0]] }\n";
    let p = pallets(
        "st = { origin = [100, 0, 0], rotation_deg = 90 }",
        &format!("[x]\nframe = \"st\"\n{text}"),
    )
    .unwrap()
    .pattern("x", &seed_robot(), &BTreeMap::new())
    .unwrap();
    // Frame turned 90: local (0, 1000) -> world (100 - 1000, 0); local (250, 1000) -> (-900, 250).
    assert!(close(&p.slot(0).unwrap().pose, [-900.0, 0.0, 50.0, 180.0]));
    assert!(close(&p.slot(1).unwrap().pose, [-900.0, 250.0, 50.0, 90.0]));
    assert_eq!((p.slot(1).unwrap().row, p.len()), (1, 2));
}

#[test]
fn the_approach_and_retreat_rise_above_the_slot_and_slow_for_the_last_millimetres() {
    let text = format!(
        "{BRICK}approach = {{ height_mm = 50, side_mm = [0, -75], slow_mm = 25, slow_speed_mm_s = 40 }}\n\
         retreat = {{ height_mm = 50 }}\nbetween_layers = \"sheet\"\nwhen_full = {{ signal = \"full\" }}\n"
    );
    let p = pallets("", &format!("[b]\n{text}"))
        .unwrap()
        .pattern("b", &seed_robot(), &BTreeMap::new())
        .unwrap();
    let s = p.slot(0).unwrap();
    let at = s.pose.position_mm;
    assert_eq!(s.approach.len(), 2);
    let above = Vector3::new(0.0, -75.0, 50.0);
    assert!((s.approach[0].pose.position_mm - (at + above)).norm() < 1e-9);
    // 25 mm short of the slot along the line from above.
    let near = at + above * (25.0 / 75f64.hypot(50.0));
    assert!((s.approach[1].pose.position_mm - near).norm() < 1e-9);
    assert_eq!(s.slot_speed_mm_s, Some(40.0));
    assert_eq!(s.retreat.len(), 1);
    assert!((s.retreat[0].pose.position_mm - (at + Vector3::new(0.0, 0.0, 50.0))).norm() < 1e-9);
    assert_eq!(
        (p.between_layers.as_deref(), p.when_full.signal.as_deref()),
        (Some("sheet"), Some("full"))
    );
    assert!(
        s.approach
            .iter()
            .chain(&s.retreat)
            .all(|w| w.blend_mm.is_none()),
        "every corner a stop unless blended"
    );
}

/// `approach.blend_mm` blends the approach's first point, and it alone: the retreat given as
/// the approach's keeps every corner a stop; a blend on the retreat, or longer than the line
/// from that point to the slow stretch, or on an approach all slow, is refused naming it.
#[test]
fn the_approachs_first_point_alone_is_blended_within_its_line() {
    let approach = "approach = { height_mm = 60, side_mm = [0, -80], slow_mm = 25, \
                    slow_speed_mm_s = 40, blend_mm = 30 }";
    let p = pallets("", &format!("[b]\n{BRICK}{approach}\n"))
        .unwrap()
        .pattern("b", &seed_robot(), &BTreeMap::new())
        .unwrap();
    let s = p.slot(5).unwrap();
    let blends: Vec<Option<f64>> = s.approach.iter().map(|w| w.blend_mm).collect();
    assert_eq!(blends, [Some(30.0), None]);
    assert_eq!(s.retreat.len(), 2, "the approach's way, out");
    assert!(s.retreat.iter().all(|w| w.blend_mm.is_none()));
    let cases = [
        (
            "approach = { height_mm = 60, side_mm = [0, -80], slow_mm = 25, slow_speed_mm_s = 40, blend_mm = 80 }",
            // The line from 100 mm out to 25 mm short of the slot: 75 mm.
            "approach.blend_mm = 80: must be above 0 and at most 75",
        ),
        (
            "approach = { height_mm = 60, blend_mm = -1 }",
            "approach.blend_mm = -1: must be above 0",
        ),
        (
            "approach = { height_mm = 60, slow_mm = 60, slow_speed_mm_s = 40, blend_mm = 10 }",
            "approach.blend_mm = 10: the approach is all slow stretch",
        ),
        (
            "retreat = { height_mm = 60, blend_mm = 10 }",
            "retreat.blend_mm = 10: the way out ends at its point above the slot",
        ),
    ];
    for (line, want) in cases {
        let e = pallets("", &format!("[b]\n{BRICK}{line}\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{line}: {e}");
    }
}

#[test]
fn a_slot_out_of_reach_is_refused_naming_the_slot() {
    // The seed reaches 500 to 1500 mm from its axis: moved 300 mm out, column 2 of row 0 of the
    // brick layer, at (1600, 0), is beyond it.
    let far = BRICK.replace("[700, 0, 100]", "[1000, 0, 100]");
    let e = pallets("", &format!("[out]\n{far}"))
        .unwrap()
        .pattern("out", &seed_robot(), &BTreeMap::new())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("pallet \"out\", slot 2 (layer 0, row 0, column 2), the slot: "),
        "{e}"
    );
    assert!(e.contains("d3"), "{e}");
    // An approach too high for the lift (z 100 + 320 > 400): the waypoint is named.
    let e = pallets(
        "",
        &format!("[out]\n{BRICK}approach = {{ height_mm = 320 }}\n"),
    )
    .unwrap()
    .pattern("out", &seed_robot(), &BTreeMap::new())
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("pallet \"out\", slot 0 (layer 0, row 0, column 0), approach waypoint 1: "),
        "{e}"
    );
    assert!(e.contains("d2") && e.contains("400"), "{e}");
}

#[test]
fn a_frame_taught_from_three_points_and_moved_moves_every_slot_with_it() {
    let robot = seed_robot();
    let set = pallets(
        "st = { origin = \"@o\", x_point = \"@x\", xy_point = \"@y\" }",
        "[p]\nframe = \"st\"\norigin_mm = [50, 50, 30]\nrows = 3\ncolumns = 4\npitch_mm = [120, 100]\n\
         layer_height_mm = 80\nlayers = [\"A\", \"B\"]\nkinds.A = {}\nkinds.B = { turn_deg = 90, shift_mm = [60, 0] }\n\
         approach = { height_mm = 60 }\n",
    )
    .unwrap();
    let points = [
        Vector3::new(-200.0, 800.0, 0.0),
        Vector3::new(200.0, 820.0, 0.0),
        Vector3::new(-220.0, 1100.0, 0.0),
    ];
    let taught = |p: &[Vector3<f64>; 3]| -> BTreeMap<String, Position> {
        ["o", "x", "y"]
            .iter()
            .zip(p)
            .map(|(n, v)| ((*n).to_owned(), position(v.x, v.y, v.z)))
            .collect()
    };
    let before = set.pattern("p", &robot, &taught(&points)).unwrap();
    // Re-taught: turned 25 degrees about (0, 0) and moved (-150, 40, 20).
    let turn = Rotation3::from_axis_angle(&Vector3::z_axis(), 25f64.to_radians());
    let shift = Vector3::new(-150.0, 40.0, 20.0);
    let moved = points.map(|p| turn * p + shift);
    let after = set.pattern("p", &robot, &taught(&moved)).unwrap();
    assert_eq!(after.len(), 24);
    for (b, a) in before.slots().iter().zip(after.slots()) {
        let expected = Pose {
            position_mm: turn * b.pose.position_mm + shift,
            a_rad: b.pose.a_rad + 25f64.to_radians(),
        };
        let want = crate::plan::check_pose(&robot, &expected).unwrap();
        let got = crate::plan::check_pose(&robot, &a.pose).unwrap();
        for j in 0..4 {
            assert!(
                (want[j] - got[j]).abs() <= 1,
                "slot {} joint {j}: {got:?} vs {want:?}",
                a.index
            );
        }
        let up = turn * b.approach[0].pose.position_mm + shift;
        assert!((a.approach[0].pose.position_mm - up).norm() < 1e-6);
    }
}

#[test]
fn bad_keys_and_values_are_refused_naming_the_pallet_key_value_and_limit() {
    let cases = [
        ("rows = 0", "pallet \"b\": rows = 0: must be within 1..=100"),
        (
            "pitch_mm = [300, -1]",
            "pallet \"b\": pitch_mm[1] = -1: must be above 0 and at most 5000",
        ),
        (
            "layer_height_mm = 0",
            "pallet \"b\": layer_height_mm = 0: must be above 0",
        ),
        (
            "layers = [\"A\", \"C\"]",
            "pallet \"b\": layers[1] = \"C\": the kinds defined are A, B",
        ),
        (
            "kinds.B = { turn_deg = 45 }",
            "pallet \"b\": kinds.B.turn_deg = 45: must be a quarter turn",
        ),
        (
            "approach = { height_mm = 50, slow_mm = 80, slow_speed_mm_s = 5 }",
            "approach.slow_mm = 80: must be above 0 and at most 50",
        ),
        (
            "frame = \"nowhere\"",
            "pallet \"b\": frame = \"nowhere\": no frame is defined",
        ),
        (
            "corners = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]",
            "pallet \"b\": origin_mm = (given): corners place the grid",
        ),
        (
            "when_full = { call = \" \" }",
            "pallet \"b\": when_full.call = \" \": must not be blank",
        ),
    ];
    for (line, want) in cases {
        let key = line.split(" =").next().unwrap();
        let kept: Vec<&str> = BRICK
            .lines()
            .filter(|l| l.split(" =").next() != Some(key))
            .collect();
        let text = format!("[b]\n{}\n{line}\n", kept.join("\n"));
        let e = pallets("", &text).unwrap_err().to_string();
        assert!(e.starts_with(want) || e.contains(want), "{line}: {e}");
    }
    let unknown = toml::from_str::<PalletDoc>(&format!("{BRICK}colour = 1\n"))
        .unwrap_err()
        .to_string();
    assert!(unknown.contains("unknown field `colour`"), "{unknown}");
}

#[test]
fn slot_layers_agree_with_the_laid_out_pattern_for_grid_and_listed_layers() {
    let text = "[mixed]\norigin_mm = [700, 0, 100]\nrows = 2\ncolumns = 3\npitch_mm = [300, 200]\n\
                layer_height_mm = 80\nlayers = [\"A\", \"L\", \"A\"]\nkinds.A = {}\n\
                kinds.L = { slots = [[0, 0, 0], [300, 0, 0]] }\n";
    let set = pallets("", &format!("[brick]\n{BRICK}\n{text}")).unwrap();
    for name in ["brick", "mixed"] {
        let pattern = set.pattern(name, &seed_robot(), &BTreeMap::new()).unwrap();
        let by_pattern: Vec<usize> = pattern.slots().iter().map(|s| s.layer).collect();
        assert_eq!(set.layouts[name].slot_layers(), by_pattern, "{name}");
    }
    // Worked by hand: 6 grid slots, 2 listed, 6 grid.
    let mut want = vec![0; 6];
    want.extend([1, 1]);
    want.extend([2; 6]);
    assert_eq!(set.layouts["mixed"].slot_layers(), want);
}
