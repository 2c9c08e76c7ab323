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
mod limits;
mod line_parts;
mod path;
mod samples;
mod seed_exact;
pub mod segments;

use thiserror::Error;

use crate::geometry::{Line, Pace, Path, PathError, Pose, Profile, ProfileError, ProfileRequest};
use crate::kinematics::{JOINTS, Joints, Kinematics, KinematicsError};
use crate::robot::{Method, Motion, OverSpeed, Robot};
use crate::sim::{self, Execution, Figures, Settings};
use crate::table::{ChannelTable, TableProblem, ValidTable};

use course::Course;
pub use course::JointPath;
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

/// Why a move cannot be planned.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PlanError {
    /// A pose or the path cannot be reached.
    #[error(transparent)]
    Kinematics(#[from] KinematicsError),
    /// The speed, acceleration time or period is unusable.
    #[error(transparent)]
    Profile(#[from] ProfileError),
    /// A path cannot be built from its elements.
    #[error(transparent)]
    Path(#[from] PathError),
    /// A path's acceleration limit is unusable.
    #[error("the path acceleration {accel_mm_s2} mm/s^2 must be a number above 0")]
    PathAccel {
        /// The limit given, mm/s^2.
        accel_mm_s2: f64,
    },
    /// A joint that first moves too late into a path section for one table to hold it back.
    #[error(
        "joint {joint} first moves {at_s:.2} s into the section, and an F174 table cannot hold \
         a channel back that long within the tolerance (its first pulse lands after one period \
         of a whole-hertz frequency: 1/1.5, 1/2, 1/3 s ...); stop at the waypoint before it \
         moves, or blend a corner where every joint is already moving"
    )]
    LateStart {
        /// The joint.
        joint: String,
        /// When it first moves, s into the section.
        at_s: f64,
    },
    /// A line on which a joint's channel needs a second F174 segment (it reverses, or its run
    /// changes frequency range) while another joint moves: one start would not play as
    /// planned through it, so the line runs as a path cut there ([`plan_line`]).
    #[error(
        "joint {joint} {} {at_mm:.1} mm along the {length_mm:.1} mm line while other joints \
         move: in one start its next F174 segment would begin up to a PLC scan late, off the \
         line by as much as the joint moves in a scan; the line runs as a path cut there into \
         starts chained at speed (`linterpd plan --path`, `linterpd run`)",
        if *reverses { "reverses" } else { "changes frequency range" }
    )]
    LaterSegment {
        /// The joint.
        joint: String,
        /// Whether it reverses there (else its run changes frequency range).
        reverses: bool,
        /// Where, mm along the line.
        at_mm: f64,
        /// The line's length, mm.
        length_mm: f64,
    },
    /// The robot is not where the path as written starts.
    #[error(
        "the path starts at [{:.3}, {:.3}, {:.3}] mm and the robot is at [{:.3}, {:.3}, {:.3}] \
         mm, {off_mm:.3} mm from it (at most {slack_mm} mm): move to the path's start first",
        start[0], start[1], start[2], robot[0], robot[1], robot[2]
    )]
    NotAtPathStart {
        /// The path's start: x, y, z mm, a deg.
        start: [f64; 4],
        /// The robot's pose: x, y, z mm, a deg.
        robot: [f64; 4],
        /// How far apart, mm.
        off_mm: f64,
        /// The most allowed, mm.
        slack_mm: f64,
    },
    /// The robot is not where a path section starts.
    #[error(
        "the robot is {off_mm:.3} mm from where the path section starts (at most {slack_mm} mm): \
         the move before it did not end where it was planned to"
    )]
    NotAtSectionStart {
        /// How far, mm.
        off_mm: f64,
        /// The most allowed, mm.
        slack_mm: f64,
    },
    /// A part of a path section chained at speed would begin from counts other than those it
    /// was planned from.
    #[error(
        "part {part} of the path section would begin from counts {counts:?}, not {planned:?} \
         where it was planned to begin; a part chained at speed starts only from the counts it \
         was planned from"
    )]
    NotAtPartStart {
        /// The part, from 1.
        part: usize,
        /// Where it would begin, per joint.
        counts: [i64; JOINTS],
        /// Where it was planned to begin, per joint.
        planned: [i64; JOINTS],
    },
    /// A path section planned again where it begins needs another number of starts than when
    /// the path was accepted.
    #[error(
        "the path section planned again where it begins needs {now} start(s), not the \
         {accepted} it was accepted with"
    )]
    PartsChanged {
        /// Starts when the path was accepted.
        accepted: usize,
        /// Starts now.
        now: usize,
    },
    /// A section of a path (between two stops) cannot be planned.
    #[error("path section {section} (element {elements}): {source}")]
    Section {
        /// Section number, from 1.
        section: usize,
        /// The elements it covers, "2" or "2-4".
        elements: String,
        /// Why.
        source: Box<PlanError>,
    },
    /// The target is the start.
    #[error(
        "the move from ({x:.3}, {y:.3}, {z:.3}) mm has length 0; a line move needs a distance above 0"
    )]
    ZeroLength {
        /// Start x, mm.
        x: f64,
        /// Start y, mm.
        y: f64,
        /// Start z, mm.
        z: f64,
    },
    /// A joint would leave its position limits.
    #[error(
        "joint {joint} would reach {value:.4} {unit} at t = {t_s:.3} s; its limits are {min} to {max} {unit}"
    )]
    OutOfLimit {
        /// Joint name.
        joint: String,
        /// The value, user units.
        value: f64,
        /// Lower limit, user units.
        min: f64,
        /// Upper limit, user units.
        max: f64,
        /// deg or mm.
        unit: &'static str,
        /// When, s.
        t_s: f64,
    },
    /// A joint move's target is beyond a joint's position limits.
    #[error("joint {joint} target {value:.4} {unit} is beyond its limits {min} to {max} {unit}")]
    TargetOutOfLimit {
        /// Joint name.
        joint: String,
        /// The target, user units.
        value: f64,
        /// Lower limit, user units.
        min: f64,
        /// Upper limit, user units.
        max: f64,
        /// deg or mm.
        unit: &'static str,
    },
    /// A joint move whose every target count is its start count.
    #[error(
        "the joint move ends where it starts (counts {counts:?}); a joint move needs a joint to \
         move at least one pulse"
    )]
    NoTravel {
        /// The start (and target) counts, per joint.
        counts: [i64; JOINTS],
    },
    /// A joint would need its channel faster than allowed.
    #[error(
        "joint {joint} would need {freq_hz:.0} Hz at t = {t_s:.3} s; channel {channel} allows {max_hz} Hz"
    )]
    OverSpeed {
        /// Joint name.
        joint: String,
        /// Frequency needed, Hz.
        freq_hz: f64,
        /// When, s.
        t_s: f64,
        /// The channel.
        channel: u8,
        /// Its maximum, Hz.
        max_hz: u32,
    },
    /// The tolerance asked of a bounded-error plan cannot be met.
    #[error(
        "tolerance {tolerance_mm} mm is below what this move can reach: with every pulse on time the path \
         still deviates {floor_mm:.4} mm{}",
        works_mm.map_or(String::new(), |w| format!("; {w} mm works"))
    )]
    ToleranceTooSmall {
        /// The tolerance asked for, mm.
        tolerance_mm: f64,
        /// The pulse grid's own path deviation on this move, mm.
        floor_mm: f64,
        /// The smallest tolerance found to work, mm.
        works_mm: Option<f64>,
    },
    /// The tables break an F174 rule or do not fit their area.
    #[error("joint {joint}: {first}{}", if *more > 0 { format!(" (and {more} more problems)") } else { String::new() })]
    InvalidTable {
        /// Joint name.
        joint: String,
        /// The first problem.
        first: TableProblem,
        /// How many more.
        more: usize,
    },
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
    /// Speed actually used over speed asked for (1 unless `slow-down` acted).
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
    plan_course(robot, &Course::Line(line), &start, req.motion)
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
    plan_course(robot, &course, &start, req.motion)
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
    let sampled = Sampled::new(robot, course, start, asked)?;
    let (first, last) = (0, sampled.last_point());
    let Course::Line(line) = course else {
        return sampled.plan(first, last, start.counts);
    };
    let later = |joint: usize, reverses: bool, at_s: f64| PlanError::LaterSegment {
        joint: robot.joints[joint].name.clone(),
        reverses,
        at_mm: sampled.profile.distance_mm(at_s),
        length_mm: line.length_mm(),
    };
    if sampled.cut_for_segments()
        && let Some((cut, joint)) = path::reversal(&sampled, first, last)
    {
        return Err(later(joint, true, sampled.time_s(cut)));
    }
    let plan = sampled.plan(first, last, start.counts)?;
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
        let grid_s = if bounded.is_some() {
            bounded::SAMPLE_S
        } else {
            motion.period_s
        };
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

    /// Plans the start from sample point `first` to `last`, from `counts` (where the start
    /// before it ends, or where the move begins).
    fn plan(&self, first: usize, last: usize, counts: [i64; JOINTS]) -> Result<Plan, PlanError> {
        let robot = self.robot;
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
        let (tables, problems, figures) = if let Some(tolerance_mm) = self.bounded() {
            let m = bounded::Move {
                robot,
                course: self.course,
                profile: &self.profile,
                window: &window,
                samples: &samples,
                motion: &self.motion,
            };
            let v = m.plan(tolerance_mm)?;
            (v.tables, Vec::new(), v.figures)
        } else {
            let tables = build_tables(robot, &samples, &self.profile, &self.motion);
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
        })
    }
}

