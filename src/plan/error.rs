//! PURE. Why a move or a path cannot be planned: one error enum for the planner, each variant
//! with the values and limits its message names.

use thiserror::Error;

use crate::geometry::{PathError, ProfileError};
use crate::kinematics::{JOINTS, KinematicsError};
use crate::table::TableProblem;

/// A joint moving slower than the lowest frequency its channel plays: an F174 row cannot wait,
/// so its pulses land early however its rows are chosen (at best each a lowest-frequency
/// period after the one before).
#[derive(Debug, Clone, PartialEq, Error)]
#[error(
    "joint {joint} moves at {rate_hz:.2} pulses/s for {over_s:.2} s, slower than {lowest_hz:.2} \
     Hz, the lowest frequency its channel plays: even at that frequency its pulse due {at_s:.2} \
     s in lands {early_s:.2} s early, ahead of the path (a faster move keeps it in range)"
)]
pub struct Creep {
    /// The joint's name.
    pub joint: String,
    /// Its mean pulse rate over the stretch it runs ahead on, pulses/s.
    pub rate_hz: f64,
    /// How long that stretch lasts, up to the pulse that lands earliest, s.
    pub over_s: f64,
    /// The lowest frequency its channel plays under the plan's frequency model, Hz.
    pub lowest_hz: f64,
    /// When the pulse that lands earliest is due, s from the start.
    pub at_s: f64,
    /// How early it lands at best, s.
    pub early_s: f64,
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
    /// planned through it, so the line runs as a path cut there ([`plan_line`](super::plan_line)).
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
        "joint {joint} would reach {} {unit} at t = {t_s:.3} s; its limits are {min} to {max} {unit}",
        crate::geometry::shown(*.value, 4)
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
    #[error(
        "joint {joint} target {} {unit} is beyond its limits {min} to {max} {unit}",
        crate::geometry::shown(*.value, 4)
    )]
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
    #[error("{}", tolerance_refusal(*tolerance_mm, *floor_mm, creep.as_ref(), *works_mm))]
    ToleranceTooSmall {
        /// The tolerance asked for, mm.
        tolerance_mm: f64,
        /// The pulse grid's own path deviation on this move, mm.
        floor_mm: f64,
        /// A joint slower than its channel plays, which runs ahead of the path whatever the
        /// rows (named in a refusal that reaches the user).
        creep: Option<Creep>,
        /// The smallest tolerance found to work, mm.
        works_mm: Option<f64>,
    },
    /// A joint's `start_hz` is below what a row from rest of the plan's length carries in its
    /// pulse of rounding alone.
    #[error(
        "joint {joint}: start_hz = {start_hz} Hz cannot be kept by rows of {row_s} s from rest: \
         one pulse of rounding is {min_hz:.1} Hz on its own; raise start_hz to at least \
         {min_hz:.1} Hz or plan with a longer period"
    )]
    StartHzTooLow {
        /// Joint name.
        joint: String,
        /// Its start frequency, Hz.
        start_hz: f64,
        /// The lowest start frequency rows of `row_s` keep, Hz.
        min_hz: f64,
        /// How long a row from rest lasts, s.
        row_s: f64,
    },
    /// An S-curve asked to follow a time-optimal pace, whose accelerations step on and off (a
    /// guard: under drive limits an S-curve is slowed as a whole instead, see
    /// `dynamics::followed`).
    #[error(
        "profile \"s-curve\" cannot follow a time-optimal pace, whose accelerations step on \
         and off; an S-curve under drive limits is slowed as a whole instead"
    )]
    SCurveUnderDriveLimits,
    /// No motion along the course keeps every limit at some point of it.
    #[error("no motion {at_mm:.1} mm along the course keeps every limit: {reason}")]
    Untimed {
        /// Where, mm along the course.
        at_mm: f64,
        /// Why.
        reason: &'static str,
    },
    /// An S-curve slowed as far as it is slowed still asks a joint for more acceleration than
    /// its `max_accel`.
    #[error(
        "joint {joint}: profile \"s-curve\" asks it for {accel:.1} {unit}/s^2 even slowed to \
         {speed_pct:.1} % of the speed asked for; max_accel = {max_accel} {unit}/s^2"
    )]
    SCurveOverMaxAccel {
        /// Joint name.
        joint: String,
        /// Its largest planned acceleration at the slowest tried, user units/s^2.
        accel: f64,
        /// The joint's limit, user units/s^2.
        max_accel: f64,
        /// deg or mm.
        unit: &'static str,
        /// The slowest speed tried, % of the speed asked for.
        speed_pct: f64,
    },
    /// An S-curve slowed as far as it is slowed still asks a joint for more jerk than its
    /// `max_jerk` (the change of its planned acceleration over 10 ms).
    #[error(
        "joint {joint}: the motion asks it for a jerk of {jerk:.1} {unit}/s^3 (its acceleration's \
         change over 10 ms) even slowed to {speed_pct:.1} % of the speed asked for; max_jerk = \
         {max_jerk} {unit}/s^3"
    )]
    OverMaxJerk {
        /// Joint name.
        joint: String,
        /// Its largest planned jerk at the slowest tried, user units/s^3.
        jerk: f64,
        /// The joint's limit, user units/s^3.
        max_jerk: f64,
        /// deg or mm.
        unit: &'static str,
        /// The slowest speed tried, % of the speed asked for.
        speed_pct: f64,
    },
    /// A trapezoid asked of a robot with a joint's `max_jerk`: its acceleration steps at once.
    #[error(
        "joint {joint} has max_jerk = {max_jerk} {unit}/s^3, which only profile \"s-curve\" \
         keeps (a trapezoid steps its acceleration at once); ask for profile \"s-curve\""
    )]
    JerkNeedsSCurve {
        /// Joint name.
        joint: String,
        /// The joint's limit, user units/s^3.
        max_jerk: f64,
        /// deg or mm.
        unit: &'static str,
    },
    /// Two consecutive rows of a joint's table step by more than its drive follows.
    #[error(
        "joint {joint}: its rows step from {from_hz:.1} Hz to {to_hz:.1} Hz at t = {t_s:.3} s; \
         max_accel = {max_accel} {unit}/s^2 allows {allowed_hz:.1} Hz between them"
    )]
    RowStep {
        /// Joint name.
        joint: String,
        /// When the second row begins, s.
        t_s: f64,
        /// The first row's frequency, Hz.
        from_hz: f64,
        /// The second's, Hz.
        to_hz: f64,
        /// The largest step allowed between them (rounding and the frequency model's step
        /// included), Hz.
        allowed_hz: f64,
        /// The joint's limit, user units/s^2.
        max_accel: f64,
        /// deg or mm.
        unit: &'static str,
    },
    /// A row that leaves or reaches standstill runs faster than the joint's drive follows.
    #[error(
        "joint {joint}: its row {} standstill at t = {t_s:.3} s runs at {freq_hz:.1} Hz; {limit} \
         allows {limit_hz:.1} Hz",
        if *from_rest { "from" } else { "into" }
    )]
    RestRow {
        /// Joint name.
        joint: String,
        /// When the row begins, s.
        t_s: f64,
        /// Whether it leaves standstill (else it reaches it).
        from_rest: bool,
        /// Its frequency, Hz.
        freq_hz: f64,
        /// The most allowed, Hz.
        limit_hz: f64,
        /// Which limit: `start_hz`, or `max_accel` over half the row.
        limit: &'static str,
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
    /// A joint move whose tables do not fit one start ([`PlanError::too_big`]): a joint move
    /// runs as one start and is never cut into parts.
    #[error(
        "{source}: a joint move runs as one start and is not cut into parts; ask for a faster \
         speed, or a longer period (constant-period) or a larger tolerance (bounded-error) for \
         fewer rows, or move there as a line (a pose target), which runs in parts chained at speed"
    )]
    JointMoveTooLong {
        /// Why one start cannot hold it.
        source: Box<PlanError>,
    },
    /// A line whose tables do not fit one start ([`PlanError::too_big`]) and that cannot run
    /// as parts chained at speed either.
    #[error(
        "{source}; cut into parts chained at speed it cannot run either: {parts}; ask for a \
         faster speed, or a longer period (constant-period) or a larger tolerance \
         (bounded-error) for fewer rows, or send it as a path of shorter lines"
    )]
    NoParts {
        /// Why one start cannot hold it.
        source: Box<PlanError>,
        /// Why its parts cannot be planned.
        parts: Box<PlanError>,
    },
}

