//! PURE. A move request becomes pulse tables, checked against every limit and judged by the
//! execution model before anyone may send it.
//!
//! ```text
//! request -> line P1P2 -> profile s(t) -> samples (IK, absolute counts) -> limits
//!         -> spans per joint (constant-period) -> segments (direction, range, duty, frequencies)
//!         -> validation -> sim -> figures
//! joint request -> joint-space path -> profile s(t) -> samples (joints in proportion) -> ...
//! ```
//!
//! A joint-space move ([`plan_joint_move`]) goes through the same profile, limits, rows,
//! segments, frequencies and bounded-error method as a line; only its samples come from the
//! joints in proportion instead of inverse kinematics (`course.rs`). Its figures measure the tool
//! against the tool's own path under the planned joints (forward kinematics), so a bounded-error
//! joint move's tolerance is the tool point's largest distance from that path, as for a line.

mod bounded;
mod constant_period;
mod course;
mod dynamics;
mod error;
mod joint_path;
mod judge;
mod limits;
mod line_parts;
mod path;
mod samples;
mod seed_exact;
pub mod segments;

use crate::geometry::{Line, Pace, Path, Pose, Profile, ProfileRequest};
use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::{Method, Motion, OverSpeed, Ramp, Robot};
use crate::sim::{self, Execution, Figures, Settings};
use crate::table::{ChannelTable, ValidTable};

use course::Course;
pub use dynamics::DriveFigures;
pub use error::{Creep, PlanError};
pub use joint_path::JointPath;
use judge::{max_hz, settings, simulate, simulate_within};
pub use limits::{check_pose, check_target};
pub use line_parts::{MovePlan, line_as_path, plan_line};
pub use path::{
    MIN_PART_S, PathPlan, PathRequest, SECTION_START_SLACK_MM, SectionPlan, plan_path, plan_section,
};
pub use samples::Samples;

/// Where a move starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Origin {
    /// A pose (a plan made ahead of time): the start counts are the nearest to it.
    Pose(Pose),
    /// The counts the PLC reports (a move about to run): the line starts at their pose.
    Counts([i64; JOINTS]),
}

/// One straight-line move to plan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveRequest {
    /// Where the move starts.
    pub from: Origin,
    /// The target pose.
    pub to: Pose,
    /// The motion settings (`Method::SeedExact` plans the paper as printed: comparison only,
    /// never valid for a PLC).
    pub motion: Motion,
}

/// One joint-space move to plan: every joint from where it starts to its target value, all on
/// one trapezoid (they reach their targets together).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMoveRequest {
    /// Where the move starts.
    pub from: Origin,
    /// Every joint's target value, rad or mm, in the joints' order.
    pub to: Joints,
    /// The motion settings: the speed is the tool's along its path (see the module `course`).
    pub motion: Motion,
}

/// A planned move: tables, profile, and how the execution model says they will run.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The line, P1 to P2 (a joint move's chord from its start pose to its end pose).
    pub line: Line,
    /// A joint move's path in joint space (`None` for a line move).
    pub joint_path: Option<JointPath>,
    /// A path section's path (lines, arcs, blends), measured from its start (`None` for a
    /// line or joint move).
    pub path: Option<Path>,
    /// A path section's pace: where the profile's distance falls on the path, slower on tight
    /// arcs (`None` for a line or joint move, whose profile runs along the course as it is).
    pub pace: Option<Pace>,
    /// The profile actually used (for a path section, over the pace's distance: see
    /// [`Plan::course_mm`]).
    pub profile: Profile,
    /// The motion settings actually used (speed lowered by `slow-down` if it had to).
    pub motion: Motion,
    /// Speed actually used over speed asked for (1 unless `slow-down` acted, or an S-curve was
    /// slowed for its drives' limits).
    pub speed_factor: f64,
    /// Counts at every interpolation point.
    pub samples: Samples,
    /// One table per joint, in joint order (a joint that does not move has no segments).
    pub tables: Vec<ChannelTable>,
    /// Why the tables must not be sent (empty for a valid plan).
    pub problems: Vec<String>,
    /// Every channel's top frequency, Hz (the execution model clamps to it).
    pub max_hz: [u32; JOINTS],
    /// The accuracy figures of the execution model's run of the tables ([`Plan::execution`]).
    pub figures: Figures,
    /// The stretch of the profile this start plays: the whole of it, or one part of a path
    /// section cut into several chained starts.
    pub window: Window,
    /// How hard every joint's drive is asked to follow its table, in joint order
    /// ([`DriveFigures`]; every row of a joint with drive limits is within them).
    pub drive: [DriveFigures; JOINTS],
}

