//! The drive limits on the seed's robot and a cylindrical robot with a short arm: the seed's
//! move, a line past the base axis, a joint move, a path with arcs.

use std::fmt::Write as _;

use crate::geometry::{Corner, Element, Pose};
use crate::kinematics::Kinematics;
use crate::plan::{
    JointMoveRequest, MovePlan, MoveRequest, Origin, PathRequest, Plan, PlanError, plan_joint_move,
    plan_line, plan_move, plan_path,
};
use crate::robot::short_arm;
use crate::robot::{Dynamics, Method, Motion, OverSpeed, Ramp, Robot, seed_robot};
use crate::table::FrequencyModel;

const BOUNDED: Method = Method::BoundedError { tolerance_mm: 0.05 };

/// `robot` with every joint's `max_accel` (user units/s^2) and `start_hz`.
fn limited(mut robot: Robot, accel_user: [f64; 4], start_hz: [Option<f64>; 4]) -> Robot {
    for (j, joint) in robot.joints.iter_mut().enumerate() {
        joint.dynamics = Dynamics {
            max_accel: Some(joint.kind.from_user(accel_user[j])),
            start_hz: start_hz[j],
            max_jerk: None,
        };
    }
    robot
}

/// The seed's robot with a radial drive that follows 1000 mm/s^2 and starts at 1 kHz.
fn seed_limited() -> Robot {
    limited(
        seed_robot(),
        [200.0, 1_000.0, 1_000.0, 200.0],
        [None, None, Some(1_000.0), None],
    )
}

fn seed_move(robot: &Robot, method: Method, model: FrequencyModel) -> MoveRequest {
    let mut req = crate::plan::tests::seed_request(model, false);
    req.motion = Motion {
        method,
        frequency_model: model,
        ..robot.motion
    };
    req
}

/// The step between neighbouring frequencies at `hz` in a range with divider clock `clock_hz`:
/// 1 Hz of the written value under the ideal model, `c/d - c/(d+1)`, about `hz^2 / c`, under
/// the divider.
fn grain_hz(model: FrequencyModel, clock_hz: f64, hz: f64) -> f64 {
    match model {
        FrequencyModel::Ideal => 1.0,
        FrequencyModel::FpxDivider => 1.0 + 1.1 * hz * hz / clock_hz,
    }
}

/// Every row of every table of `plan` within its joint's limits, checked from the execution
/// model's rows (the rule of `rows.rs`, written again from its documentation).
fn assert_rows_within(robot: &Robot, plan: &Plan) {
    let run = plan.execution();
    let model = plan.motion.frequency_model;
    for (j, joint) in robot.joints.iter().enumerate() {
        let rows: Vec<_> = run.rows.iter().filter(|r| r.table == j).collect();
        let a = joint.dynamics.max_accel.map(|a| a / joint.step.abs());
        let grain = |r: &crate::sim::RowTiming| {
            let clock = plan.tables[j].segments[r.segment]
                .control
                .range
                .divider_clock_hz();
            grain_hz(model, clock, r.actual_hz)
        };
        for (k, r) in rows.iter().enumerate() {
            assert!(r.actual_hz <= f64::from(joint.max_freq_hz) + 1e-9);
            let len = r.end_s - r.start_s;
            let first = k == 0 && !plan.window.begins_at_speed();
            let last = k + 1 == rows.len() && !plan.window.ends_at_speed;
            if first || last {
                if let Some(hz) = joint.dynamics.start_hz {
                    assert!(
                        r.actual_hz <= hz,
                        "{}: row {k} at {} Hz",
                        joint.name,
                        r.actual_hz
                    );
                }
                if let Some(a) = a {
                    let hz = a * len / 2.0 + 1.0 / len + grain(r);
                    assert!(r.actual_hz <= hz, "{}: row {k}", joint.name);
                }
            }
            if k > 0
                && let Some(a) = a
            {
                let b = rows[k - 1];
                let (lb, lr) = (b.end_s - b.start_s, len);
                let allowed = a * (lb + lr) / 2.0 + 1.0 / lb + 1.0 / lr + grain(b) + grain(r);
                let step = (r.actual_hz - b.actual_hz).abs();
                assert!(
                    step <= allowed,
                    "{}: rows {} and {k} step {step} Hz, {allowed} allowed",
                    joint.name,
                    k - 1
                );
            }
        }
    }
}

