//! Paths on the seed's robot: cycles blended and stopped, parts, arcs, tight blends, slow-down
//! on a stretch, S-curves, refusals.

use nalgebra::Vector3;

use super::parts::{parts, parts_in_turn, planned_ahead};
use super::section::{as_asked_pace, planned_as_asked};
use super::*;
use crate::geometry::{ArcBy, Pace};
use crate::plan::course::Course;
use crate::plan::part::plan_start;
use crate::plan::sampled::Sampled;
use crate::robot::{Method, OverSpeed, Ramp, seed_robot};
use crate::table::FrequencyModel;

const P1: [f64; 3] = [-926.57, 535.03, 50.0];
const P2: [f64; 3] = [-1144.43, 659.60, 186.60];

fn pose(p: [f64; 3], dz: f64) -> Pose {
    Pose::from_mm_deg(p[0], p[1], p[2] + dz, 0.0)
}

fn motion(robot: &Robot, method: Method, model: FrequencyModel) -> Motion {
    Motion {
        method,
        frequency_model: model,
        ..robot.motion
    }
}

/// A pick and place on the seed robot through `waypoints` (then down to P2), every
/// waypoint `corner`.
fn cycle(
    waypoints: &[Pose],
    corner: Corner,
    method: Method,
    model: FrequencyModel,
) -> Result<PathPlan, PlanError> {
    let robot = seed_robot();
    let mut elements: Vec<_> = waypoints
        .iter()
        .map(|&to| (Element::Line { to }, corner))
        .collect();
    elements.push((Element::Line { to: pose(P2, 0.0) }, Corner::Stop));
    let req = PathRequest {
        from: Origin::Pose(pose(P1, 0.0)),
        start: None,
        elements,
        motion: motion(&robot, method, model),
        path_accel_mm_s2: 5_000.0,
    };
    plan_path(&robot, &req)
}

/// From P1 to `via`, a 20 mm blend there, on to `to`, at `motion` (5000 mm/s^2 on arcs).
fn blended_via(via: Pose, to: Pose, motion: Motion) -> PathRequest {
    PathRequest {
        from: Origin::Pose(pose(P1, 0.0)),
        start: None,
        elements: vec![
            (Element::Line { to: via }, Corner::Blend(20.0)),
            (Element::Line { to }, Corner::Stop),
        ],
        motion,
        path_accel_mm_s2: 5_000.0,
    }
}

/// From P1 up and across to 100 mm above P2, a 20 mm blend there, down to P2, at `motion`.
fn over_p2(motion: Motion) -> PathRequest {
    blended_via(pose(P2, 100.0), pose(P2, 0.0), motion)
}

/// `req`'s one section (planned as `plan`) run on the pace a trapezoid would have (as an
/// S-curve was before stop 40): its duration and the tool's largest jerk along it.
fn on_trapezoid_pace(robot: &Robot, req: &PathRequest, plan: &PathPlan) -> (f64, f64) {
    let section = &plan.sections[0].path;
    let start = Start::at(robot, req.from).unwrap();
    let pace = as_asked_pace(robot, section, &start, &req.motion, req.path_accel_mm_s2);
    let course = Course::Path {
        path: section.clone(),
        pace,
    };
    let starts = parts(robot, &course, &start, req.motion).unwrap();
    let jerk = starts
        .iter()
        .map(crate::testing::course_jerk)
        .fold(0.0, f64::max);
    (starts.iter().map(Plan::duration_s).sum(), jerk)
}

#[test]
fn a_blended_cycle_is_one_section_within_tolerance_ends_on_p2_and_beats_stops() {
    let robot = seed_robot();
    let target = robot.counts_of(&robot.kinematics.ik(&pose(P2, 0.0), None).unwrap());
    let bounded = Method::BoundedError { tolerance_mm: 0.05 };
    // Up and across at once to above P2, then down.
    let above = [pose(P2, 100.0)];
    for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
        let blended = cycle(&above, Corner::Blend(20.0), bounded, model).unwrap();
        assert_eq!(blended.sections.len(), 1);
        assert!(blended.valid());
        let deviation = blended.max_deviation_mm();
        assert!(deviation <= 0.05, "{model:?}: {deviation} mm");
        assert_eq!(blended.sections[0].end_counts(), target);
        // The blend is an arc of the planned path.
        let arcs = blended.path.pieces().iter().filter(|p| p.element.is_none());
        assert_eq!(arcs.count(), 1);
        let stopped = cycle(&above, Corner::Stop, bounded, model).unwrap();
        assert_eq!(stopped.sections.len(), 2);
        assert_eq!(stopped.sections[1].end_counts(), target);
        // The second section starts from the counts the first ends on.
        assert_eq!(
            stopped.sections[1].starts[0].samples.counts[0],
            stopped.sections[0].end_counts()
        );
        assert!(
            blended.duration_s() < stopped.duration_s(),
            "{} s blended, {} s stopped",
            blended.duration_s(),
            stopped.duration_s()
        );
    }
}