/// Plays `tables` in the execution model and measures them against the course and profile
/// over `window`.
fn simulate(
    robot: &Robot,
    tables: &[ChannelTable],
    course: &Course,
    profile: &Profile,
    window: &Window,
    motion: &Motion,
) -> Figures {
    simulate_within(
        robot,
        tables,
        course,
        profile,
        window,
        motion,
        f64::INFINITY,
    )
    .expect("no limit")
}

/// Every joint's channel's top frequency, Hz.
fn max_hz(robot: &Robot) -> [u32; JOINTS] {
    std::array::from_fn(|j| robot.joints[j].max_freq_hz)
}

/// How the planner plays its own tables: the motion's frequency model, no time between a
/// channel's segments (its report; the mock PLC adds its scan).
fn settings(motion: &Motion) -> Settings {
    Settings {
        model: motion.frequency_model,
        segment_gap_s: 0.0,
    }
}

/// [`simulate`], giving up as soon as the path deviation passes `path_limit_mm`. The run is
/// measured as it is played, pulse by pulse, and not kept. A start that ends at speed (a part
/// of a cut path section) has its end error measured against where the profile is when it
/// ends, not against the course's end.
fn simulate_within(
    robot: &Robot,
    tables: &[ChannelTable],
    course: &Course,
    profile: &Profile,
    window: &Window,
    motion: &Motion,
    path_limit_mm: f64,
) -> Option<Figures> {
    let run = Run {
        robot,
        tables,
        course,
        window,
        motion,
        path_limit_mm,
    };
    if let Course::Line(line) = course {
        run.measure(&OnLine::new(line, profile, window.from_s))
    } else if let (Some(path), Some(pace)) = (course.path(), course.pace()) {
        run.measure(&OnPath {
            path,
            pace,
            profile,
            from_s: window.from_s,
            hint: std::cell::Cell::new(0),
        })
    } else {
        let position = course.positions();
        run.measure(&|t: f64| position(profile.distance_mm(window.from_s + t)))
    }
}