/// The stretch of a profile one start plays, s: `samples` point 0 is at `from_s`, and the
/// start's own time 0 is `from_s` of the profile's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// Where the start begins on the profile's time, s.
    pub from_s: f64,
    /// Where it ends, s.
    pub to_s: f64,
    /// Whether it ends at speed, chained into the next part (every part of a cut section but
    /// its last).
    pub ends_at_speed: bool,
}

impl Window {
    /// The whole of `profile`.
    #[must_use]
    pub fn whole(profile: &Profile) -> Self {
        Self {
            from_s: 0.0,
            to_s: profile.duration_s(),
            ends_at_speed: false,
        }
    }

    /// Whether it begins at speed, behind another part of the same section.
    #[must_use]
    pub fn begins_at_speed(&self) -> bool {
        self.from_s > 0.0
    }

    /// Its length, s.
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.to_s - self.from_s
    }
}

impl Plan {
    /// Whether the tables may be sent to a PLC.
    #[must_use]
    pub fn valid(&self) -> bool {
        self.problems.is_empty()
    }

    /// The final counts, joint by joint.
    #[must_use]
    pub fn end_counts(&self) -> [i64; JOINTS] {
        std::array::from_fn(|j| self.tables[j].end())
    }

    /// The counts it starts from, joint by joint.
    #[must_use]
    pub fn start_counts(&self) -> [i64; JOINTS] {
        std::array::from_fn(|j| self.tables[j].start)
    }

    /// How long the start runs as planned, s.
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.window.duration_s()
    }

    /// The execution model's run of the tables, every pulse and row timed: the run the
    /// figures were measured on. Planning reads it once as it is made and keeps none of it;
    /// this plays it again (a few milliseconds), for a plot, a CSV or a replay.
    #[must_use]
    pub fn execution(&self) -> Execution {
        sim::execute(&self.tables, &self.max_hz, settings(&self.motion))
    }

    /// [`Plan::execution`] with `scan_s` between the end of a channel's segment and the start
    /// of its next, as a PLC scan may put there (ACCURACY.md).
    #[must_use]
    pub fn execution_with_scan(&self, scan_s: f64) -> Execution {
        let settings = Settings {
            segment_gap_s: scan_s,
            ..settings(&self.motion)
        };
        sim::execute(&self.tables, &self.max_hz, settings)
    }

    /// The first later F174 segment of any channel, as the execution model plays it: the
    /// joint, and when the segment begins, s from the start. The PLC begins it in the scan
    /// after the segment before it ends, up to a scan late (ACCURACY.md), while the other
    /// channels run on.
    #[must_use]
    pub fn later_segment(&self) -> Option<(usize, f64)> {
        // Most plans have none: no rows timed for them.
        if self.tables.iter().all(|t| t.segments.len() <= 1) {
            return None;
        }
        self.row_timings()
            .into_iter()
            .filter(|r| r.segment > 0 && r.row == 0)
            .map(|r| (r.table, r.start_s))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// When every row of the tables runs in the execution model, table by table (the rows of
    /// [`Plan::execution`], without its pulses).
    #[must_use]
    pub fn row_timings(&self) -> Vec<sim::RowTiming> {
        sim::row_timings(&self.tables, &self.max_hz, settings(&self.motion))
    }

    /// How far along its course (its line, or its section's path) the profile is at its own
    /// time `profile_s` (not the start's: see [`Window`]), mm.
    #[must_use]
    pub fn course_mm(&self, profile_s: f64) -> f64 {
        let s_mm = self.profile.distance_mm(profile_s);
        self.pace.as_ref().map_or(s_mm, |pace| pace.path_mm(s_mm))
    }

    /// When, on the profile's own time, the planned motion reaches `s_mm` along its course, s.
    #[must_use]
    pub fn time_at_course_mm(&self, s_mm: f64) -> f64 {
        let sigma_mm = self
            .pace
            .as_ref()
            .map_or(s_mm, |pace| pace.profile_mm(s_mm));
        self.profile.time_at_mm(sigma_mm)
    }

    /// The tool's slowest planned speed between `from_mm` and `to_mm` along its course while
    /// the profile cruises, mm/s: the profile's speed, lowered on a path's tight arcs.
    #[must_use]
    pub fn cruise_mm_s(&self, from_mm: f64, to_mm: f64) -> f64 {
        self.profile.speed_mm_s
            * self
                .pace
                .as_ref()
                .map_or(1.0, |pace| pace.slowest(from_mm, to_mm))
    }

    /// The planned position at time `t_s` of this start.
    #[must_use]
    pub fn planned_position_mm(&self, t_s: f64) -> nalgebra::Vector3<f64> {
        if let Some(path) = &self.path {
            return path
                .at(self.course_mm(self.window.from_s + t_s))
                .position_mm;
        }
        let s_mm = self.profile.distance_mm(self.window.from_s + t_s);
        match &self.joint_path {
            Some(path) => path.pose_at(s_mm / self.profile.length_mm).position_mm,
            None => self.line.at(s_mm).position_mm,
        }
    }

    /// The validated tables of the joints that move, for encoding; `None` for an invalid plan.
    #[must_use]
    pub fn valid_tables(&self, robot: &Robot) -> Option<Vec<ValidTable>> {
        if !self.valid() {
            return None;
        }
        self.tables
            .iter()
            .enumerate()
            .filter(|(_, t)| !t.segments.is_empty())
            .map(|(j, t)| crate::table::validate(t.clone(), robot.channel_limits(j)).ok())
            .collect()
    }
}

