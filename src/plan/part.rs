//! PURE. One start of a sampled course (the whole of it, or one part of a path section cut into
//! several): its tables by the method asked, checked against the channels and every drive, and
//! judged by the execution model.

use crate::geometry::Profile;
use crate::kinematics::JOINTS;
use crate::robot::{Motion, Robot};
use crate::sim::Figures;
use crate::table::ChannelTable;

use super::course::Course;
use super::error::PlanError;
use super::judge::{check_tables, simulate};
use super::planned::{DriveFigures, Plan, Window, max_hz, settings};
use super::sampled::Sampled;
use super::samples::Samples;
use super::start::Start;
use super::{bounded, constant_period, dynamics, seed_exact, segments};

/// Plans a move along `course` from `start`: one start over the whole profile.
pub(super) fn plan_course(
    robot: &Robot,
    course: &Course,
    start: &Start,
    asked: Motion,
) -> Result<Plan, PlanError> {
    plan_course_checked(robot, course, start, asked, None)
}

/// A check of a sampled motion before its rows are made: every joint's planned acceleration
/// (user units) and the speed factor `slow-down` left ([`plan_course_checked`]).
pub(super) type MotionCheck<'a> = &'a dyn Fn(&[f64; JOINTS], f64) -> Result<(), PlanError>;

/// [`plan_course`], the sampled motion first checked by `check` (its every joint's planned
/// acceleration, user units, and the speed factor `slow-down` left): a motion refused on its
/// samples is refused before any rows are made.
pub(super) fn plan_course_checked(
    robot: &Robot,
    course: &Course,
    start: &Start,
    asked: Motion,
    check: Option<MotionCheck>,
) -> Result<Plan, PlanError> {
    let sampled = Sampled::new(robot, course, start, asked)?;
    if let Some(check) = check {
        // The profile's period is the samples' grid.
        let accels = dynamics::planned_accels(
            robot,
            &sampled.samples,
            sampled.profile.period_s,
            sampled.profile.duration_s(),
        );
        check(&accels, sampled.speed_factor)?;
    }
    let (first, last) = (0, sampled.last_point());
    let plan = |first, last| {
        plan_start(&sampled, first, last, start.counts)
            .map_err(|e| named(&sampled, e, first, last, start.counts))
    };
    let Some(line) = course.line() else {
        return plan(first, last);
    };
    let later = |joint: usize, reverses: bool, at_s: f64| PlanError::LaterSegment {
        joint: robot.joints[joint].name.clone(),
        reverses,
        at_mm: course
            .pace()
            .map_or(sampled.profile.distance_mm(at_s), |pace| {
                pace.path_mm(sampled.profile.distance_mm(at_s))
            }),
        length_mm: line.length_mm(),
    };
    if sampled.cut_for_segments()
        && let Some((cut, joint)) = sampled.reversal(first, last)
    {
        return Err(later(joint, true, sampled.time_s(cut)));
    }
    let plan = plan(first, last)?;
    if sampled.cut_for_segments()
        && let Some((joint, at_s)) = plan.later_segment()
    {
        return Err(later(joint, false, at_s));
    }
    Ok(plan)
}

/// The bounded-error planner of a part of `sampled` ([`Sampled::part`]).
fn bounded_move<'m>(
    sampled: &'m Sampled,
    window: &'m Window,
    samples: &'m Samples,
) -> bounded::Move<'m> {
    bounded::Move {
        robot: sampled.robot,
        course: sampled.course,
        profile: &sampled.profile,
        window,
        samples,
        motion: &sampled.motion,
    }
}

/// `refusal` of the start of `sampled` from `first` to `last` from `counts` as it reaches the
/// user: a tolerance too small names the smallest found to work, and a joint slower than its
/// channel plays ([`plan_start`] leaves both out).
pub(super) fn named(
    sampled: &Sampled,
    refusal: PlanError,
    first: usize,
    last: usize,
    counts: [i64; JOINTS],
) -> PlanError {
    match refusal {
        PlanError::ToleranceTooSmall {
            tolerance_mm,
            floor_mm,
            works_mm: None,
            ..
        } => {
            let (window, samples) = sampled.part(first, last, counts);
            let start = bounded_move(sampled, &window, &samples);
            PlanError::ToleranceTooSmall {
                tolerance_mm,
                floor_mm,
                creep: start.creep(),
                works_mm: start.works_mm(tolerance_mm),
            }
        }
        other => other,
    }
}

/// Plans the start of `sampled` from sample point `first` to `last`, from `counts` (where the
/// start before it ends, or where the move begins). A tolerance too small is refused without
/// the one that works ([`named`] adds it).
pub(super) fn plan_start(
    sampled: &Sampled,
    first: usize,
    last: usize,
    counts: [i64; JOINTS],
) -> Result<Plan, PlanError> {
    let robot = sampled.robot;
    let (window, samples) = sampled.part(first, last, counts);
    let (tables, problems, figures) = tabled(sampled, &window, &samples)?;
    let drive = if sampled.motion.method.is_seed_exact() {
        [DriveFigures::default(); JOINTS]
    } else {
        dynamics::judge(
            robot,
            &tables,
            &samples,
            sampled.profile.period_s,
            &window,
            settings(&sampled.motion),
        )?
    };
    Ok(Plan {
        line: sampled.course.chord(),
        joint_path: sampled.course.joint_path().cloned(),
        path: sampled.course.path().cloned(),
        pace: sampled.course.pace().cloned(),
        profile: sampled.profile,
        motion: sampled.motion,
        speed_factor: sampled.speed_factor,
        samples,
        tables,
        problems,
        max_hz: max_hz(robot),
        figures,
        window,
        drive,
    })
}

/// The start's tables, what is wrong with them and their figures: bounded by the path tolerance
/// when the motion asks for it, else built from `samples`, checked and simulated.
fn tabled(
    sampled: &Sampled,
    window: &Window,
    samples: &Samples,
) -> Result<(Vec<ChannelTable>, Vec<String>, Figures), PlanError> {
    if let Some(tolerance_mm) = sampled.bounded() {
        let v = bounded_move(sampled, window, samples).plan(tolerance_mm)?;
        return Ok((v.tables, Vec::new(), v.figures));
    }
    let robot = sampled.robot;
    let tables = build_tables(
        robot,
        samples,
        &sampled.profile,
        window.duration_s(),
        &sampled.motion,
    );
    let problems = check_tables(robot, &tables, sampled.motion.method)?;
    let figures = simulate(
        robot,
        &tables,
        sampled.course,
        &sampled.profile,
        window,
        &sampled.motion,
    );
    Ok((tables, problems, figures))
}

/// Every joint's table from `samples`, a period apart but the last point, `end_s` from the first.
fn build_tables(
    robot: &Robot,
    samples: &Samples,
    profile: &Profile,
    end_s: f64,
    motion: &Motion,
) -> Vec<ChannelTable> {
    robot
        .joints
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let counts = samples.joint(j);
            if motion.method.is_seed_exact() {
                return seed_exact::table(joint, &counts, profile.period_s);
            }
            let spans = constant_period::spans(&counts, profile.period_s, end_s);
            let segments = segments::build(
                joint,
                motion.frequency_model,
                counts[0],
                &spans,
                profile.period_s,
            );
            ChannelTable {
                channel: joint.channel,
                start: counts[0],
                segments,
            }
        })
        .collect()
}
