//! The SVG builder on a short synthetic move of the seed's robot.

use super::*;
use crate::geometry::Pose;
use crate::plan::{MoveRequest, Origin, plan_move};
use crate::robot::seed_robot;

fn plan(method: Method, seed_exact: bool) -> Plan {
    let robot = seed_robot();
    let request = MoveRequest {
        from: Origin::Pose(Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0)),
        to: Pose::from_mm_deg(-936.57, 541.03, 56.0, 0.0),
        motion: crate::robot::Motion {
            method,
            ..robot.motion
        },
        seed_exact,
    };
    plan_move(&robot, &request).expect("a short move plans")
}

fn count(svg: &str, needle: &str) -> usize {
    svg.matches(needle).count()
}

#[test]
fn svg_is_one_document_with_every_series_in_every_panel() {
    let a = plan(Method::ConstantPeriod, false);
    let b = plan(Method::BoundedError { tolerance_mm: 0.05 }, false);
    let svg = svg(&seed_robot(), &[&a, &b]).unwrap();
    assert!(svg.starts_with("<svg"), "{}", &svg[..80]);
    assert!(svg.trim_end().ends_with("</svg>"));
    // Two series in three panels, the planned line twice, one line sample a legend entry.
    assert!(
        count(&svg, "<polyline") >= 2 * 3 + 2,
        "{}",
        count(&svg, "<polyline")
    );
    for text in [
        "X (mm)",
        "Y (mm)",
        "Z (mm)",
        "distance along the line (mm)",
        "deviation (mm)",
        "tolerance 0.05 mm",
        "constant-period, fpx-divider",
        "bounded-error 0.05 mm, fpx-divider",
        "press-loader",
    ] {
        assert!(svg.contains(text), "no {text:?}");
    }
}

#[test]
fn no_plan_is_an_error() {
    assert!(matches!(svg(&seed_robot(), &[]), Err(PlotError::NoPlan)));
}

#[test]
fn seed_exact_is_named_as_such_and_has_no_tolerance_line() {
    let p = plan(Method::ConstantPeriod, true);
    assert_eq!(label(&p), "seed-exact, fpx-divider");
    let svg = svg(&seed_robot(), &[&p]).unwrap();
    assert!(!svg.contains("tolerance"));
}

#[test]
fn magnification_is_a_1_2_5_value_keeping_offsets_within_their_share() {
    assert!((magnification(250.0, 0.05, 0.04) - 200.0).abs() < 1e-9);
    assert!((magnification(250.0, 0.3, 0.04) - 20.0).abs() < 1e-9);
    assert!((magnification(250.0, 0.0, 0.04) - 1.0).abs() < 1e-9);
    assert!((magnification(10.0, 5.0, 0.04) - 1.0).abs() < 1e-9);
}

fn path<'a>(label: &'a str, p: &'a Plan) -> Path<'a> {
    Path {
        label,
        line: p.line,
        start: start_counts(p),
        events: &p.execution.events,
        tolerance_mm: None,
    }
}

#[test]
fn executed_paths_back_and_forth_on_one_line_are_drawn_with_their_tolerance() {
    let there = plan(Method::ConstantPeriod, false);
    let back_request = MoveRequest {
        from: Origin::Counts(there.end_counts()),
        to: there.line.from,
        motion: crate::robot::Motion {
            method: Method::BoundedError { tolerance_mm: 0.05 },
            ..seed_robot().motion
        },
        seed_exact: false,
    };
    let back = plan_move(&seed_robot(), &back_request).unwrap();
    let paths = [
        path("there", &there),
        Path {
            tolerance_mm: Some(0.05),
            ..path("back", &back)
        },
    ];
    let svg = svg_paths(&seed_robot(), "two moves", there.line, &paths).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for text in ["two moves", "there", "back", "tolerance 0.05 mm"] {
        assert!(svg.contains(text), "no {text:?}");
    }
    assert!(matches!(
        svg_paths(&seed_robot(), "none", there.line, &[]),
        Err(PlotError::NoPlan)
    ));
}