/// The most times `slow-down` lowers the speed before giving up.
const SLOW_DOWN_ATTEMPTS: usize = 24;

/// Plans one move for `robot`.
pub fn plan_move(robot: &Robot, req: &MoveRequest) -> Result<Plan, PlanError> {
    let (line, start_values, start_counts) = resolve_line(robot, req)?;
    robot.kinematics.check_line(&line)?;
    let length_mm = line.length_mm();
    if length_mm < 1e-6 {
        let p = line.from.position_mm;
        return Err(PlanError::ZeroLength {
            x: p.x,
            y: p.y,
            z: p.z,
        });
    }
    let start = Start {
        values: start_values,
        counts: start_counts,
    };
    if robot.has_dynamics() {
        dynamics::jerk_needs_s_curve(robot, req.motion.ramp)?;
        if let Ramp::SCurve { jerk_mm_s3 } = req.motion.ramp {
            let averaged = dynamics::rest_rows_first(&req.motion, |rows_any_length| {
                dynamics::averaged_line(robot, &line, &start, &req.motion, rows_any_length)
            });
            let course = Course::Line(line);
            let unslowed_s = unslowed_s_curve_s(&course, &req.motion, jerk_mm_s3);
            return dynamics::faster_s_curve(averaged, unslowed_s, Plan::duration_s, |floor| {
                dynamics::followed(floor, |k| {
                    let slowed = dynamics::slowed(&req.motion, k);
                    let check = |accels: &[f64; JOINTS], factor: f64| {
                        dynamics::clearly_over_max_accel(robot, accels, factor * k.sqrt() * 100.0)
                    };
                    let mut plan =
                        plan_course_checked(robot, &course, &start, slowed, Some(&check))?;
                    plan.speed_factor *= k.sqrt();
                    dynamics::within_limits(robot, &mut plan)?;
                    Ok(plan)
                })
            });
        }
        return dynamics::rest_rows_first(&req.motion, |rows_any_length| {
            let course = dynamics::timed_line(robot, &line, &start, &req.motion, rows_any_length)?;
            plan_course(robot, &course, &start, req.motion)
        });
    }
    plan_course(robot, &Course::Line(line), &start, req.motion)
}

/// The grid `motion`'s method samples a course on: bounded-error's fine samples
/// ([`bounded::SAMPLE_S`]), or the period.
fn grid_s(motion: &Motion) -> f64 {
    if motion.method.tolerance_mm().is_some() {
        bounded::SAMPLE_S
    } else {
        motion.period_s
    }
}

/// How long the S-curve `motion` (its jerk `jerk_mm_s3`) takes along `course` unslowed, on the
/// grid its method samples it on (`None` if it cannot be profiled).
fn unslowed_s_curve_s(course: &Course, motion: &Motion, jerk_mm_s3: f64) -> Option<f64> {
    let request = ProfileRequest {
        length_mm: course.length_mm(),
        speed_mm_s: motion.speed_mm_s,
        accel_s: motion.accel_s,
        period_s: grid_s(motion),
    };
    Profile::s_curve(request, jerk_mm_s3)
        .ok()
        .map(|p| p.duration_s())
}