#[test]
fn the_seed_move_under_drive_limits_keeps_every_row_within_them_at_little_cost() {
    // Without limits the radial joint starts at about 2 kHz from rest: a drive that starts at
    // 1 kHz would lose steps there.
    let free = seed_robot();
    let unlimited = plan_move(
        &free,
        &seed_move(&free, free.motion.method, FrequencyModel::FpxDivider),
    )
    .unwrap();
    assert!(
        unlimited.drive[2].rest_hz > 1_900.0,
        "{:?}",
        unlimited.drive[2]
    );
    let robot = seed_limited();
    for method in [Method::ConstantPeriod, BOUNDED] {
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let plan = plan_move(&robot, &seed_move(&robot, method, model)).unwrap();
            assert!(plan.valid(), "{method:?} {model:?}: {:?}", plan.problems);
            assert_rows_within(&robot, &plan);
            let d3 = plan.drive[2];
            assert!(d3.rest_hz <= 1_000.0, "{method:?} {model:?}: {d3:?}");
            assert!(d3.step_load.unwrap() <= 1.0, "{method:?} {model:?}: {d3:?}");
            assert!(
                d3.peak_accel <= 1_000.0 * 1.05,
                "{method:?} {model:?}: {d3:?}"
            );
            // The speed drops only where the limits need it: the ramps.
            let cost = plan.duration_s() / unlimited.duration_s();
            assert!((1.0..1.2).contains(&cost), "{method:?} {model:?}: {cost}");
            if let Some(tolerance_mm) = method.tolerance_mm() {
                assert!(
                    plan.figures.path_deviation_mm <= tolerance_mm,
                    "{:?}",
                    plan.figures
                );
            }
            assert_eq!(
                plan.end_counts(),
                robot.counts_of(
                    &robot
                        .kinematics
                        .ik(&seed_move(&robot, method, model).to, None)
                        .unwrap()
                )
            );
        }
    }
}

#[test]
fn without_drive_limits_the_seed_move_plans_the_tables_it_always_did() {
    // The tables of the seed's move at the commit before drive limits, both methods and both
    // frequency models: a robot with no `max_accel` and no `start_hz` takes the same road.
    let robot = seed_robot();
    let mut text = String::new();
    for method in [Method::ConstantPeriod, BOUNDED] {
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let plan = plan_move(&robot, &seed_move(&robot, method, model)).unwrap();
            writeln!(text, "{method:?} {model:?}\n{:?}", plan.tables).unwrap();
        }
    }
    let golden = include_str!("seed_tables.golden");
    if std::env::var_os("LINTERPD_WRITE_GOLDEN").is_some() {
        std::fs::write("src/plan/dynamics/seed_tables.golden", &text).unwrap();
    }
    assert!(text == golden, "the seed's tables changed");
}

/// A line 100 mm from the axis, 400 mm long, ending where it comes nearest the axis (no joint
/// reverses: one start).
fn to_the_axis(robot: &Robot, method: Method) -> MoveRequest {
    let from = robot.pose_with_wrist_at_zero(-400.0, 100.0, 100.0).unwrap();
    let mut to = Pose::from_mm_deg(0.0, 100.0, 100.0, 0.0);
    to.a_rad = from.a_rad;
    MoveRequest {
        from: Origin::Pose(from),
        to,
        motion: Motion {
            method,
            ..robot.motion
        },
    }
}

fn total_s(plan: &MovePlan) -> f64 {
    plan.starts().map(Plan::duration_s).sum()
}

#[test]
fn a_line_to_the_axis_slows_near_the_axis_alone_where_slow_down_slows_it_all() {
    // Whole-move slow-down: today's answer for a line of one start without drive limits.
    let whole = short_arm(OverSpeed::SlowDown);
    let slowed = plan_line(&whole, &to_the_axis(&whole, Method::ConstantPeriod)).unwrap();
    assert!(matches!(slowed, MovePlan::One(ref p) if p.speed_factor < 0.5));
    // Drive limits (generous accelerations) time the line along it instead.
    let robot = limited(
        short_arm(OverSpeed::SlowDown),
        [2_000.0, 5_000.0, 5_000.0, 2_000.0],
        [None; 4],
    );
    for method in [Method::ConstantPeriod, BOUNDED] {
        let timed = plan_line(&robot, &to_the_axis(&robot, method)).unwrap();
        for plan in timed.starts() {
            assert!(plan.valid(), "{method:?}");
            assert_rows_within(&robot, plan);
            assert!(plan.drive[0].peak_hz <= 20_000.0);
        }
        let gain = total_s(&slowed) / total_s(&timed);
        assert!(
            gain > 1.5,
            "{method:?}: {} s timed, {} s slowed",
            total_s(&timed),
            total_s(&slowed)
        );
        // Away from the axis the tool runs at the speed asked.
        let first = timed.starts().next().unwrap();
        let at = first.time_at_course_mm(100.0);
        let speed = (first.course_mm(at + 0.01) - first.course_mm(at - 0.01)) / 0.02;
        assert!(
            speed > 0.98 * 240.0 * first.speed_factor,
            "{method:?}: {speed}"
        );
    }
}