#[test]
fn a_straight_lift_blended_into_the_traverse_is_cut_where_a_joint_starts_late_and_chains_exactly() {
    // Straight up from P1: the base and radial joints stand still until the blend, longer
    // than one table can hold them back within 0.05 mm, so the section is cut just before
    // the first of them moves.
    let robot = seed_robot();
    let lift = [pose(P1, 100.0), pose(P2, 100.0)];
    let target = robot.counts_of(&robot.kinematics.ik(&pose(P2, 0.0), None).unwrap());
    let bounded = Method::BoundedError { tolerance_mm: 0.05 };
    for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
        let blended = cycle(&lift, Corner::Blend(20.0), bounded, model).unwrap();
        assert_eq!(blended.sections.len(), 1);
        let starts = &blended.sections[0].starts;
        assert!(starts.len() >= 2, "{model:?}: {} starts", starts.len());
        assert!(blended.valid());
        assert!(
            blended.max_deviation_mm() <= 0.05,
            "{model:?}: {} mm",
            blended.max_deviation_mm()
        );
        // The first part is the lift alone: the base and radial joints have nothing to play
        // in it.
        assert!(starts[0].tables[0].segments.is_empty());
        assert!(starts[0].tables[2].segments.is_empty());
        assert!(!starts[1].tables[0].segments.is_empty());
        for pair in starts.windows(2) {
            // Every part begins on exactly the counts the one before ends on, at the
            // instant it ends, and only the last ends at rest.
            assert_eq!(pair[1].start_counts(), pair[0].end_counts());
            assert!((pair[1].window.from_s - pair[0].window.to_s).abs() < 1e-12);
            assert!(pair[0].window.ends_at_speed && pair[1].window.begins_at_speed());
            assert!(pair[0].duration_s() >= MIN_PART_S - 1e-9);
        }
        assert!(!starts[starts.len() - 1].window.ends_at_speed);
        assert_eq!(blended.sections[0].end_counts(), target);
        // Every channel plays each part in one segment (a later one would start up to a PLC
        // scan late, while the others run on): the radial joint starts from rest in the
        // second part and reaches 18 kHz, past range 0's 9.8 kHz, in one; d2 reverses at the
        // top of the second blend, where the section is cut.
        for (k, start) in starts.iter().enumerate() {
            for table in &start.tables {
                assert!(
                    table.segments.len() <= 1,
                    "{model:?}: part {k} channel {} has {} segments",
                    table.channel,
                    table.segments.len()
                );
            }
        }
        assert_eq!(
            starts.len(),
            3,
            "{model:?}: the lift, to d2's reversal, the rest"
        );
        let stopped = cycle(&lift, Corner::Stop, bounded, model).unwrap();
        assert_eq!(stopped.sections.len(), 3);
        assert!(stopped.max_deviation_mm() <= 0.05);
        assert!(
            blended.duration_s() < stopped.duration_s(),
            "{} s blended, {} s stopped",
            blended.duration_s(),
            stopped.duration_s()
        );
    }
}