/// Plans one joint-space move for `robot`: the target is checked against every joint's limits
/// (the joints move in proportion, so the start and the target bound every position between).
pub fn plan_joint_move(robot: &Robot, req: &JointMoveRequest) -> Result<Plan, PlanError> {
    let start = Start::at(robot, req.from)?;
    limits::check_target(robot, &req.to)?;
    let course = Course::joints(robot, start.values, req.to);
    if robot.counts_of(&req.to) == start.counts || course.length_mm() < 1e-9 {
        return Err(PlanError::NoTravel {
            counts: start.counts,
        });
    }
    dynamics::jerk_needs_s_curve(robot, req.motion.ramp)?;
    dynamics::rest_rows_first(&req.motion, |rows_any_length| {
        let motion = dynamics::joint_move_motion(
            robot,
            &start.values,
            &req.to,
            course.length_mm(),
            req.motion,
            rows_any_length,
        )?;
        let mut plan = plan_course(robot, &course, &start, motion)?;
        dynamics::within_limits(robot, &mut plan)?;
        Ok(plan)
    })
}

/// Where a move starts: joint values and the counts that stand for them.
struct Start {
    values: Joints,
    counts: [i64; JOINTS],
}

impl Start {
    /// The start `origin` gives: a pose's joint values and their nearest counts, or counts and
    /// the values they stand for.
    fn at(robot: &Robot, origin: Origin) -> Result<Self, PlanError> {
        Ok(match origin {
            Origin::Pose(pose) => {
                let values = robot.kinematics.ik(&pose, None)?;
                Self {
                    values,
                    counts: robot.counts_of(&values),
                }
            }
            Origin::Counts(counts) => Self {
                values: robot.values_of(&counts),
                counts,
            },
        })
    }
}

/// Plans a move along `course` from `start`: one start over the whole profile.
fn plan_course(
    robot: &Robot,
    course: &Course,
    start: &Start,
    asked: Motion,
) -> Result<Plan, PlanError> {
    plan_course_checked(robot, course, start, asked, None)
}

/// A check of a sampled motion before its rows are made: every joint's planned acceleration
/// (user units) and the speed factor `slow-down` left ([`plan_course_checked`]).
type MotionCheck<'a> = &'a dyn Fn(&[f64; JOINTS], f64) -> Result<(), PlanError>;

/// [`plan_course`], the sampled motion first checked by `check` (its every joint's planned
/// acceleration, user units, and the speed factor `slow-down` left): a motion refused on its
/// samples is refused before any rows are made.
fn plan_course_checked(
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
        sampled
            .plan(first, last, start.counts)
            .map_err(|e| sampled.named(e, first, last, start.counts))
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
        && let Some((cut, joint)) = path::reversal(&sampled, first, last)
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

/// A course sampled for one motion: the profile and the samples every start along it is planned
/// from (one start over the whole of it, or a path section cut into parts).
struct Sampled<'a> {
    robot: &'a Robot,
    course: &'a Course,
    /// The motion used (speed lowered by `slow-down` if it had to).
    motion: Motion,
    speed_factor: f64,
    profile: Profile,
    samples: Samples,
}

impl<'a> Sampled<'a> {
    fn new(
        robot: &'a Robot,
        course: &'a Course,
        start: &Start,
        asked: Motion,
    ) -> Result<Self, PlanError> {
        let mut motion = asked;
        let bounded = motion.method.tolerance_mm();
        let grid_s = grid_s(&motion);
        let sampler = Sampler {
            robot,
            course,
            grid_s,
            continuous: bounded.is_some(),
            start_values: &start.values,
            start_counts: start.counts,
        };
        let (profile, samples) = sampler.fast_enough(&mut motion)?;
        Ok(Self {
            robot,
            course,
            speed_factor: motion.speed_mm_s / asked.speed_mm_s,
            motion,
            profile,
            samples,
        })
    }

    /// The index of the last sample point (the course's end).
    fn last_point(&self) -> usize {
        self.samples.counts.len() - 1
    }

    /// The profile's time at sample point `i`, s.
    /// Whether a start is cut where a channel would need a later segment (a reversal, a run
    /// no one range plays): the PLC begins that segment up to a scan late while the other
    /// channels run on, which the execution model does not play. Every plan meant for a PLC;
    /// not the paper as printed.
    fn cut_for_segments(&self) -> bool {
        !self.motion.method.is_seed_exact()
    }