/// Under bounded-error rows are of any length: a standstill's zone is planned for the row from
/// rest that leaves the joint the most acceleration, not for a period. The seed's move with
/// d3's `start_hz` at 1000, 200 and 100 Hz: every row within every limit, the rows from and to
/// rest within `start_hz`. At 1000 Hz it is as fast as with no `start_hz` at all, and faster
/// than constant-period, whose zone lasts one and a half 50 ms periods. At 200 and 100 Hz it
/// plans; the zone of a period made d2's rows outgrow its table area and refused it.
#[test]
fn bounded_error_leaves_a_standstill_as_its_rows_allow_not_as_a_period_would() {
    let without = limited(seed_robot(), [200.0, 1_000.0, 1_000.0, 200.0], [None; 4]);
    let free_s = plan_move(
        &without,
        &seed_move(&without, BOUNDED, FrequencyModel::FpxDivider),
    )
    .unwrap()
    .duration_s();
    for (start_hz, at_most) in [(1_000.0, 1.0), (200.0, 1.1), (100.0, 1.3)] {
        let robot = limited(
            seed_robot(),
            [200.0, 1_000.0, 1_000.0, 200.0],
            [None, None, Some(start_hz), None],
        );
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let plan = plan_move(&robot, &seed_move(&robot, BOUNDED, model)).unwrap();
            assert!(plan.valid(), "{start_hz} {model:?}: {:?}", plan.problems);
            assert_rows_within(&robot, &plan);
            let d3 = plan.drive[2];
            assert!(d3.rest_hz <= start_hz, "{start_hz} {model:?}: {d3:?}");
            assert!(plan.figures.path_deviation_mm <= 0.05, "{:?}", plan.figures);
            let cost = plan.duration_s() / free_s;
            assert!(cost <= at_most + 1e-9, "{start_hz} {model:?}: x{cost}");
            if start_hz >= 1_000.0 {
                let constant =
                    plan_move(&robot, &seed_move(&robot, Method::ConstantPeriod, model)).unwrap();
                assert!(
                    plan.duration_s() < 0.95 * constant.duration_s(),
                    "{} s against constant-period's {} s",
                    plan.duration_s(),
                    constant.duration_s()
                );
            }
        }
    }
}

#[test]
fn a_start_frequency_below_a_pulse_per_period_is_refused_naming_the_joint_and_the_figure() {
    // 50 ms rows carry 20 Hz of rounding on their own.
    let robot = limited(
        seed_robot(),
        [200.0, 1_000.0, 1_000.0, 200.0],
        [None, None, Some(15.0), None],
    );
    let err = plan_move(
        &robot,
        &seed_move(&robot, Method::ConstantPeriod, FrequencyModel::Ideal),
    )
    .unwrap_err();
    assert!(
        matches!(err, PlanError::StartHzTooLow { ref joint, .. } if joint == "d3"),
        "{err}"
    );
    assert!(err.to_string().contains("start_hz = 15 Hz"), "{err}");
    assert!(err.to_string().contains("20.6 Hz"), "{err}");
}

#[test]
fn a_start_frequency_on_a_joint_that_does_not_move_refuses_nothing() {
    // A vertical line moves d2 alone: theta1's start_hz of 1 Hz (below a pulse per period) has
    // no standstill to leave, while the same on d2 is refused.
    let lift = |robot: &Robot| {
        let from = robot
            .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
            .unwrap();
        let mut to = from;
        to.position_mm.z += 100.0;
        MoveRequest {
            from: Origin::Pose(from),
            to,
            motion: robot.motion,
        }
    };
    let mut robot = seed_limited();
    robot.joints[0].dynamics.start_hz = Some(1.0);
    let plan = plan_move(&robot, &lift(&robot)).unwrap();
    assert!(plan.tables[0].segments.is_empty());
    assert!(plan.valid());
    robot.joints[1].dynamics.start_hz = Some(1.0);
    let err = plan_move(&robot, &lift(&robot)).unwrap_err();
    assert!(
        matches!(err, PlanError::StartHzTooLow { ref joint, .. } if joint == "d2"),
        "{err}"
    );
}