#[test]
fn a_section_too_long_for_one_table_area_is_split_into_parts_that_fit() {
    let mut robot = seed_robot();
    let bounded = Method::BoundedError { tolerance_mm: 0.05 };
    let whole = cycle(
        &[pose(P2, 100.0)],
        Corner::Blend(20.0),
        bounded,
        FrequencyModel::Ideal,
    )
    .unwrap();
    // Up and across, then down: d2 reverses at the top of the blend while the others move,
    // so the section is two parts.
    let whole_starts = whole.sections[0].starts.len();
    assert_eq!(whole_starts, 2);
    let words = whole.sections[0]
        .starts
        .iter()
        .flat_map(|start| start.tables.iter().map(crate::table::encoded_words))
        .max()
        .unwrap();
    // Areas a little over half of what the largest table needs.
    let area = words / 2 + 10;
    robot.area_words = area;
    let req = over_p2(motion(&robot, bounded, FrequencyModel::Ideal));
    let split = plan_path(&robot, &req).unwrap_or_else(|e| panic!("area {area}: {e}"));
    let starts = &split.sections[0].starts;
    assert!(starts.len() > whole_starts + 1, "{} starts", starts.len());
    for (k, plan) in starts.iter().enumerate() {
        for (j, table) in plan.tables.iter().enumerate() {
            if !table.segments.is_empty() {
                let used = crate::table::encoded_words(table);
                assert!(used <= area, "start {k} joint {j}: {used} words > {area}");
            }
        }
    }
    for pair in starts.windows(2) {
        assert_eq!(pair[1].start_counts(), pair[0].end_counts());
    }
    assert!(
        split.max_deviation_mm() <= 0.05,
        "{}",
        split.max_deviation_mm()
    );
    assert_eq!(
        split.sections[0].end_counts(),
        whole.sections[0].end_counts()
    );
    // An area too small for any part of at least MIN_PART_S is refused naming the joint.
    robot.area_words = 30;
    let req = PathRequest {
        motion: motion(&robot, bounded, FrequencyModel::Ideal),
        ..req
    };
    let msg = plan_path(&robot, &req).unwrap_err().to_string();
    assert!(
        msg.starts_with("path section 1 (element 1-2): joint "),
        "{msg}"
    );
}

#[test]
fn a_half_circle_is_planned_within_tolerance_and_slowed_for_its_radius() {
    let robot = seed_robot();
    let from = pose(P1, 0.0);
    let centre = from.position_mm - Vector3::new(100.0, 0.0, 0.0);
    let to = Pose {
        position_mm: centre - Vector3::new(100.0, 0.0, 0.0),
        a_rad: 0.0,
    };
    let req = |method, accel| PathRequest {
        from: Origin::Pose(from),
        start: None,
        elements: vec![(
            Element::Arc {
                to,
                by: ArcBy::Centre {
                    centre_mm: centre,
                    axis: Vector3::z(),
                    clockwise: false,
                },
            },
            Corner::Stop,
        )],
        motion: motion(&robot, method, FrequencyModel::FpxDivider),
        path_accel_mm_s2: accel,
    };
    let bounded = Method::BoundedError { tolerance_mm: 0.05 };
    let plan = plan_path(&robot, &req(bounded, 1_000.0)).unwrap();
    assert!(
        plan.max_deviation_mm() <= 0.05,
        "{}",
        plan.max_deviation_mm()
    );
    assert!((plan.path.length_mm() - 100.0 * std::f64::consts::PI).abs() < 1e-9);
    let whole = plan.path.length_mm();
    let cruise = plan.sections[0].starts[0].cruise_mm_s(0.0, whole);
    assert!(cruise > 239.0 && cruise <= 240.0, "{cruise} mm/s");
    // 100 mm/s^2 on r = 100 mm allows 100 mm/s, all the way round.
    let slow = plan_path(&robot, &req(bounded, 100.0)).unwrap();
    let start = &slow.sections[0].starts[0];
    let speed = start.cruise_mm_s(0.0, whole);
    assert!(speed > 99.0 && speed <= 100.0 + 1e-9, "{speed} mm/s");
    assert!(slow.duration_s() > whole / 100.0);
    let err = plan_path(&robot, &req(bounded, 0.0)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "the path acceleration 0 mm/s^2 must be a number above 0"
    );
}

