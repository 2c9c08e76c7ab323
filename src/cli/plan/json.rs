//! The JSON plan document (`"linterpd_plan": 1`), stable for scripts. Fields are only ever added.

use serde::Serialize;
use std::collections::BTreeMap;

use crate::kinematics::{JointKind, Kinematics};
use crate::plan::{MoveRequest, Plan};
use crate::robot::{Method, Robot};
use crate::sim::Figures;
use crate::table::{ChannelTable, Direction, Duty, Segment};

/// The whole document.
#[derive(Debug, Serialize)]
pub(super) struct Document {
    linterpd_plan: u32,
    robot: RobotDoc,
    #[serde(rename = "move")]
    move_: MoveDoc,
    profile: ProfileDoc,
    channels: Vec<ChannelDoc>,
    valid: bool,
    problems: Vec<String>,
    figures: FiguresDoc,
    /// How hard each joint's drive is asked, against its limits (added with drive limits).
    drives: Vec<DriveDoc>,
}

/// One joint's drive in one start: its peaks and its limits (`null` where the config sets none).
#[derive(Debug, Serialize)]
pub(super) struct DriveDoc {
    joint: String,
    unit: &'static str,
    peak_hz: f64,
    peak_speed: f64,
    peak_accel: f64,
    max_accel: Option<f64>,
    /// The largest step between two rows over what `max_accel` allows there.
    step_load: Option<f64>,
    rest_hz: f64,
    start_hz: Option<f64>,
    /// The largest change of acceleration over 10 ms, measured when a joint has `max_jerk`.
    peak_jerk: Option<f64>,
    max_jerk: Option<f64>,
}

/// Every joint's drive figures of `plan`.
pub(super) fn drives(robot: &Robot, plan: &Plan) -> Vec<DriveDoc> {
    robot
        .joints
        .iter()
        .zip(&plan.drive)
        .map(|(j, d)| DriveDoc {
            joint: j.name.clone(),
            unit: j.kind.user_unit(),
            peak_hz: d.peak_hz,
            peak_speed: d.peak_speed,
            peak_accel: d.peak_accel,
            max_accel: j.dynamics.max_accel.map(|a| j.user(a).abs()),
            step_load: d.step_load,
            rest_hz: d.rest_hz,
            start_hz: j.dynamics.start_hz,
            peak_jerk: d.peak_jerk,
            max_jerk: j.dynamics.max_jerk.map(|v| j.user(v).abs()),
        })
        .collect()
}

#[derive(Debug, Serialize)]
struct RobotDoc {
    name: String,
    kinematics: &'static str,
    params: BTreeMap<&'static str, f64>,
    joints: Vec<JointDoc>,
}

#[derive(Debug, Serialize)]
struct JointDoc {
    name: String,
    channel: u8,
    kind: &'static str,
    step: f64,
    unit: &'static str,
    offset: f64,
    max_freq_hz: u32,
    output: &'static str,
}

#[derive(Debug, Serialize)]
struct MoveDoc {
    from: [f64; 4],
    to: [f64; 4],
    method: &'static str,
    seed_exact: bool,
    frequency_model: &'static str,
    over_speed: &'static str,
    requested_speed_mm_s: f64,
    speed_factor: f64,
}

#[derive(Debug, Serialize)]
struct ProfileDoc {
    /// The distance the profile runs: its course's length, or, for a path section run at its
    /// pace (slower on tight arcs), more than its path's.
    length_mm: f64,
    /// The course's length: the line's, or the section path's, mm.
    course_length_mm: f64,
    speed_mm_s: f64,
    /// "trapezoid" (the seed's profile), "s-curve" (jerk-limited ramps: `accel_mm_s2` is their
    /// peak), "time-optimal" (under drive limits: the ramps are the pace's, `accel_s` 0 and
    /// `accel_mm_s2` null) or "time-optimal s-curve" (under drive limits, or on a path section
    /// whose speed changes along it, the time-optimal motion averaged to the S-curve's jerk: the
    /// ramps are the pace's, as "time-optimal").
    timing: &'static str,
    accel_s: f64,
    accel_mm_s2: f64,
    period_s: f64,
    periods: u32,
    duration_s: f64,
}

#[derive(Debug, Serialize)]
struct ChannelDoc {
    channel: u8,
    joint: String,
    start: i64,
    end: i64,
    segments: Vec<SegmentDoc>,
}

#[derive(Debug, Serialize)]
struct SegmentDoc {
    direction: i8,
    range: u32,
    duty: &'static str,
    control_code: u32,
    rows: Vec<[i64; 2]>,
}