/// A start's tables played and measured by [`simulate_within`].
struct Run<'a> {
    robot: &'a Robot,
    tables: &'a [ChannelTable],
    course: &'a Course,
    window: &'a Window,
    motion: &'a Motion,
    path_limit_mm: f64,
}

impl Run<'_> {
    /// Measures the run against the planned position `planned` (the start's own time).
    fn measure(&self, planned: &impl sim::Planned) -> Option<Figures> {
        let (robot, tables) = (self.robot, self.tables);
        let max_hz = max_hz(robot);
        let settings = settings(self.motion);
        let duration_s = self.window.duration_s();
        let mut figures = sim::measure_within(
            robot,
            tables,
            sim::pulses(tables, &max_hz, settings),
            &sim::finish_times(tables, &max_hz, settings),
            self.course.tool_path(),
            planned,
            duration_s,
            self.path_limit_mm,
        )?;
        if self.window.ends_at_speed {
            let end: [i64; JOINTS] = std::array::from_fn(|j| tables[j].end());
            let there = robot.pose_of(&end).position_mm;
            figures.end_error_mm = (there - planned.at(duration_s)).norm();
        }
        Some(figures)
    }
}

/// The planned position of a start on a line: the profile's distance from `from_s` on, along
/// the line (the same values as [`Course::positions`]), and near it without a division.
struct OnLine<'a> {
    profile: &'a Profile,
    from_s: f64,
    from: nalgebra::Vector3<f64>,
    d: nalgebra::Vector3<f64>,
    len: f64,
    inv_len: f64,
    /// How far the position made with `inv_len` may be from the one made with `len`, mm: a
    /// few roundings of the largest coordinates involved.
    off_mm: f64,
}

