//! A path section as the strategy plans it ([`Timed`]): one move along the section, from the
//! counts the section before it ends on, into one start or several parts ([`super::parts`]).
//!
//! As asked, a section runs on one trapezoid at its pace ([`Pace`]): at the speed asked on
//! lines, and on an arc too tight for it at what the path's centripetal acceleration limit
//! allows (`v = sqrt(a r)`), for that arc alone, slowing before it and speeding up after it at
//! the profile's own acceleration (speed / acceleration time). Under `slow-down`, the stretches
//! where a joint's channel would pass its top frequency are slowed for in the same way
//! ([`frequency_caps`]); what that misses, the sampled check lowers the whole section's speed
//! for, as for a line. Under `reject` such a section is refused. An S-curve on a section whose
//! pace would change speed so (an acceleration stepping on and off, past its jerk) is timed as
//! under drive limits: the time-optimal motion averaged to its jerk.

use crate::geometry::{Pace, Path, SpeedCap};
use crate::kinematics::Kinematics;
use crate::robot::{Motion, OverSpeed, Ramp, Robot};

use super::super::course::Course;
use super::super::dynamics::{self, Averaging, PathLimits, Shape, Shares};
use super::super::error::PlanError;
use super::super::planned::Plan;
use super::super::sampled::probe;
use super::super::start::Start;
use super::super::strategy::{Kind, Strategy, Timed, Timing, plan_fastest};
use super::parts::parts;

/// Plans `section` from `start` into its starts: the fastest of the strategy's candidates
/// ([`Strategy::for_course`]).
pub(super) fn plan(
    robot: &Robot,
    section: &Path,
    start: &Start,
    asked: Motion,
    path_accel_mm_s2: f64,
) -> Result<Vec<Plan>, PlanError> {
    let s_curve = matches!(asked.ramp, Ramp::SCurve { .. });
    // Without drive limits, an S-curve whose pace would change speed along the section (a tight
    // arc; under `slow-down`, where a channel would be too fast) is timed as a robot with drive
    // limits is: the pace's changes of speed step the acceleration on and off.
    let pace_changes_speed = s_curve
        && !robot.has_dynamics()
        && !as_asked_pace(robot, section, start, &asked, path_accel_mm_s2).is_uniform();
    let strategy = Strategy::for_course(robot, &asked, Kind::Section { pace_changes_speed })?;
    let section = SectionMove {
        robot,
        section,
        start,
        asked,
        path_accel_mm_s2,
    };
    plan_fastest(&section, &strategy)
}

/// A path section to plan: the section, where it starts, the motion asked and the path's
/// centripetal acceleration limit.
struct SectionMove<'a> {
    robot: &'a Robot,
    section: &'a Path,
    start: &'a Start,
    asked: Motion,
    path_accel_mm_s2: f64,
}

impl SectionMove<'_> {
    /// The section's time-optimal pace under `motion` to `shares` of the limits, its
    /// standstills' zones for rows of any length or not.
    fn pace(
        &self,
        motion: &Motion,
        shares: Shares,
        rows_any_length: bool,
    ) -> Result<Pace, PlanError> {
        let section = self.section;
        let breaks_mm: Vec<f64> = section
            .pieces()
            .iter()
            .skip(1)
            .map(|p| p.start_mm)
            .collect();
        let shape = Shape {
            length_mm: section.length_mm(),
            pose_at: &|s| section.at(s),
            curvature_at: &|s| section.curvature_per_mm(s),
            breaks_mm: &breaks_mm,
        };
        let limits = PathLimits {
            centripetal_mm_s2: self.path_accel_mm_s2,
            rest_row_s: self.asked.period_s,
            rows_any_length,
            shares,
        };
        dynamics::pace(self.robot, &shape, &self.start.values, motion, &limits)
    }

    /// The section at `pace` as a course.
    fn course(&self, pace: Pace) -> Course {
        Course::Path {
            path: self.section.clone(),
            pace,
        }
    }

    /// The S-curve asked slowed as a whole to share `k` of its accelerations (its path's
    /// centripetal acceleration with the rest), every start's planned motion checked.
    fn slowed(&self, k: f64) -> Result<Vec<Plan>, PlanError> {
        let mut starts = planned_as_asked(
            self.robot,
            self.section,
            self.start,
            dynamics::slowed(&self.asked, k),
            self.path_accel_mm_s2 * k,
        )?;
        for s in &mut starts {
            s.speed_factor *= k.sqrt();
            dynamics::within_limits(self.robot, s)?;
        }
        Ok(starts)
    }
}

impl Timed for SectionMove<'_> {
    type Planned = Vec<Plan>;

    fn plan(&self, timing: Timing) -> Result<Vec<Plan>, PlanError> {
        match timing {
            Timing::AsAsked => planned_as_asked(
                self.robot,
                self.section,
                self.start,
                self.asked,
                self.path_accel_mm_s2,
            ),
            Timing::TimeOptimal {
                rows_any_length,
                accel_share,
            } => {
                let shares = Shares {
                    accel: accel_share,
                    ..Shares::WHOLE
                };
                let pace = self.pace(&self.asked, shares, rows_any_length)?;
                parts(self.robot, &self.course(pace), self.start, self.asked)
            }
            Timing::Averaged { rows_any_length } => {
                dynamics::averaged(self, &self.asked, self.path_accel_mm_s2, rows_any_length)
            }
            Timing::Slowed { k } => self.slowed(k),
        }
    }

    fn duration_s(starts: &Vec<Plan>) -> f64 {
        starts.iter().map(Plan::duration_s).sum()
    }

    fn fastest_s(&self, _: Timing) -> Option<f64> {
        None
    }
}

