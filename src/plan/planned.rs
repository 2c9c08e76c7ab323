//! PURE. A planned start as the planner returns it: its tables, the profile and samples they
//! were made from, the execution model's figures and how hard each drive is asked
//! ([`DriveFigures`]); and how the planner plays its own tables ([`settings`]).

use crate::geometry::{Line, Pace, Path, Profile};
use crate::kinematics::JOINTS;
use crate::robot::{Motion, Robot};
use crate::sim::{self, Execution, Figures, Settings};
use crate::table::{ChannelTable, ValidTable};

use super::joint_path::JointPath;
use super::samples::Samples;

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

/// How one joint's drive is asked to follow its table in one start.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DriveFigures {
    /// The fastest row's real frequency, Hz.
    pub peak_hz: f64,
    /// The joint's fastest planned speed, deg/s or mm/s.
    pub peak_speed: f64,
    /// The joint's largest planned acceleration, deg/s^2 or mm/s^2 (from the samples: over
    /// a period for constant-period, over a millisecond for bounded-error).
    pub peak_accel: f64,
    /// The joint's largest planned jerk, deg/s^3 or mm/s^3: the change of its acceleration over
    /// 10 ms (measured for an S-curve on a robot with a joint's `max_jerk`, else `None`).
    pub peak_jerk: Option<f64>,
    /// The largest step between two consecutive rows as a share of what `max_accel` allows
    /// (`None` without `max_accel`, or with fewer than two rows).
    pub step_load: Option<f64>,
    /// The fastest row from or into standstill, Hz.
    pub rest_hz: f64,
}

/// Every joint's channel's top frequency, Hz.
pub(super) fn max_hz(robot: &Robot) -> [u32; JOINTS] {
    std::array::from_fn(|j| robot.joints[j].max_freq_hz)
}

/// How the planner plays its own tables: the motion's frequency model, no time between a
/// channel's segments (its report; the mock PLC adds its scan).
pub(super) fn settings(motion: &Motion) -> Settings {
    Settings {
        model: motion.frequency_model,
        segment_gap_s: 0.0,
    }
}