#[test]
fn a_joint_move_under_drive_limits_keeps_one_trapezoid_within_them() {
    let robot = seed_limited();
    let start = robot
        .kinematics
        .ik(
            &robot
                .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
                .unwrap(),
            None,
        )
        .unwrap();
    let mut to = start;
    to[1] += 100.0;
    to[2] += 200.0;
    let req = |method| JointMoveRequest {
        from: Origin::Pose(robot.kinematics.fk(&start)),
        to,
        motion: Motion {
            method,
            ..robot.motion
        },
    };
    let plan = plan_joint_move(&robot, &req(Method::ConstantPeriod)).unwrap();
    let free = plan_joint_move(&seed_robot(), &req(Method::ConstantPeriod)).unwrap();
    assert!(plan.valid());
    assert_rows_within(&robot, &plan);
    assert!(plan.drive[2].rest_hz <= 1_000.0, "{:?}", plan.drive[2]);
    assert!(free.drive[2].rest_hz > 1_000.0, "{:?}", free.drive[2]);
    assert!(plan.motion.accel_s > free.motion.accel_s);
    // Bounded-error's rows from rest are as short as its windows make them: its trapezoid
    // leaves rest at d3's max_accel, not held for 50 ms rows within start_hz.
    let bounded = plan_joint_move(&robot, &req(BOUNDED)).unwrap();
    assert!(bounded.valid());
    assert_rows_within(&robot, &bounded);
    assert!(
        bounded.drive[2].rest_hz <= 1_000.0,
        "{:?}",
        bounded.drive[2]
    );
    assert!(
        bounded.motion.accel_s < plan.motion.accel_s,
        "{} s against {} s",
        bounded.motion.accel_s,
        plan.motion.accel_s
    );
}

/// A path of lines from the seed's start through `corners` (the wrist held), at `motion`, with
/// a path acceleration of 2000 mm/s^2.
fn from_the_seed_start(
    robot: &Robot,
    corners: &[([f64; 3], Corner)],
    motion: Motion,
) -> PathRequest {
    let start = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let elements = corners
        .iter()
        .map(|&([x, y, z], corner)| {
            let mut to = Pose::from_mm_deg(x, y, z, 0.0);
            to.a_rad = start.a_rad;
            (Element::Line { to }, corner)
        })
        .collect();
    PathRequest {
        from: Origin::Pose(start),
        start: None,
        elements,
        motion,
        path_accel_mm_s2: 2_000.0,
    }
}

#[test]
fn a_path_with_arcs_under_drive_limits_keeps_every_row_within_them() {
    let robot = seed_limited();
    let req = from_the_seed_start(
        &robot,
        &[
            ([-926.57, 535.03, 150.0], Corner::Blend(20.0)),
            ([-1100.0, 640.0, 150.0], Corner::Blend(20.0)),
            ([-1100.0, 640.0, 60.0], Corner::Stop),
        ],
        Motion {
            method: BOUNDED,
            ..robot.motion
        },
    );
    let plan = plan_path(&robot, &req).unwrap();
    assert!(plan.valid());
    for start in plan.starts() {
        assert_rows_within(&robot, start);
        assert!(
            start.figures.path_deviation_mm <= 0.05,
            "{:?}",
            start.figures
        );
    }
}

/// The seed's robot with a radial drive that follows only 300 mm/s^2: the seed's move's
/// S-curve asks it for about 1050.
fn seed_slow_radial() -> Robot {
    limited(
        seed_robot(),
        [200.0, 1_000.0, 300.0, 200.0],
        [None, None, Some(1_000.0), None],
    )
}

fn s_curve(robot: &Robot, method: Method, jerk_mm_s3: f64) -> MoveRequest {
    let mut req = seed_move(robot, method, FrequencyModel::FpxDivider);
    req.motion.ramp = Ramp::SCurve { jerk_mm_s3 };
    req
}

