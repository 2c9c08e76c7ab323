//! A line move as it will run. A line on which a joint reverses while another joint moves
//! cannot be one start: the reversing joint's next F174 segment begins in the PLC scan after
//! its last one ends (ACCURACY.md), up to a scan late, and holds the rest of its run back by
//! that much while the other channels run on. On the seed robot's 1 m line past its axis, a
//! 2 ms scan put the tool 0.25 mm off the line, and a 10 ms scan 1.09 mm, where the plan said
//! 0.044 mm (bounded-error 0.05 mm; constant-period 50 ms: 0.23 and 1.04 mm, said 0.045 mm).
//! Such a line runs as a path of that one line, cut at the reversal into starts the PLC chains
//! at speed: every channel stops and restarts together, a pause on the line and no deviation
//! ([`super::path`]). The same holds where a run needs a second frequency range.

use crate::geometry::{Corner, Element};

use super::{MoveRequest, PathPlan, PathRequest, Plan, PlanError, plan_move, plan_path};

/// A line move as planned: one start, or the line as a one-element path cut into starts.
#[derive(Debug, Clone, PartialEq)]
pub enum MovePlan {
    /// One start.
    One(Box<Plan>),
    /// A line cut where a joint's channel would need a later segment
    /// ([`PlanError::LaterSegment`]): one section, its starts chained at speed.
    Parts {
        /// The line as a path of one element, and its starts.
        path: PathPlan,
        /// The joint whose later segment the line is cut for (the first, if several).
        joint: String,
        /// Whether it reverses there (else its run changes frequency range).
        reverses: bool,
        /// Where, mm along the line.
        at_mm: f64,
    },
    /// A line whose tables would not fit one start ([`PlanError::too_big`]: a channel's table
    /// needs more words than its area holds): one section, cut into parts chained at speed
    /// until each part's tables fit.
    Long {
        /// The line as a path of one element, and its starts.
        path: PathPlan,
        /// Why one start could not hold it (the first table that did not fit).
        one_start: Box<PlanError>,
    },
}

impl MovePlan {
    /// Every start, in order.
    pub fn starts(&self) -> impl Iterator<Item = &Plan> {
        let (one, parts) = match self {
            Self::One(plan) => (Some(plan.as_ref()), None),
            Self::Parts { path, .. } | Self::Long { path, .. } => (None, Some(path.starts())),
        };
        one.into_iter().chain(parts.into_iter().flatten())
    }
}

/// The line `req` as a path of one line element ending at rest.
#[must_use]
pub fn line_as_path(req: &MoveRequest) -> PathRequest {
    PathRequest {
        from: req.from,
        start: None,
        elements: vec![(Element::Line { to: req.to }, Corner::Stop)],
        motion: req.motion,
        // A line has no arc to turn on: the profile's own acceleration (any, without a ramp).
        path_accel_mm_s2: if req.motion.accel_s > 0.0 {
            req.motion.speed_mm_s / req.motion.accel_s
        } else {
            f64::MAX
        },
    }
}

/// Plans the line `req` as it will run: [`plan_move`], or where that refuses one start because a
/// joint reverses on the line while another moves, or because its tables would not fit one
/// start, the line as a path ([`line_as_path`]) cut into starts chained at speed.
///
/// # Errors
/// As [`plan_move`], and as [`plan_section`](super::plan_section) for a line cut into starts;
/// [`PlanError::NoParts`] for a line too long for one start that cannot run in parts.
pub fn plan_line(robot: &crate::robot::Robot, req: &MoveRequest) -> Result<MovePlan, PlanError> {
    match plan_move(robot, req) {
        Err(e) if e.too_big() => plan_long(robot, req, e),
        Err(PlanError::LaterSegment {
            joint,
            reverses,
            at_mm,
            ..
        }) => plan_path(robot, &line_as_path(req))
            .map(|path| MovePlan::Parts {
                path,
                joint,
                reverses,
                at_mm,
            })
            // The line is the path's one section: its error is the line's.
            .map_err(|e| match e {
                PlanError::Section { source, .. } => *source,
                e => e,
            }),
        planned => planned.map(|plan| MovePlan::One(Box::new(plan))),
    }
}