#[test]
fn a_tight_blend_slows_the_tool_on_it_alone_within_the_centripetal_limit() {
    // Up and across to above P2, a 20 mm blend turning 133 deg (radius 8.6 mm), down to P2:
    // 5000 mm/s^2 allows 207.7 mm/s on the blend; the lines run at 240 mm/s.
    let accel = 5_000.0;
    for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
        let bounded = Method::BoundedError { tolerance_mm: 0.05 };
        let plan = cycle(&[pose(P2, 100.0)], Corner::Blend(20.0), bounded, model).unwrap();
        assert!(plan.valid());
        assert!(plan.max_deviation_mm() <= 0.05, "{model:?}");
        let blend = plan.path.pieces()[1];
        assert!(blend.element.is_none());
        let r = 1.0 / blend.primitive.curvature_per_mm();
        let allowed = (accel * r).sqrt();
        let (b0, b1) = (blend.start_mm, blend.start_mm + blend.primitive.length_mm());
        // The planned tool speed, by finite differences of the planned positions along every
        // start's time.
        let mut fastest_on_blend: f64 = 0.0;
        let mut fastest: f64 = 0.0;
        let dt = 1e-4;
        for start in plan.starts() {
            let steps = (start.duration_s() / dt) as usize;
            for i in 0..steps {
                let t = i as f64 * dt;
                let (p, q) = (
                    start.planned_position_mm(t),
                    start.planned_position_mm(t + dt),
                );
                let speed = (q - p).norm() / dt;
                let s = start.course_mm(start.window.from_s + t);
                if s > b0 && s < b1 {
                    fastest_on_blend = fastest_on_blend.max(speed);
                }
                fastest = fastest.max(speed);
            }
        }
        assert!(
            fastest_on_blend <= allowed * (1.0 + 1e-6),
            "{model:?}: {fastest_on_blend} mm/s on the blend, {allowed} allowed"
        );
        assert!(fastest_on_blend > allowed * 0.99, "{fastest_on_blend}");
        assert!(fastest > 239.0, "{model:?}: the lines at {fastest} mm/s");
        // The whole section slowed to the blend's speed would take longer.
        let length = plan.path.length_mm();
        assert!(
            plan.duration_s() < length / allowed,
            "{} s for {length} mm",
            plan.duration_s()
        );
    }
}

/// An S-curve through a blend too tight for its speed is the time-optimal motion averaged
/// to its jerk: slowed for the blend alone, within its jerk, where on the trapezoid's pace
/// (as it was) its change of speed into the blend passed the jerk many times over.
#[test]
fn an_s_curve_through_a_tight_blend_slows_for_it_alone_and_keeps_its_jerk() {
    // The blend of the test above: 207.7 mm/s allowed on it, 240 mm/s on the lines.
    let robot = seed_robot();
    let jerk_mm_s3 = 20_000.0;
    for method in [
        Method::ConstantPeriod,
        Method::BoundedError { tolerance_mm: 0.05 },
    ] {
        let req = over_p2(Motion {
            ramp: Ramp::SCurve { jerk_mm_s3 },
            ..motion(&robot, method, FrequencyModel::FpxDivider)
        });
        let plan = plan_path(&robot, &req).unwrap();
        assert!(plan.valid(), "{method:?}");
        for start in plan.starts() {
            let jerk = crate::testing::course_jerk(start);
            assert!(jerk <= jerk_mm_s3 * 1.05, "{method:?}: {jerk} mm/s^3");
            assert!(
                start.pace.as_ref().is_some_and(Pace::from_rest),
                "{method:?}"
            );
        }
        // Along the course: within the blend's speed on it, at the speed asked on a line.
        let blend = plan.path.pieces()[1];
        let allowed = (req.path_accel_mm_s2 / blend.primitive.curvature_per_mm()).sqrt();
        let (b0, b1) = (blend.start_mm, blend.start_mm + blend.primitive.length_mm());
        let (mut on_blend, mut fastest) = (0.0_f64, 0.0_f64);
        for start in plan.starts() {
            let at = |t: f64| start.course_mm(start.window.from_s + t);
            let dt = 1e-4;
            for i in 0..(start.duration_s() / dt) as usize {
                let t = i as f64 * dt;
                let speed = (at(t + dt) - at(t)) / dt;
                if (b0..b1).contains(&at(t)) {
                    on_blend = on_blend.max(speed);
                }
                fastest = fastest.max(speed);
            }
        }
        assert!(on_blend <= allowed * (1.0 + 1e-6), "{method:?}: {on_blend}");
        assert!(fastest > 239.0, "{method:?}: the lines at {fastest} mm/s");
        // On the trapezoid's pace.
        let (_, stepped_jerk) = on_trapezoid_pace(&robot, &req, &plan);
        assert!(
            stepped_jerk > 3.0 * jerk_mm_s3,
            "{method:?}: {stepped_jerk}"
        );
    }
}