/// A plan's accuracy figures, as both the plan and the comparison documents give them.
#[derive(Debug, Serialize)]
pub(super) struct FiguresDoc {
    path_deviation_mm: f64,
    tracking_error_mm: f64,
    sampled_deviation_mm: f64,
    end_skew_ms: f64,
    end_error_mm: f64,
    finish_s: f64,
    rows: usize,
    words: usize,
}

/// Builds the document for a plan.
pub(super) fn document(robot: &Robot, request: &MoveRequest, plan: &Plan) -> Document {
    let figures = plan.figures;
    Document {
        linterpd_plan: 1,
        robot: robot_doc(robot),
        move_: MoveDoc {
            from: plan.line.from.to_mm_deg(),
            to: plan.line.to.to_mm_deg(),
            // The paper as printed is the constant-period method, flagged.
            method: match plan.motion.method {
                Method::SeedExact => Method::ConstantPeriod.name(),
                other => other.name(),
            },
            seed_exact: plan.motion.method.is_seed_exact(),
            frequency_model: plan.motion.frequency_model.name(),
            over_speed: plan.motion.over_speed.name(),
            requested_speed_mm_s: request.motion.speed_mm_s,
            speed_factor: plan.speed_factor,
        },
        profile: ProfileDoc::of(plan),
        channels: plan
            .tables
            .iter()
            .zip(&robot.joints)
            .map(|(t, j)| channel_doc(t, &j.name))
            .collect(),
        valid: plan.valid(),
        problems: plan.problems.clone(),
        figures: FiguresDoc::from(figures),
        drives: drives(robot, plan),
    }
}

impl ProfileDoc {
    /// The plan's speed profile and how it was timed.
    fn of(plan: &Plan) -> Self {
        Self {
            length_mm: plan.profile.length_mm,
            course_length_mm: plan.pace.as_ref().map_or(
                plan.profile.length_mm,
                crate::geometry::Pace::path_length_mm,
            ),
            speed_mm_s: plan.profile.speed_mm_s,
            timing: if plan
                .pace
                .as_ref()
                .is_some_and(crate::geometry::Pace::from_rest)
            {
                match plan.motion.ramp {
                    crate::robot::Ramp::SCurve { .. } => "time-optimal s-curve",
                    crate::robot::Ramp::Trapezoid => "time-optimal",
                }
            } else {
                plan.motion.ramp.name()
            },
            accel_s: plan.profile.accel_s,
            accel_mm_s2: plan.profile.accel_mm_s2,
            period_s: plan.profile.period_s,
            periods: plan.profile.periods(),
            duration_s: plan.duration_s(),
        }
    }
}

impl From<Figures> for FiguresDoc {
    fn from(figures: Figures) -> Self {
        Self {
            path_deviation_mm: figures.path_deviation_mm,
            tracking_error_mm: figures.tracking_error_mm,
            sampled_deviation_mm: figures.sampled_deviation_mm,
            end_skew_ms: figures.end_skew_ms,
            end_error_mm: figures.end_error_mm,
            finish_s: figures.finish_s,
            rows: figures.rows,
            words: figures.words,
        }
    }
}

fn robot_doc(robot: &Robot) -> RobotDoc {
    RobotDoc {
        name: robot.name.clone(),
        kinematics: robot.kinematics.name(),
        params: robot.kinematics.params().into_iter().collect(),
        joints: robot
            .joints
            .iter()
            .map(|j| JointDoc {
                name: j.name.clone(),
                channel: j.channel,
                kind: match j.kind {
                    JointKind::Revolute => "revolute",
                    JointKind::Prismatic => "prismatic",
                },
                step: j.step,
                unit: j.kind.unit(),
                offset: j.offset,
                max_freq_hz: j.max_freq_hz,
                output: j.output.name(),
            })
            .collect(),
    }
}

fn channel_doc(table: &ChannelTable, joint: &str) -> ChannelDoc {
    ChannelDoc {
        channel: table.channel,
        joint: joint.to_owned(),
        start: table.start,
        end: table.end(),
        segments: table.segments.iter().map(segment_doc).collect(),
    }
}

fn segment_doc(seg: &Segment) -> SegmentDoc {
    SegmentDoc {
        direction: if seg.control.direction == Direction::Up {
            1
        } else {
            -1
        },
        range: seg.control.range.digit(),
        duty: if seg.control.duty == Duty::Quarter {
            "1/4"
        } else {
            "1/2"
        },
        control_code: seg.control.value(),
        rows: seg
            .rows
            .iter()
            .map(|r| [i64::from(r.freq_hz), r.target])
            .collect(),
    }
}