    /// The bounded-error tolerance, mm (`None`: a constant-period method).
    fn bounded(&self) -> Option<f64> {
        self.motion.method.tolerance_mm()
    }

    fn time_s(&self, i: usize) -> f64 {
        if i == self.last_point() {
            self.profile.duration_s()
        } else {
            i as f64 * self.profile.period_s
        }
    }

    /// The window and samples of the start from sample point `first` to `last`, from
    /// `counts`.
    fn part(&self, first: usize, last: usize, counts: [i64; JOINTS]) -> (Window, Samples) {
        let window = Window {
            from_s: self.time_s(first),
            to_s: self.time_s(last),
            ends_at_speed: last != self.last_point(),
        };
        let mut samples = Samples {
            counts: self.samples.counts[first..=last].to_vec(),
            values: self.samples.values[first..=last].to_vec(),
        };
        samples.counts[0] = counts;
        (window, samples)
    }

    /// The bounded-error planner of a part ([`Self::part`]).
    fn bounded_move<'m>(&'m self, window: &'m Window, samples: &'m Samples) -> bounded::Move<'m> {
        bounded::Move {
            robot: self.robot,
            course: self.course,
            profile: &self.profile,
            window,
            samples,
            motion: &self.motion,
        }
    }

    /// `refusal` of the start from `first` to `last` from `counts` as it reaches the user: a
    /// tolerance too small names the smallest found to work, and a joint slower than its
    /// channel plays ([`Self::plan`] leaves both out).
    fn named(
        &self,
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
                let (window, samples) = self.part(first, last, counts);
                let start = self.bounded_move(&window, &samples);
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

    /// Plans the start from sample point `first` to `last`, from `counts` (where the start
    /// before it ends, or where the move begins). A tolerance too small is refused without the
    /// one that works ([`Self::named`] adds it).
    fn plan(&self, first: usize, last: usize, counts: [i64; JOINTS]) -> Result<Plan, PlanError> {
        let robot = self.robot;
        let (window, samples) = self.part(first, last, counts);
        let (tables, problems, figures) = if let Some(tolerance_mm) = self.bounded() {
            let v = self.bounded_move(&window, &samples).plan(tolerance_mm)?;
            (v.tables, Vec::new(), v.figures)
        } else {
            let tables = build_tables(
                robot,
                &samples,
                &self.profile,
                window.duration_s(),
                &self.motion,
            );
            let problems = check_tables(robot, &tables, self.motion.method)?;
            let figures = simulate(
                robot,
                &tables,
                self.course,
                &self.profile,
                &window,
                &self.motion,
            );
            (tables, problems, figures)
        };
        let drive = if self.motion.method.is_seed_exact() {
            [DriveFigures::default(); JOINTS]
        } else {
            dynamics::judge(
                robot,
                &tables,
                &samples,
                self.profile.period_s,
                &window,
                settings(&self.motion),
            )?
        };
        Ok(Plan {
            line: self.course.chord(),
            joint_path: self.course.joint_path().cloned(),
            path: self.course.path().cloned(),
            pace: self.course.pace().cloned(),
            profile: self.profile,
            motion: self.motion,
            speed_factor: self.speed_factor,
            samples,
            tables,
            problems,
            max_hz: max_hz(robot),
            figures,
            window,
            drive,
        })
    }
}

type Resolved = (Line, crate::kinematics::Joints, [i64; JOINTS]);

fn resolve_line(robot: &Robot, req: &MoveRequest) -> Result<Resolved, PlanError> {
    crate::kinematics::check_finite(&req.to)?;
    match req.from {
        Origin::Pose(from) => {
            let q = robot.kinematics.ik(&from, None)?;
            Ok((Line { from, to: req.to }, q, robot.counts_of(&q)))
        }
        Origin::Counts(counts) => {
            let q = robot.values_of(&counts);
            Ok((
                Line {
                    from: robot.kinematics.fk(&q),
                    to: req.to,
                },
                q,
                counts,
            ))
        }
    }
}

/// Samples the course for one motion: the profile, the samples, and the fastest channel's load.
struct Sampler<'a> {
    robot: &'a Robot,
    course: &'a Course,
    grid_s: f64,
    continuous: bool,
    start_values: &'a crate::kinematics::Joints,
    start_counts: [i64; JOINTS],
}

