//! PURE. The judgement of a plan: its tables played in the execution model (`crate::sim`) and
//! measured against the course and profile they were planned on, the tool's own path under the
//! planned joints for a joint move.

use crate::geometry::{Line, Profile};
use crate::kinematics::JOINTS;
use crate::robot::{Method, Motion, Robot};
use crate::sim::{self, Figures};
use crate::table::ChannelTable;

use super::course::Course;
use super::error::PlanError;
use super::planned::{Window, max_hz, settings};
use super::seed_exact;

/// Plays `tables` in the execution model and measures them against the course and profile
/// over `window`.
pub(super) fn simulate(
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

/// [`simulate`], giving up as soon as the path deviation passes `path_limit_mm`. The run is
/// measured as it is played, pulse by pulse, and not kept. A start that ends at speed (a part
/// of a cut path section) has its end error measured against where the profile is when it
/// ends, not against the course's end.
pub(super) fn simulate_within(
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
pub(super) struct Run<'a> {
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
pub(super) struct OnLine<'a> {
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
/// without a root or a division on a line piece ([`crate::geometry::Path::near`]).
pub(super) struct OnPath<'a> {
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