/// The line `req`, whose one start `one_start` refused for its size, as a path of that line:
/// its parts each fit their areas ([`super::path`] cuts a part in halves until it does).
fn plan_long(
    robot: &crate::robot::Robot,
    req: &MoveRequest,
    one_start: PlanError,
) -> Result<MovePlan, PlanError> {
    match plan_path(robot, &line_as_path(req)) {
        Ok(path) => Ok(MovePlan::Long {
            path,
            one_start: Box::new(one_start),
        }),
        Err(parts) => Err(one_start.no_parts(parts)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Line, Pose};
    use crate::kinematics::Kinematics;
    use crate::robot::{Method, Motion, Robot, seed_robot};
    use crate::sim;
    use crate::table::FrequencyModel;

    /// A line 800 mm from the seed robot's axis, `length_mm` long, passing the point nearest
    /// it halfway: the radial joint shortens, then lengthens.
    fn past_the_axis(robot: &Robot, length_mm: f64, method: Method) -> MoveRequest {
        let h = length_mm / 2.0;
        let from = robot.pose_with_wrist_at_zero(-h, 800.0, 150.0).unwrap();
        let mut to = Pose::from_mm_deg(h, 800.0, 150.0, 0.0);
        to.a_rad = from.a_rad;
        MoveRequest {
            from: super::super::Origin::Pose(from),
            to,
            motion: Motion {
                method,
                ..robot.motion
            },
        }
    }

    const BOUNDED: Method = Method::BoundedError { tolerance_mm: 0.05 };

    #[test]
    fn one_start_through_a_reversal_is_refused_naming_the_joint_and_where() {
        let robot = seed_robot();
        let err = plan_move(&robot, &past_the_axis(&robot, 500.0, BOUNDED)).unwrap_err();
        let PlanError::LaterSegment {
            joint,
            reverses: true,
            at_mm,
            length_mm,
        } = &err
        else {
            panic!("{err}");
        };
        assert_eq!(joint, "d3");
        assert!((length_mm - 500.0).abs() < 1e-6, "{err}");
        assert!((at_mm - 250.0).abs() < 5.0, "{err}");
        assert!(err.to_string().contains("reverses 2"), "{err}");
    }

    #[test]
    fn a_line_through_a_reversal_holds_its_tolerance_under_any_scan_between_segments() {
        // Invariant: whatever the PLC's scan (0 to 10 ms between a channel's segments), every
        // start of the line stays within the tolerance of the line, starts from the counts the
        // one before it ends on, and the last ends on the target's counts. One start through
        // the reversal left the line by 0.16 mm at a 2 ms scan and 0.66 mm at 10 ms.
        let robot = seed_robot();
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            let mut req = past_the_axis(&robot, 500.0, BOUNDED);
            req.motion.frequency_model = model;
            let MovePlan::Parts {
                path,
                joint,
                reverses: true,
                ..
            } = plan_line(&robot, &req).unwrap()
            else {
                panic!("{model:?}: planned as one start");
            };
            assert_eq!(joint, "d3");
            let starts: Vec<&Plan> = path.starts().collect();
            assert!(starts.len() >= 2, "{model:?}");
            assert!(path.valid(), "{model:?}");
            let super::super::Origin::Pose(from) = req.from else {
                unreachable!()
            };
            let line = Line { from, to: req.to };
            for pair in starts.windows(2) {
                assert_eq!(pair[1].start_counts(), pair[0].end_counts(), "{model:?}");
            }
            let q = robot.kinematics.ik(&req.to, None).unwrap();
            assert_eq!(starts[starts.len() - 1].end_counts(), robot.counts_of(&q));
            for (k, plan) in starts.iter().enumerate() {
                for gap_s in [0.0, 0.002, 0.010] {
                    let run = plan.execution_with_scan(gap_s);
                    let d = sim::path_deviation_mm(
                        &robot,
                        &plan.start_counts(),
                        run.events.iter().copied(),
                        &line,
                    );
                    assert!(d <= 0.05, "{model:?} start {k}, gap {gap_s} s: {d} mm");
                }
            }
        }
    }

    #[test]
    fn a_constant_period_line_is_cut_at_the_reversal_too_and_one_without_stays_one_start() {
        let robot = seed_robot();
        assert!(matches!(robot.motion.method, Method::ConstantPeriod));
        // The seed's method samples every period; its starts play as planned whatever the
        // scan, where one start's figures held only without one.
        let cp = past_the_axis(&robot, 500.0, robot.motion.method);
        let MovePlan::Parts { path, joint, .. } = plan_line(&robot, &cp).unwrap() else {
            panic!("one start through the reversal");
        };
        assert_eq!(joint, "d3");
        for plan in path.starts() {
            assert!(plan.tables.iter().all(|t| t.segments.len() <= 1));
        }
        // Away from the axis's nearest point no joint reverses.
        for method in [robot.motion.method, BOUNDED] {
            let mut one_side = past_the_axis(&robot, 500.0, method);
            one_side.to.position_mm.x = -10.0;
            assert_eq!(
                plan_line(&robot, &one_side).unwrap(),
                MovePlan::One(Box::new(plan_move(&robot, &one_side).unwrap()))
            );
        }
    }

    /// The seed's line at 20 mm/s sampled every 10 ms: channel 0's one table needs more words
    /// than its area (2000) holds.
    fn long_slow_line() -> (Robot, MoveRequest) {
        let robot = seed_robot();
        let mut req = crate::plan::tests::seed_request(FrequencyModel::FpxDivider, false);
        req.motion.speed_mm_s = 20.0;
        req.motion.period_s = 0.01;
        (robot, req)
    }

    #[test]
    fn a_line_too_long_for_one_start_runs_in_parts_each_whole_in_its_areas() {
        // Issue 47: "channel 0 table needs 3152 words; its area holds 2000", with no way out.
        let (robot, req) = long_slow_line();
        let one = plan_move(&robot, &req).unwrap_err();
        assert!(one.too_big(), "{one}");
        let MovePlan::Long { path, one_start } = plan_line(&robot, &req).unwrap() else {
            panic!("not planned in parts for its size");
        };
        assert_eq!(*one_start, one);
        let starts: Vec<&Plan> = path.starts().collect();
        assert!(starts.len() >= 2, "{} starts", starts.len());
        assert_eq!(
            path.sections.len(),
            1,
            "one section: chained at speed, no stop"
        );
        for (k, plan) in starts.iter().enumerate() {
            assert!(plan.valid(), "part {k}: {:?}", plan.problems);
            assert!(plan.valid_tables(&robot).is_some(), "part {k}");
            for (j, table) in plan.tables.iter().enumerate() {
                let words: usize = table
                    .segments
                    .iter()
                    .map(crate::table::Segment::words)
                    .sum();
                assert!(words <= robot.area_words, "part {k} joint {j}: {words}");
            }
        }
        for pair in starts.windows(2) {
            assert_eq!(pair[1].start_counts(), pair[0].end_counts());
        }
        let super::super::Origin::Pose(from) = req.from else {
            unreachable!()
        };
        assert_eq!(
            starts[0].start_counts(),
            robot.counts_of(&robot.kinematics.ik(&from, None).unwrap())
        );
        let q = robot.kinematics.ik(&req.to, None).unwrap();
        assert_eq!(starts[starts.len() - 1].end_counts(), robot.counts_of(&q));
        // Every part runs on the line, within what its plan says (what `linterpd plan` shows)
        // and as close as the seed's constant-period line runs as one start (under 0.1 mm).
        let line = Line { from, to: req.to };
        for (k, plan) in starts.iter().enumerate() {
            let run = plan.execution_with_scan(0.0);
            let d = sim::path_deviation_mm(
                &robot,
                &plan.start_counts(),
                run.events.iter().copied(),
                &line,
            );
            let said = plan.figures.path_deviation_mm;
            assert!(
                d <= said + 1e-6 && d < 0.1,
                "part {k}: {d} mm off the line, {said} said"
            );
        }
    }

    #[test]
    fn a_joint_move_too_long_for_one_start_is_refused_saying_why_and_what_to_do() {
        let (robot, req) = long_slow_line();
        let super::super::Origin::Pose(from) = req.from else {
            unreachable!()
        };
        let joints = crate::plan::JointMoveRequest {
            from: req.from,
            to: robot
                .kinematics
                .ik(&req.to, robot.kinematics.ik(&from, None).ok().as_ref())
                .unwrap(),
            motion: req.motion,
        };
        let e = crate::plan::plan_joint_move(&robot, &joints).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, PlanError::JointMoveTooLong { .. }), "{text}");
        assert!(text.contains("words; its area holds 2000"), "{text}");
        assert!(
            text.contains(
                "a joint move runs as one start and is not cut into parts; ask for a faster speed"
            ),
            "{text}"
        );
        assert!(text.contains("move there as a line"), "{text}");
    }

    #[test]
    fn a_line_too_long_that_cannot_run_in_parts_says_both_and_what_to_do() {
        let (robot, req) = long_slow_line();
        let one = plan_move(&robot, &req).unwrap_err();
        let parts = PlanError::PathAccel { accel_mm_s2: 0.0 };
        let text = one.clone().no_parts(parts.clone()).to_string();
        assert!(text.starts_with(&one.to_string()), "{text}");
        assert!(
            text.contains(&format!("; cut into parts chained at speed it cannot run either: {parts}; ask for a faster speed")),
            "{text}"
        );
        assert!(
            text.ends_with("or send it as a path of shorter lines"),
            "{text}"
        );
    }
}