/// The seed's move's `s-curve:20000` slowed to share `k` of its accelerations, planned for
/// `robot` as it is (no slowing of the planner's own).
fn seed_s_curve_slowed(robot: &Robot, method: Method, k: f64) -> Plan {
    let asked = s_curve(robot, method, 20_000.0);
    let req = MoveRequest {
        motion: super::slowed(&asked.motion, k),
        ..asked
    };
    plan_move(robot, &req).unwrap()
}

/// The seed's move's `s-curve:20000` under `robot`'s limits slowed as a whole until the drives
/// follow it ([`crate::plan::strategy::followed`]), as it was planned before the averaged
/// motion.
fn seed_s_curve_slowed_as_a_whole(robot: &Robot, method: Method) -> Plan {
    seed_s_curve_slowed_checked(robot, method, None)
}

/// A check of a motion slowed to share `k` on its samples: `k`, every joint's planned
/// acceleration, and the speed factor `slow-down` left.
type SlowedCheck<'a> = dyn Fn(f64, &[f64; 4], f64) -> Result<(), PlanError> + 'a;

/// [`seed_s_curve_slowed_as_a_whole`], every slowed motion first checked by `check` on its
/// samples (`crate::plan::part::plan_course_checked`).
fn seed_s_curve_slowed_checked(robot: &Robot, method: Method, check: Option<&SlowedCheck>) -> Plan {
    let asked = s_curve(robot, method, 20_000.0);
    let (line, values, counts) = crate::plan::line::resolve_line(robot, &asked).unwrap();
    let start = crate::plan::start::Start { values, counts };
    let course = crate::plan::course::Course::Line(line);
    crate::plan::strategy::followed(0.0, |k| {
        let checked = check.map(|c| move |a: &[f64; 4], f: f64| c(k, a, f));
        let motion = super::slowed(&asked.motion, k);
        let mut plan = crate::plan::part::plan_course_checked(
            robot,
            &course,
            &start,
            motion,
            checked.as_ref().map(|c| c as _),
        )?;
        plan.speed_factor *= k.sqrt();
        super::within_limits(robot, &mut plan)?;
        Ok(plan)
    })
    .unwrap()
}

/// An S-curve under drive limits is planned (it was refused) as the time-optimal motion
/// averaged to its jerk: every row and the planned motion keep every limit, the tool's jerk
/// stays within the one asked, and it takes the time-optimal trapezoid's time and one window
/// (its acceleration's range over the jerk), far less than the same S-curve slowed as a whole.
#[test]
fn an_s_curve_under_drive_limits_is_the_time_optimal_motion_averaged_to_its_jerk() {
    let robot = seed_slow_radial();
    let free = seed_robot();
    for method in [Method::ConstantPeriod, BOUNDED] {
        let asked = plan_move(&free, &s_curve(&free, method, 20_000.0)).unwrap();
        assert!(asked.drive[2].peak_accel > 800.0, "{:?}", asked.drive[2]);
        let plan = plan_move(&robot, &s_curve(&robot, method, 20_000.0)).unwrap();
        assert!(plan.valid(), "{method:?}: {:?}", plan.problems);
        assert!(matches!(plan.motion.ramp, Ramp::SCurve { .. }));
        assert_rows_within(&robot, &plan);
        let d3 = plan.drive[2];
        assert!(d3.peak_accel <= 300.0 * 1.02, "{method:?}: {d3:?}");
        assert!(d3.rest_hz <= 1_000.0, "{method:?}: {d3:?}");
        let jerk = crate::testing::course_jerk(&plan);
        assert!(jerk <= 20_000.0 * 1.05, "{method:?}: {jerk} mm/s^3");
        let mut trapezoid_req = seed_move(&robot, method, FrequencyModel::FpxDivider);
        trapezoid_req.motion.ramp = Ramp::Trapezoid;
        let trapezoid = plan_move(&robot, &trapezoid_req).unwrap();
        let slowed = seed_s_curve_slowed_as_a_whole(&robot, method);
        eprintln!(
            "{method:?}: averaged {:.3} s (speed factor {}), time-optimal trapezoid {:.3} s, \
             slowed as a whole {:.3} s (to {:.1} %); tool jerk {jerk:.0} mm/s^3",
            plan.duration_s(),
            plan.speed_factor,
            trapezoid.duration_s(),
            slowed.duration_s(),
            slowed.speed_factor * 100.0
        );
        // The trapezoid's acceleration runs from -1200 to 1200 mm/s^2: a window of 0.12 s.
        assert!(
            plan.duration_s() <= trapezoid.duration_s() + 0.12 + 0.1,
            "{method:?}: {} against {}",
            plan.duration_s(),
            trapezoid.duration_s()
        );
        assert!(
            plan.duration_s() < 0.85 * slowed.duration_s(),
            "{method:?}: {} against {}",
            plan.duration_s(),
            slowed.duration_s()
        );
    }
}