impl Averaging for SectionMove<'_> {
    type Planned = Vec<Plan>;

    fn timed(
        &self,
        motion: &Motion,
        shares: Shares,
        rows_any_length: bool,
    ) -> Result<(Path, Pace), PlanError> {
        Ok((
            self.section.clone(),
            self.pace(motion, shares, rows_any_length)?,
        ))
    }

    fn plan(&self, path: &Path, pace: Pace, motion: Motion) -> Result<Vec<Plan>, PlanError> {
        let course = Course::Path {
            path: path.clone(),
            pace,
        };
        let mut starts = parts(self.robot, &course, self.start, motion)?;
        for s in &mut starts {
            s.motion.ramp = self.asked.ramp;
            dynamics::within_limits(self.robot, s)?;
        }
        Ok(starts)
    }

    fn probe(&self, path: &Path, pace: Pace, motion: Motion) -> Option<(f64, f64)> {
        let course = Course::Path {
            path: path.clone(),
            pace,
        };
        probe(self.robot, &course, self.start, motion)
    }
}

/// `section` as asked ([`Timing::AsAsked`]): the profile along a pace that slows only for tight
/// arcs and, under `slow-down` with a trapezoid, where a channel would be too fast.
///
/// An S-curve is not slowed there: the pace's change of speed into and out of a cap is a
/// constant acceleration that steps on and off, past the jerk asked. The sampled check slows
/// the whole section instead, as it does a line, and the S-curve keeps its jerk.
pub(super) fn planned_as_asked(
    robot: &Robot,
    section: &Path,
    start: &Start,
    asked: Motion,
    path_accel_mm_s2: f64,
) -> Result<Vec<Plan>, PlanError> {
    // The pace an S-curve runs at has no caps: its arcs' alone, as under `reject`.
    let paced = match asked.ramp {
        Ramp::Trapezoid => asked,
        Ramp::SCurve { .. } => Motion {
            over_speed: OverSpeed::Reject,
            ..asked
        },
    };
    let course = Course::Path {
        path: section.clone(),
        pace: as_asked_pace(robot, section, start, &paced, path_accel_mm_s2),
    };
    parts(robot, &course, start, asked)
}

/// The pace a trapezoid of `asked` would run `section` at: slowed for tight arcs and, under
/// `slow-down`, where a channel would be too fast ([`frequency_caps`]).
pub(super) fn as_asked_pace(
    robot: &Robot,
    section: &Path,
    start: &Start,
    asked: &Motion,
    path_accel_mm_s2: f64,
) -> Pace {
    let caps = match asked.over_speed {
        OverSpeed::SlowDown => frequency_caps(robot, section, start, asked.speed_mm_s),
        OverSpeed::Reject => Vec::new(),
    };
    Pace::new(
        section,
        asked.speed_mm_s,
        path_accel_mm_s2,
        asked.speed_mm_s / asked.accel_s,
        &caps,
    )
}

/// The stretches a section is cut into to find where a joint would be too fast, mm.
const CAP_STRETCH_MM: f64 = 2.0;
/// The most such stretches in one section.
const MAX_CAP_STRETCHES: usize = 4_096;
/// The share of a channel's top frequency a capped stretch is planned to (the rest is left for
/// the joints' rates changing within a stretch, and for the rows' rounding).
const FREQUENCY_MARGIN: f64 = 0.97;

/// Under `slow-down`: every stretch (about [`CAP_STRETCH_MM`]) of `section` where a joint's
/// channel would pass [`FREQUENCY_MARGIN`] of its top frequency at `speed_mm_s`, capped at the
/// speed that keeps every channel within it, from the joints' pulses over the stretch (inverse
/// kinematics at its ends). Empty when a pose is out of reach: sampling the section says where.
/// Whatever the caps miss, the sampled check lowers the whole section's speed for, as before.
fn frequency_caps(robot: &Robot, section: &Path, start: &Start, speed_mm_s: f64) -> Vec<SpeedCap> {
    let length_mm = section.length_mm();
    let n = ((length_mm / CAP_STRETCH_MM).ceil() as usize).clamp(1, MAX_CAP_STRETCHES);
    let Ok(mut q) = robot.kinematics.ik(&section.at(0.0), Some(&start.values)) else {
        return Vec::new();
    };
    let mut caps = Vec::new();
    let mut from_mm = 0.0;
    for i in 1..=n {
        let to_mm = length_mm * i as f64 / n as f64;
        let Ok(next) = robot.kinematics.ik(&section.at(to_mm), Some(&q)) else {
            return Vec::new();
        };
        let fastest = robot
            .joints
            .iter()
            .zip(q.iter().zip(&next))
            .map(|(joint, (a, b))| {
                let pulses = (b - a).abs() / joint.step.abs();
                if pulses > 0.0 {
                    FREQUENCY_MARGIN * f64::from(joint.max_freq_hz) * (to_mm - from_mm) / pulses
                } else {
                    f64::INFINITY
                }
            })
            .fold(f64::INFINITY, f64::min);
        if fastest < speed_mm_s {
            caps.push(SpeedCap {
                from_mm,
                to_mm,
                speed_mm_s: fastest,
            });
        }
        (q, from_mm) = (next, to_mm);
    }
    caps
}