/// The seed robot with d2 (the lift, 40 pulses/mm) limited to 6 kHz, 150 mm/s straight up,
/// and a lift of 100 mm blended into a level traverse of about 250 mm at 240 mm/s asked:
/// the request for `motion` (its method, `over_speed` and ramp taken).
fn lift_and_traverse() -> (Robot, impl Fn(Method, OverSpeed, Ramp) -> PathRequest) {
    let mut robot = seed_robot();
    robot.joints[1].max_freq_hz = 6_000;
    let asked = robot.motion;
    let level = Pose::from_mm_deg(P2[0], P2[1], P1[2] + 100.0, 0.0);
    let req = move |method, over_speed, ramp| {
        let motion = Motion {
            method,
            frequency_model: FrequencyModel::FpxDivider,
            over_speed,
            ramp,
            ..asked
        };
        blended_via(pose(P1, 100.0), level, motion)
    };
    (robot, req)
}

#[test]
fn under_slow_down_a_joint_too_fast_on_one_stretch_slows_the_tool_there_alone() {
    let (robot, lift) = lift_and_traverse();
    let bounded = Method::BoundedError { tolerance_mm: 0.05 };
    let req = |over_speed| lift(bounded, over_speed, Ramp::Trapezoid);
    let err = plan_path(&robot, &req(OverSpeed::Reject)).unwrap_err();
    assert!(err.to_string().contains("d2"), "{err}");
    let plan = plan_path(&robot, &req(OverSpeed::SlowDown)).unwrap();
    assert!(plan.valid());
    assert!(
        plan.max_deviation_mm() <= 0.05,
        "{}",
        plan.max_deviation_mm()
    );
    // No channel past its top frequency in the execution model.
    for start in plan.starts() {
        for row in start.row_timings() {
            let limit = f64::from(robot.joints[row.table].max_freq_hz);
            assert!(row.actual_hz <= limit, "{row:?}");
        }
        // The whole section was not slowed: its profile cruises at the speed asked.
        assert!(start.speed_factor > 0.99, "{}", start.speed_factor);
    }
    let first = plan.starts().next().unwrap();
    let lift = first.cruise_mm_s(0.0, 50.0);
    assert!(lift < 150.0 && lift > 140.0, "the lift at {lift} mm/s");
    let length = plan.path.length_mm();
    let traverse = plan
        .starts()
        .last()
        .unwrap()
        .cruise_mm_s(length - 100.0, length - 50.0);
    assert!(traverse > 239.0, "the traverse at {traverse} mm/s");
    // Faster than the whole section slowed to the lift's speed could be.
    assert!(
        plan.duration_s() < length / 150.0,
        "{} s",
        plan.duration_s()
    );
}

/// An S-curve that must slow on a stretch (under `slow-down`, where a channel would be too
/// fast) is the time-optimal motion averaged to its jerk: a trapezoid's pace steps its
/// acceleration on and off into the slow stretch, past any jerk (an S-curve run on that
/// pace read 7.4 times its jerk on a line in the heavy properties, before). Slowed as a
/// whole, it would keep its jerk too, but take longer; run on that pace, it takes about as
/// long.
#[test]
fn under_slow_down_an_s_curve_slows_on_the_stretch_alone_and_keeps_its_jerk() {
    let (robot, lift) = lift_and_traverse();
    let jerk_mm_s3 = 5_000.0;
    for method in [
        Method::ConstantPeriod,
        Method::BoundedError { tolerance_mm: 0.05 },
    ] {
        let req = |ramp| lift(method, OverSpeed::SlowDown, ramp);
        let trapezoid = plan_path(&robot, &req(Ramp::Trapezoid)).unwrap();
        let s_curve_req = req(Ramp::SCurve { jerk_mm_s3 });
        let s_curve = plan_path(&robot, &s_curve_req).unwrap();
        assert!(trapezoid.valid() && s_curve.valid(), "{method:?}");
        for start in s_curve.starts() {
            let jerk = crate::testing::course_jerk(start);
            assert!(jerk <= jerk_mm_s3 * 1.05, "{method:?}: {jerk} mm/s^3");
            for row in start.row_timings() {
                let limit = f64::from(robot.joints[row.table].max_freq_hz);
                assert!(row.actual_hz <= limit, "{method:?} {row:?}");
            }
        }
        // The trapezoid's change into its slow stretch is far past that jerk.
        let stepped = trapezoid
            .starts()
            .map(crate::testing::course_jerk)
            .fold(0.0, f64::max);
        assert!(stepped > 10.0 * jerk_mm_s3, "{method:?}: {stepped} mm/s^3");
        // Slowed as a whole (what the sampled check does to an S-curve run as asked, no
        // longer slowed on the stretch), it keeps its jerk, and takes longer.
        let section = &s_curve.sections[0];
        let start = Start::at(&robot, s_curve_req.from).unwrap();
        let whole = planned_as_asked(
            &robot,
            &section.path,
            &start,
            s_curve_req.motion,
            s_curve_req.path_accel_mm_s2,
        )
        .unwrap();
        let whole_s: f64 = whole.iter().map(Plan::duration_s).sum();
        assert!(whole[0].speed_factor < 0.7, "{}", whole[0].speed_factor);
        for start in &whole {
            let jerk = crate::testing::course_jerk(start);
            assert!(jerk <= jerk_mm_s3 * 1.05, "{method:?}: {jerk} mm/s^3");
        }
        assert!(
            s_curve.duration_s() < 0.9 * whole_s,
            "{method:?}: {} s against {whole_s} s",
            s_curve.duration_s()
        );
        assert!(s_curve.duration_s() > trapezoid.duration_s(), "{method:?}");
        // Run on the trapezoid's pace (as it was), the S-curve passed its jerk many times
        // over, and took hardly less time: the average passes d2's top frequency after
        // the lift, and is timed again to the share of it the sampled check leaves.
        let (stepped_s, stepped_jerk) = on_trapezoid_pace(&robot, &s_curve_req, &s_curve);
        assert!(
            stepped_jerk > 10.0 * jerk_mm_s3,
            "{method:?}: {stepped_jerk}"
        );
        assert!(
            s_curve.duration_s() < 1.04 * stepped_s,
            "{method:?}: {} s against {stepped_s} s",
            s_curve.duration_s()
        );
    }
}