/// A limit no slowing meets is refused naming the joint: d3 at 0.001 mm/s^2.
#[test]
fn an_s_curve_no_slowing_lets_a_drive_follow_is_refused_naming_the_joint() {
    let robot = limited(seed_robot(), [200.0, 1_000.0, 0.001, 200.0], [None; 4]);
    let e = plan_move(&robot, &s_curve(&robot, Method::ConstantPeriod, 20_000.0)).unwrap_err();
    assert!(
        matches!(
            e,
            PlanError::RowStep { ref joint, .. } | PlanError::SCurveOverMaxAccel { ref joint, .. }
                if joint == "d3"
        ),
        "{e}"
    );
}

/// A path section's S-curve under drive limits is planned the same way: every start keeps
/// every limit and the tool's jerk the one asked.
#[test]
fn a_path_s_curve_under_drive_limits_keeps_every_limit() {
    let robot = seed_slow_radial();
    let req = from_the_seed_start(
        &robot,
        &[
            ([-926.57, 535.03, 150.0], Corner::Blend(20.0)),
            ([-1100.0, 640.0, 150.0], Corner::Stop),
        ],
        Motion {
            ramp: Ramp::SCurve {
                jerk_mm_s3: 20_000.0,
            },
            ..robot.motion
        },
    );
    let plan = plan_path(&robot, &req).unwrap();
    assert!(plan.valid());
    for start in plan.starts() {
        assert!(matches!(start.motion.ramp, Ramp::SCurve { .. }));
        let jerk = crate::testing::course_jerk(start);
        assert!(jerk <= 20_000.0 * 1.05, "{jerk} mm/s^3");
        assert_rows_within(&robot, start);
        assert!(
            start.drive[2].peak_accel <= 300.0 * 1.02,
            "{:?}",
            start.drive[2]
        );
    }
}

/// `robot` with joint `j`'s `max_jerk` (user units/s^3) added.
fn with_max_jerk(mut robot: Robot, j: usize, max_jerk_user: f64) -> Robot {
    let joint = &mut robot.joints[j];
    joint.dynamics.max_jerk = Some(joint.kind.from_user(max_jerk_user));
    robot
}

/// The measurement itself, against a motion whose jerk is known: on a joint move every joint
/// runs the profile's S-curve scaled by its share of the course, so its jerk is that share of
/// the profile's (its jerk phases, 60 ms here, longer than the 10 ms it is judged over).
#[test]
fn a_joint_s_jerk_reads_as_its_share_of_a_joint_move_s_s_curve() {
    let robot = seed_robot();
    let from = crate::plan::tests::seed_request(FrequencyModel::FpxDivider, false).from;
    let Origin::Pose(from_pose) = from else {
        unreachable!()
    };
    let start = robot.kinematics.ik(&from_pose, None).unwrap();
    let to = [start[0] + 0.3, start[1] + 40.0, start[2] - 90.0, start[3]];
    let motion = Motion {
        ramp: Ramp::SCurve {
            jerk_mm_s3: 20_000.0,
        },
        ..robot.motion
    };
    let plan = plan_joint_move(&robot, &JointMoveRequest { from, to, motion }).unwrap();
    let jerks = super::jerk::peak_jerks(&robot, &plan).unwrap();
    let path_jerk = plan.profile.accel_mm_s2 / plan.profile.jerk_s;
    assert!(plan.profile.jerk_s > 0.05, "{:?}", plan.profile);
    let length = plan.profile.length_mm;
    for (j, joint) in robot.joints.iter().enumerate() {
        let share = (to[j] - start[j]).abs() / length;
        let expected = joint.user(path_jerk * share).abs();
        assert!(
            (jerks[j] - expected).abs() <= 0.01 * expected + 1e-6,
            "{}: {} against {expected}",
            joint.name,
            jerks[j]
        );
    }
}