impl Sampler<'_> {
    fn at(&self, motion: &Motion) -> Result<(Profile, Samples, limits::Peak), PlanError> {
        // A time-optimal pace starts and ends at rest itself: its profile has no ramp, and
        // under constant-period keeps its speed with a last period of its own length.
        let ramp = !self.course.pace().is_some_and(Pace::from_rest);
        let request = ProfileRequest {
            length_mm: self.course.length_mm(),
            speed_mm_s: motion.speed_mm_s,
            accel_s: if ramp { motion.accel_s } else { 0.0 },
            period_s: self.grid_s,
        };
        let profile = match (ramp, motion.ramp) {
            (true, Ramp::SCurve { jerk_mm_s3 }) => Profile::s_curve(request, jerk_mm_s3)?,
            (false, Ramp::SCurve { .. }) => return Err(PlanError::SCurveUnderDriveLimits),
            (true, Ramp::Trapezoid) => Profile::new(request)?,
            (false, Ramp::Trapezoid) if self.continuous => Profile::new(request)?,
            (false, Ramp::Trapezoid) => {
                Profile::paced(self.course.length_mm(), motion.speed_mm_s, self.grid_s)?
            }
        };
        let samples =
            self.course
                .sample(self.robot, &profile, self.start_values, self.start_counts)?;
        limits::check_positions(self.robot, &samples.counts, profile.period_s)?;
        let peak = limits::peak(self.robot, &samples, &profile, self.continuous);
        Ok((profile, samples, peak))
    }

    /// The profile and samples of `motion`, or under `slow-down` of the fastest speed (within
    /// 1 %) at which every channel fits; `motion.speed_mm_s` is set to the speed used. Speed and
    /// acceleration scale together (the ramp time stays).
    fn fast_enough(&self, motion: &mut Motion) -> Result<(Profile, Samples), PlanError> {
        let (profile, samples, peak) = self.at(motion)?;
        if peak.load <= 1.0 {
            return Ok((profile, samples));
        }
        if motion.over_speed == OverSpeed::Reject {
            return Err(limits::over_speed(self.robot, &peak));
        }
        let asked = *motion;
        let scaled = |f: f64| Motion {
            speed_mm_s: asked.speed_mm_s * f,
            ..asked
        };
        // Find a factor that fits. A triangular profile's peak speed goes with the square root of
        // its acceleration, and counts round to whole pulses: cut by the square of the overload,
        // and by at least 1 %.
        let (mut bad, mut factor, mut peak) = (1.0, 1.0, peak);
        let mut good = None;
        for _ in 0..SLOW_DOWN_ATTEMPTS {
            factor *= (0.999 / peak.load).powi(2).min(0.99);
            let (p, s, pk) = self.at(&scaled(factor))?;
            if pk.load <= 1.0 {
                good = Some((factor, p, s));
                break;
            }
            (bad, peak) = (factor, pk);
        }
        let Some((mut fits, mut profile, mut samples)) = good else {
            return Err(limits::over_speed(self.robot, &peak));
        };
        // Then the fastest that fits, to within 1 %.
        while bad / fits > 1.01 {
            let mid = (fits * bad).sqrt();
            let (p, s, pk) = self.at(&scaled(mid))?;
            if pk.load <= 1.0 {
                (fits, profile, samples) = (mid, p, s);
            } else {
                bad = mid;
            }
        }
        *motion = scaled(fits);
        Ok((profile, samples))
    }
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

pub(super) fn check_tables(
    robot: &Robot,
    tables: &[ChannelTable],
    method: Method,
) -> Result<Vec<String>, PlanError> {
    let seed_exact = method.is_seed_exact();
    let mut out = if seed_exact {
        seed_exact::problems()
    } else {
        Vec::new()
    };
    for (j, table) in tables.iter().enumerate() {
        let found = crate::table::problems(table, robot.channel_limits(j));
        if found.is_empty() {
            continue;
        }
        if !seed_exact {
            let more = found.len() - 1;
            let first = found.into_iter().next().expect("not empty");
            return Err(PlanError::InvalidTable {
                joint: robot.joints[j].name.clone(),
                first,
                more,
            });
        }
        out.extend(
            found
                .iter()
                .map(|p| format!("joint {}: {p}", robot.joints[j].name)),
        );
    }
    Ok(out)
}

#[cfg(test)]
mod tests;