impl<'a> OnLine<'a> {
    fn new(line: &Line, profile: &'a Profile, from_s: f64) -> Self {
        let from = line.from.position_mm;
        let d = line.to.position_mm - from;
        let len = d.norm();
        Self {
            profile,
            from_s,
            from,
            d,
            len,
            inv_len: if len > 0.0 { 1.0 / len } else { 0.0 },
            off_mm: 16.0 * f64::EPSILON * (from.norm() + len),
        }
    }
}

impl sim::Planned for OnLine<'_> {
    fn at(&self, t_s: f64) -> nalgebra::Vector3<f64> {
        let s_mm = self.profile.distance_mm(self.from_s + t_s);
        self.from + self.d * if self.len > 0.0 { s_mm / self.len } else { 1.0 }
    }

    // Called on every pulse of the measurement, and inlined there: left to itself the compiler
    // stopped inlining it after an unrelated change, and the constant-period plan took 10 %
    // longer.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn near(&self, t_s: f64) -> (nalgebra::Vector3<f64>, f64) {
        if self.len <= 0.0 {
            return (self.at(t_s), 0.0);
        }
        let s_mm = self.profile.distance_mm(self.from_s + t_s);
        (self.from + self.d * (s_mm * self.inv_len), self.off_mm)
    }
}

/// The planned position of a start on a path section: the profile's distance from `from_s` on,
/// through the pace, along the path (the same values as [`Course::positions`]), and near it
/// without a root or a division on a line piece ([`Path::near`]).
struct OnPath<'a> {
    path: &'a crate::geometry::Path,
    pace: &'a crate::geometry::Pace,
    profile: &'a Profile,
    from_s: f64,
    /// The piece the last position fell on.
    hint: std::cell::Cell<usize>,
}

impl OnPath<'_> {
    #[inline]
    fn path_mm(&self, t_s: f64) -> f64 {
        self.pace
            .path_mm(self.profile.distance_mm(self.from_s + t_s))
    }
}

impl sim::Planned for OnPath<'_> {
    fn at(&self, t_s: f64) -> nalgebra::Vector3<f64> {
        self.path.at(self.path_mm(t_s)).position_mm
    }

    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn near(&self, t_s: f64) -> (nalgebra::Vector3<f64>, f64) {
        let s_mm = self.path_mm(t_s);
        let mut hint = self.hint.get();
        let near = self.path.near(s_mm, &mut hint);
        self.hint.set(hint);
        near.unwrap_or_else(|| (self.path.at(s_mm).position_mm, 0.0))
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
        let profile = Profile::new(ProfileRequest {
            length_mm: self.course.length_mm(),
            speed_mm_s: motion.speed_mm_s,
            accel_s: motion.accel_s,
            period_s: self.grid_s,
        })?;
        let samples =
            self.course
                .sample(self.robot, &profile, self.start_values, self.start_counts)?;
        limits::check_positions(self.robot, &samples.counts, profile.period_s)?;
        let peak = limits::peak(self.robot, &samples, profile.period_s, self.continuous);
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

fn build_tables(
    robot: &Robot,
    samples: &Samples,
    profile: &Profile,
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
            let spans = constant_period::spans(&counts, profile.period_s);
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