/// A radial drive that takes 5000 mm/s^3: the seed's move's S-curve (20000 mm/s^3 along the
/// line) asks more of it, so the time-optimal motion's window is lengthened until d3's jerk
/// keeps it, which is faster than slowing the S-curve as a whole until it does.
#[test]
fn an_s_curve_s_window_is_lengthened_until_every_joint_keeps_its_max_jerk() {
    let free = seed_robot();
    let robot = with_max_jerk(
        limited(seed_robot(), [200.0, 1_000.0, 1_000.0, 200.0], [None; 4]),
        2,
        5_000.0,
    );
    for method in [Method::ConstantPeriod, BOUNDED] {
        let asked = plan_move(&free, &s_curve(&free, method, 20_000.0)).unwrap();
        let asked_jerk = super::jerk::peak_jerks(&free, &asked).unwrap()[2];
        assert!(asked_jerk > 8_000.0, "{method:?}: {asked_jerk}");
        let plan = plan_move(&robot, &s_curve(&robot, method, 20_000.0)).unwrap();
        assert!(plan.valid(), "{method:?}: {:?}", plan.problems);
        assert_rows_within(&robot, &plan);
        let d3 = plan.drive[2].peak_jerk.expect("measured");
        assert!(d3 <= 5_000.0, "{method:?}: {d3}");
        // Every joint's figure is the measurement's.
        let again = super::jerk::peak_jerks(&robot, &plan).unwrap();
        for (d, again) in plan.drive.iter().zip(again) {
            assert_eq!(d.peak_jerk, Some(again));
        }
        let slowed = seed_s_curve_slowed_as_a_whole(&robot, method);
        eprintln!(
            "{method:?}: averaged {:.3} s, d3 {d3:.0} mm/s^3; slowed as a whole {:.3} s (to \
             {:.1} %)",
            plan.duration_s(),
            slowed.duration_s(),
            slowed.speed_factor * 100.0
        );
        assert!(
            slowed.speed_factor < 0.9,
            "{method:?}: {}",
            slowed.speed_factor
        );
        assert!(
            plan.duration_s() < slowed.duration_s(),
            "{method:?}: {} against {}",
            plan.duration_s(),
            slowed.duration_s()
        );
        // Slowed as a whole, a tenth faster is over it.
        let k = (slowed.speed_factor * 1.1).powi(2);
        let faster = seed_s_curve_slowed(&free, method, k);
        let faster_jerk = super::jerk::peak_jerks(&free, &faster).unwrap()[2];
        assert!(faster_jerk > 5_000.0, "{method:?}: {faster_jerk}");
    }
}

/// A jerk no slowing meets is refused naming the joint, the figures and the speed tried.
#[test]
fn a_max_jerk_no_slowing_meets_is_refused_naming_the_joint() {
    let robot = with_max_jerk(seed_robot(), 2, 1.0);
    let e = plan_move(&robot, &s_curve(&robot, Method::ConstantPeriod, 20_000.0)).unwrap_err();
    let PlanError::OverMaxJerk {
        ref joint,
        max_jerk,
        speed_pct,
        ..
    } = e
    else {
        panic!("{e}")
    };
    assert_eq!((joint.as_str(), max_jerk), ("d3", 1.0));
    assert!((speed_pct - 12.5).abs() < 1e-9, "{speed_pct}");
    assert!(e.to_string().contains("max_jerk = 1 mm/s^3"), "{e}");
}

/// A trapezoid steps its acceleration at once: a robot with a joint's `max_jerk` refuses it for
/// a line, a joint move and a path alike, before anything is planned.
#[test]
fn a_trapezoid_is_refused_for_a_robot_with_a_max_jerk() {
    let robot = with_max_jerk(seed_robot(), 0, 900.0);
    let trapezoid = seed_move(&robot, Method::ConstantPeriod, FrequencyModel::FpxDivider);
    let refused = |e: PlanError| {
        assert!(
            matches!(e, PlanError::JerkNeedsSCurve { ref joint, max_jerk, unit }
                if joint == "theta1" && (max_jerk - 900.0).abs() < 1e-9 && unit == "deg"),
            "{e}"
        );
    };
    refused(plan_move(&robot, &trapezoid).unwrap_err());
    let to = [0.9, 60.0, 600.0, 0.0];
    let joint = JointMoveRequest {
        from: trapezoid.from,
        to,
        motion: trapezoid.motion,
    };
    refused(plan_joint_move(&robot, &joint).unwrap_err());
    let path = from_the_seed_start(
        &robot,
        &[([-1100.0, 640.0, 150.0], Corner::Stop)],
        robot.motion,
    );
    let e = plan_path(&robot, &path).unwrap_err();
    let PlanError::Section { source, .. } = e else {
        panic!("{e}")
    };
    refused(*source);
}

