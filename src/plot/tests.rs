//! The SVG builder on a short synthetic move of the seed's robot.

use super::*;
use crate::geometry::Pose;
use crate::plan::{MoveRequest, Origin, plan_move};
use crate::robot::seed_robot;
use crate::sim::PulseEvent;

fn plan(method: Method, seed_exact: bool) -> Plan {
    let robot = seed_robot();
    let request = MoveRequest {
        from: Origin::Pose(Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0)),
        to: Pose::from_mm_deg(-936.57, 541.03, 56.0, 0.0),
        motion: crate::robot::Motion {
            method: if seed_exact {
                Method::SeedExact
            } else {
                method
            },
            ..robot.motion
        },
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

fn path<'a>(label: &'a str, p: &'a Plan, events: &'a [PulseEvent]) -> Path<'a> {
    Path {
        label,
        line: p.line,
        start: start_counts(p),
        events,
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
    };
    let back = plan_move(&seed_robot(), &back_request).unwrap();
    let (there_run, back_run) = (there.execution(), back.execution());
    let paths = [
        path("there", &there, &there_run.events),
        Path {
            tolerance_mm: Some(0.05),
            ..path("back", &back, &back_run.events)
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

/// The blended pick and place of docs/PATHS.md, bounded-error 0.05 mm, with a stop at the top of
/// the lift: two starts.
fn blended_path() -> crate::plan::PathPlan {
    use crate::geometry::{Corner, Element};
    use crate::plan::{PathRequest, plan_path};
    let robot = seed_robot();
    let at = |x, y, z| Element::Line {
        to: Pose::from_mm_deg(x, y, z, 0.0),
    };
    let req = PathRequest {
        from: Origin::Pose(Pose::from_mm_deg(-926.57, 535.03, 50.0, 0.0)),
        start: None,
        elements: vec![
            (at(-926.57, 535.03, 60.0), Corner::Stop),
            (at(-1144.43, 659.60, 286.60), Corner::Blend(20.0)),
            (at(-1144.43, 659.60, 186.60), Corner::Stop),
        ],
        motion: crate::robot::Motion {
            method: Method::BoundedError { tolerance_mm: 0.05 },
            ..robot.motion
        },
        path_accel_mm_s2: 5_000.0,
    };
    plan_path(&robot, &req).unwrap()
}

#[test]
fn a_path_is_drawn_with_its_blend_arc_and_every_starts_pulses() {
    let planned = blended_path();
    let starts: Vec<&Plan> = planned.starts().collect();
    // Two sections; the second cut where d2 reverses at the top of the blend.
    assert_eq!(starts.len(), 3);
    let svg = svg_path(&seed_robot(), &planned.path, &starts).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for text in [
        "planned path",
        "offsets from the path",
        "distance along the path (mm)",
        "blend at waypoint 2, radius 8.",
        "bounded-error 0.05 mm, fpx-divider",
        "tolerance 0.05 mm",
        "4 pieces",
    ] {
        assert!(svg.contains(text), "no {text:?}");
    }
    assert!(!svg.contains("planned line"));
    assert!(matches!(
        svg_path(&seed_robot(), &planned.path, &[]),
        Err(PlotError::NoPlan)
    ));
}

#[test]
fn the_executed_path_runs_every_start_along_the_whole_path_within_the_tolerance() {
    let planned = blended_path();
    let path = &planned.path;
    let mut track = Vec::new();
    for plan in planned.starts() {
        let run = track::executed(
            &seed_robot(),
            path,
            path,
            start_counts(plan),
            &plan.execution().events,
        );
        assert_eq!(run.len(), plan.execution().events.len() + 1);
        track.extend(run);
    }
    // From the path's start to its end, never farther from it than the plans say.
    assert!(track[0].along_mm < 0.1);
    let last = track.last().unwrap().along_mm;
    assert!((last - path.length_mm()).abs() < 0.1, "{last}");
    let worst = track
        .iter()
        .map(track::TrackPoint::deviation_mm)
        .fold(0.0, f64::max);
    assert!(worst <= planned.max_deviation_mm() + 1e-9, "{worst}");
    // Some of it is placed on the blend's arc.
    let arc = planned.path.pieces()[2];
    let on_arc = track
        .iter()
        .filter(|p| (arc.start_mm..arc.start_mm + arc.primitive.length_mm()).contains(&p.along_mm));
    assert!(on_arc.count() > 10);
}

#[test]
fn an_arc_is_outlined_through_its_middle_within_a_hair() {
    let planned = blended_path();
    let arc = planned.path.pieces()[2];
    assert_eq!(arc.waypoint, Some(2));
    let points = draw::outline(&arc.primitive);
    assert!(points.len() > 60, "{}", points.len());
    let crate::geometry::Primitive::Arc(a) = arc.primitive else {
        panic!("{arc:?}")
    };
    for p in &points {
        assert!(((p - a.centre_mm).norm() - a.radius_mm).abs() < 1e-9);
    }
    let middle = a.at(a.length_mm() / 2.0).position_mm;
    let nearest = points
        .iter()
        .map(|p| (p - middle).norm())
        .fold(f64::INFINITY, f64::min);
    // Points every 2 deg at most: one within 1 deg of arc of the middle.
    assert!(nearest <= a.radius_mm * 1f64.to_radians(), "{nearest}");
}