/// A part refused for its tolerance is cut again, without the planner searching for a
/// tolerance that works; one that reaches the user names it, and it does plan the path.
#[test]
fn a_path_tolerance_below_the_pulse_grid_is_refused_naming_one_that_plans_it() {
    let above = [pose(P2, 100.0)];
    let asked = Method::BoundedError { tolerance_mm: 0.01 };
    let model = FrequencyModel::FpxDivider;
    let refused = cycle(&above, Corner::Blend(20.0), asked, model).unwrap_err();
    let PlanError::Section { source, .. } = &refused else {
        panic!("{refused}")
    };
    let PlanError::ToleranceTooSmall {
        floor_mm,
        works_mm: Some(works_mm),
        ..
    } = **source
    else {
        panic!("{refused}")
    };
    assert!(floor_mm > 0.01 && works_mm > floor_mm, "{refused}");
    assert!(
        refused
            .to_string()
            .contains(&format!("{works_mm} mm works"))
    );
    let works = Method::BoundedError {
        tolerance_mm: works_mm,
    };
    let plan = cycle(&above, Corner::Blend(20.0), works, model).unwrap();
    assert!(plan.valid() && plan.max_deviation_mm() <= works_mm);
}

#[test]
fn a_section_that_leaves_a_joint_limit_is_refused_naming_its_elements() {
    let robot = seed_robot();
    let line = |to| Element::Line { to };
    let req = PathRequest {
        from: Origin::Pose(pose(P1, 0.0)),
        start: None,
        elements: vec![
            (line(pose(P1, 100.0)), Corner::Stop),
            (line(pose(P2, 100.0)), Corner::Blend(10.0)),
            (line(pose(P2, 2_000.0)), Corner::Stop),
        ],
        motion: motion(&robot, Method::ConstantPeriod, FrequencyModel::Ideal),
        path_accel_mm_s2: 2_000.0,
    };
    let msg = plan_path(&robot, &req).unwrap_err().to_string();
    assert!(msg.starts_with("path section 2 (element 2-3): "), "{msg}");
}