/// A joint move's S-curve takes the jerk its joints allow over their shares, as its
/// acceleration does: planned at the asked speed, not slowed.
#[test]
fn a_joint_move_s_s_curve_keeps_every_joint_s_max_jerk_at_its_speed() {
    let robot = with_max_jerk(seed_robot(), 2, 3_000.0);
    let from = crate::plan::tests::seed_request(FrequencyModel::FpxDivider, false).from;
    let motion = Motion {
        ramp: Ramp::SCurve {
            jerk_mm_s3: 20_000.0,
        },
        ..robot.motion
    };
    let to = [1.1, 100.0, 700.0, 0.0];
    let plan = plan_joint_move(&robot, &JointMoveRequest { from, to, motion }).unwrap();
    assert!(plan.valid());
    let d3 = plan.drive[2].peak_jerk.expect("measured");
    assert!((2_500.0..=3_000.0).contains(&d3), "{d3}");
    assert!((plan.speed_factor - 1.0).abs() < 1e-12);
    let Ramp::SCurve { jerk_mm_s3 } = plan.motion.ramp else {
        panic!()
    };
    assert!(jerk_mm_s3 < 20_000.0, "{jerk_mm_s3}");
}

/// A path's corner steps its acceleration where its arc begins: that step over 10 ms is a jerk
/// too, and the path's S-curve is slowed until it keeps d3's.
#[test]
fn a_path_s_curve_keeps_every_joint_s_max_jerk_through_its_blends() {
    let robot = with_max_jerk(seed_robot(), 2, 20_000.0);
    let corners = [
        ([-926.57, 535.03, 150.0], Corner::Blend(20.0)),
        ([-1100.0, 640.0, 150.0], Corner::Stop),
    ];
    let motion = Motion {
        ramp: Ramp::SCurve {
            jerk_mm_s3: 20_000.0,
        },
        ..robot.motion
    };
    let free = seed_robot();
    let asked = plan_path(&free, &from_the_seed_start(&free, &corners, motion)).unwrap();
    let asked_jerk = asked
        .starts()
        .map(|s| super::jerk::peak_jerks(&free, s).unwrap()[2])
        .fold(0.0, f64::max);
    assert!(asked_jerk > 20_000.0, "{asked_jerk}");
    let plan = plan_path(&robot, &from_the_seed_start(&robot, &corners, motion)).unwrap();
    assert!(plan.valid());
    for start in plan.starts() {
        assert!(start.speed_factor < 1.0, "{}", start.speed_factor);
        let d3 = start.drive[2].peak_jerk.expect("measured");
        assert!(d3 <= 20_000.0, "{d3}");
    }
}

/// The check on the samples refuses only what the planned motion's check would: the seed's
/// S-curve slowed as a whole under d3's 300 mm/s^2 finds the same share with it as without it,
/// and the motion asked for (871 mm/s^2 of d3) is refused by it naming d3.
#[test]
fn a_motion_clearly_over_max_accel_is_refused_on_its_samples_as_after_its_rows() {
    let robot = seed_slow_radial();
    let check = |k: f64, accels: &[f64; 4], factor: f64| {
        super::clearly_over_max_accel(&robot, accels, factor * k.sqrt() * 100.0)
    };
    for method in [Method::ConstantPeriod, BOUNDED] {
        let plain = seed_s_curve_slowed_as_a_whole(&robot, method);
        let checked = seed_s_curve_slowed_checked(&robot, method, Some(&check));
        assert_eq!(
            plain.speed_factor.to_bits(),
            checked.speed_factor.to_bits(),
            "{method:?}"
        );
        assert_eq!(plain.tables, checked.tables, "{method:?}");
    }
    let free = plan_move(
        &seed_robot(),
        &s_curve(&seed_robot(), Method::ConstantPeriod, 20_000.0),
    )
    .unwrap();
    let accels: [f64; 4] = std::array::from_fn(|j| free.drive[j].peak_accel);
    let e = super::clearly_over_max_accel(&robot, &accels, 100.0).unwrap_err();
    assert!(
        matches!(e, PlanError::SCurveOverMaxAccel { ref joint, .. } if joint == "d3"),
        "{e}"
    );
}