impl PlanError {
    /// This refusal of a line's one start for its size ([`Self::too_big`]), with `parts`, why
    /// the line as a path of parts chained at speed cannot be planned either.
    #[must_use]
    pub fn no_parts(self, parts: PlanError) -> PlanError {
        PlanError::NoParts {
            source: Box::new(self),
            // The line is the path's one section: its error is the line's.
            parts: match parts {
                PlanError::Section { source, .. } => source,
                e => Box::new(e),
            },
        }
    }

    /// Whether a start's tables are refused only for their size (a channel's table needs more
    /// words than its area holds, or more than 8 segments): shorter starts would fit.
    #[must_use]
    pub fn too_big(&self) -> bool {
        matches!(
            self,
            Self::InvalidTable {
                first: TableProblem::TooManySegments { .. } | TableProblem::AreaOverflow { .. },
                ..
            }
        )
    }

    /// Whether a drive refused a table's rows: a row step over its `max_accel`, a row from or
    /// into rest over its `start_hz`. A timing to lower shares of the limits may be followed.
    pub(super) fn refuses_rows(&self) -> bool {
        matches!(self, Self::RowStep { .. } | Self::RestRow { .. })
    }

    /// Whether a drive refused: its rows ([`Self::refuses_rows`]), or the planned motion over
    /// its `max_accel` or its `max_jerk`. A slower motion may be followed.
    pub(super) fn refused_by_a_drive(&self) -> bool {
        self.refuses_rows()
            || matches!(
                self,
                Self::SCurveOverMaxAccel { .. } | Self::OverMaxJerk { .. }
            )
    }
}

/// [`PlanError::ToleranceTooSmall`]'s message.
fn tolerance_refusal(
    tolerance_mm: f64,
    floor_mm: f64,
    creep: Option<&Creep>,
    works_mm: Option<f64>,
) -> String {
    let creep = creep.map_or(String::new(), |c| format!(": {c}"));
    let works = works_mm.map_or(String::new(), |w| format!("; {w} mm works"));
    if floor_mm >= tolerance_mm {
        format!(
            "tolerance {tolerance_mm} mm is below what this move can reach: with every pulse on \
             time the path still deviates {floor_mm:.4} mm{works}"
        )
    } else {
        format!(
            "no rows found that keep this move within tolerance {tolerance_mm} mm: with every \
             pulse on time the path deviates {floor_mm:.4} mm, but every set of rows tried ran \
             further off it{creep}; a larger tolerance may plan it{works}"
        )
    }
}