#[test]
fn parts_planned_side_by_side_are_the_parts_planned_in_turn() {
    let robot = seed_robot();
    // Up and down three times, blended: d2 reverses at every blend, so the section is cut
    // into parts there.
    let elements = (1..=4)
        .map(|k| {
            let z = if k % 2 == 1 { 220.0 } else { 100.0 };
            let to = Pose::from_mm_deg(-800.0 + 160.0 * f64::from(k), 900.0, z, 0.0);
            let corner = if k == 4 {
                Corner::Stop
            } else {
                Corner::Blend(20.0)
            };
            (Element::Line { to }, corner)
        })
        .collect();
    let from = Pose::from_mm_deg(-800.0, 900.0, 100.0, 0.0);
    let start = Start::at(&robot, Origin::Pose(from)).unwrap();
    let spec = PathSpec {
        start: robot.kinematics.fk(&start.values),
        elements,
    };
    let section = Path::build(&spec).unwrap().sections().remove(0);
    let asked = motion(
        &robot,
        Method::BoundedError { tolerance_mm: 0.05 },
        FrequencyModel::FpxDivider,
    );
    let pace = Pace::new(
        &section,
        asked.speed_mm_s,
        5_000.0,
        asked.speed_mm_s / asked.accel_s,
        &[],
    );
    let course = Course::Path {
        path: section,
        pace,
    };
    let sampled = Sampled::new(&robot, &course, &start, asked).unwrap();
    let ahead = planned_ahead(&sampled, start.counts);
    assert!(ahead.len() >= 3, "{} parts planned ahead", ahead.len());

    let in_turn = parts_in_turn(&robot, &sampled, &start, Vec::new()).unwrap();
    let side_by_side = parts_in_turn(&robot, &sampled, &start, ahead).unwrap();
    assert_eq!(side_by_side, in_turn);

    // Parts planned ahead from counts the part before does not end on are planned again.
    let mut wrong = planned_ahead(&sampled, start.counts);
    for a in &mut wrong {
        a.counts[1] += 1;
        a.plan = plan_start(&sampled, a.first, a.end, a.counts);
    }
    assert!(
        wrong
            .iter()
            .any(|a| a.plan.as_ref().is_ok_and(|p| !in_turn.contains(p)))
    );
    assert_eq!(
        parts_in_turn(&robot, &sampled, &start, wrong).unwrap(),
        in_turn
    );
}

#[test]
fn a_part_too_short_to_chain_behind_is_a_stop_instead() {
    // `demo --pallet`'s way into slot 19 (layer 4, turned): from the pick point, the tool at
    // 140 degrees, to 80 mm above the slot, turned half a turn. d2 slows into its reversal:
    // its last row before it needs a later segment (cut there) and it reverses a sample
    // later (cut there): a part of one sample, 50 ms, which no link can chain behind.
    let mut robot = seed_robot();
    robot.motion.over_speed = OverSpeed::SlowDown;
    let pick = Pose::from_mm_deg(-900.0, 450.0, 120.0, 140.0);
    let above = Pose::from_mm_deg(-250.0, 780.0, 350.0, -40.0);
    let req = PathRequest {
        from: Origin::Pose(pick),
        start: None,
        elements: vec![(Element::Line { to: above }, Corner::Stop)],
        motion: robot.motion,
        path_accel_mm_s2: robot.motion.speed_mm_s / robot.motion.accel_s,
    };
    let start = Start::at(&robot, req.from).unwrap();
    let line = Path::build(&PathSpec {
        start: pick,
        elements: req.elements.clone(),
    })
    .unwrap();
    let chained = section::plan(&robot, &line, &start, req.motion, req.path_accel_mm_s2).unwrap();
    let short = |starts: &[Plan]| {
        starts[..starts.len() - 1]
            .iter()
            .any(|p| p.duration_s() < MIN_PART_S - 1e-9)
    };
    assert!(short(&chained), "{:?}", durations(&chained));

    let planned = plan_path(&robot, &req).unwrap();
    assert!(
        planned.sections.len() >= 2,
        "{} sections",
        planned.sections.len()
    );
    for s in &planned.sections {
        assert!(!short(&s.starts), "{:?}", durations(&s.starts));
        assert!(!s.starts[s.starts.len() - 1].window.ends_at_speed);
    }
    // The stop lies on the line, the sections follow each other and end where the line does.
    let mut along_mm = 0.0;
    for pair in planned.sections.windows(2) {
        assert_eq!(pair[1].starts[0].start_counts(), pair[0].end_counts());
        along_mm += pair[0].path.length_mm();
        let stop = pair[1].path.at(0.0).position_mm;
        assert!((stop - line.at(along_mm).position_mm).norm() < 1e-6);
    }
    let total_mm: f64 = planned.sections.iter().map(|s| s.path.length_mm()).sum();
    assert!((total_mm - line.length_mm()).abs() < 1e-6);
    assert_eq!(
        planned.sections[planned.sections.len() - 1].end_counts(),
        chained[chained.len() - 1].end_counts()
    );
    assert!(planned.valid());
}

fn durations(starts: &[Plan]) -> Vec<f64> {
    starts.iter().map(Plan::duration_s).collect()
}
