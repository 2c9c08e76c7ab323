//! PURE. The planner's strategy as values: the timings a course may be planned with
//! ([`Timing`]), the candidates a line, a path section or a joint move is planned with, in
//! order ([`Strategy::for_course`]), and the one function that plans them and keeps the fastest
//! plan every drive follows ([`plan_fastest`]). How one timing is planned is the course's own
//! ([`Timed`]: `line.rs`, `joint_move.rs`, `path/section.rs`).
//!
//! ```text
//! course          robot             ramp                       candidates, in order
//! line, section   no drive limits   trapezoid; an S-curve      as asked
//!                                   whose pace keeps one speed
//! section         no drive limits   S-curve, its pace changing averaged; as asked where that
//!                                   speed (tight arcs, caps)   is refused
//! line, section   drive limits      trapezoid                  time-optimal (a section again to
//!                                                              85 % and 70 % of the accelerations
//!                                                              where a drive refuses its rows)
//! line, section   drive limits      S-curve                    averaged; slowed as a whole where
//!                                                              that may be faster
//! joint move      any               any                        time-optimal: one trapezoid, the
//!                                                              slowest joint's
//! ```
//!
//! Under bounded-error every time-optimal and averaged timing is tried with the standstills'
//! zones planned for rows of any length first, and where that is refused for rows of a period
//! (as constant-period's always are): a joint's rows from rest that its windows make too fast are
//! narrowed, which on a long move can outgrow the table area, and the zone of a period plans what
//! it always did.

use crate::robot::{Motion, Ramp, Robot};

use super::dynamics::{RETIMING, jerk_needs_s_curve};
use super::error::PlanError;

/// One timing of a course: how the motion asked is run along it. Each is planned by the
/// course ([`Timed::plan`]); the strategy chooses among them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Timing {
    /// The profile asked along the course as it is: a line's straight on, a path section's at
    /// the pace its tight arcs allow (and under `slow-down` a trapezoid's channel caps), a
    /// channel too fast slowed for over the whole course (`slow-down`).
    AsAsked,
    /// The time-optimal motion under every limit (a trapezoid: the pace carries it), timed to
    /// `accel_share` of every joint's acceleration limits, its standstills' zones planned for
    /// rows of any length (`rows_any_length`, bounded-error) or for a period. A joint move's is
    /// one trapezoid, the slowest joint's.
    TimeOptimal {
        /// Whether the zones around standstills are planned for rows of any length.
        rows_any_length: bool,
        /// The share of every joint's acceleration limits planned to.
        accel_share: f64,
    },
    /// The S-curve asked, as the time-optimal motion averaged to its jerk
    /// ([`super::dynamics::averaged`]).
    Averaged {
        /// As for [`Timing::TimeOptimal`].
        rows_any_length: bool,
    },
    /// The S-curve asked slowed as a whole to share `k` of its accelerations (its speeds to
    /// `sqrt(k)`, its jerk to `k^1.5`, [`super::dynamics::slowed`]). As a candidate it is listed
    /// at `k = 1`, the first share tried: where a drive refuses it, the largest share every
    /// drive follows is searched ([`followed`]).
    Slowed {
        /// The share of the accelerations asked.
        k: f64,
    },
}

/// A line, a path section or a joint move, planned under one timing at a time.
pub(super) trait Timed {
    /// What planning it gives: one start, or a section's starts.
    type Planned;

    /// Plans it under `timing`.
    fn plan(&self, timing: Timing) -> Result<Self::Planned, PlanError>;

    /// How long `planned` runs, s.
    fn duration_s(planned: &Self::Planned) -> f64;

    /// A time no plan under `timing` beats, s, where it is known (`None`): a line's S-curve
    /// unslowed, for its slowed timing (slowing only lengthens it).
    fn fastest_s(&self, timing: Timing) -> Option<f64>;
}

/// What a course is, as the strategy reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// A line.
    Line,
    /// A path section; `pace_changes_speed`: without drive limits, an S-curve's pace as asked
    /// would change speed along it (a tight arc, a channel's cap), stepping its acceleration on
    /// and off past the jerk.
    Section {
        /// Whether the pace as asked changes speed along it.
        pace_changes_speed: bool,
    },
    /// A joint move.
    Joints,
}

/// When a candidate after the first is planned (the first always is).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum When {
    /// Where the plan kept so far is refused: the first that plans is kept.
    Refused,
    /// Where the plan kept so far is refused for a drive's rows ([`PlanError::refuses_rows`]):
    /// a timing to a lower share of the limits, which a drive may follow.
    RowsRefused,
    /// Where it may be faster than the plan kept ([`Timed::fastest_s`]), planned no slower than
    /// that plan: kept when it is no slower (on a tie, this one).
    Faster,
}

/// The candidates a course is planned with, in order.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Strategy {
    first: Timing,
    then: Vec<(When, Timing)>,
}

impl Strategy {
    /// The candidates for planning `kind` of course with `motion` for `robot` (the table in the
    /// module's docs). A trapezoid for a robot with a joint's `max_jerk` has none: refused
    /// naming the joint.
    pub(super) fn for_course(
        robot: &Robot,
        motion: &Motion,
        kind: Kind,
    ) -> Result<Self, PlanError> {
        jerk_needs_s_curve(robot, motion.ramp)?;
        let rows: &[bool] = if motion.method.tolerance_mm().is_some() {
            &[true, false]
        } else {
            &[false]
        };
        let s_curve = matches!(motion.ramp, Ramp::SCurve { .. });
        let refused = |timing| (When::Refused, timing);
        let averaged = rows
            .iter()
            .map(|&r| refused(Timing::Averaged { rows_any_length: r }));
        let listed: Vec<(When, Timing)> = match kind {
            Kind::Joints => time_optimal(rows, &[]),
            _ if robot.has_dynamics() && s_curve => averaged
                .chain([(When::Faster, Timing::Slowed { k: 1.0 })])
                .collect(),
            Kind::Section {
                pace_changes_speed: true,
            } if s_curve => averaged.chain([refused(Timing::AsAsked)]).collect(),
            Kind::Line if robot.has_dynamics() => time_optimal(rows, &[]),
            Kind::Section { .. } if robot.has_dynamics() => time_optimal(rows, &RETIMING),
            Kind::Line | Kind::Section { .. } => vec![refused(Timing::AsAsked)],
        };
        let mut listed = listed.into_iter();
        let (_, first) = listed.next().expect("every course has a candidate");
        Ok(Self {
            first,
            then: listed.collect(),
        })
    }
}

/// The time-optimal timings for each of `rows` (rows of any length, or of a period): at every
/// joint's whole acceleration limits where the ones before are refused, and again at each of
/// `retimings` where a drive refuses the rows of the one before.
fn time_optimal(rows: &[bool], retimings: &[f64]) -> Vec<(When, Timing)> {
    let mut out = Vec::new();
    for &rows_any_length in rows {
        for (when, accel_share) in std::iter::once((When::Refused, 1.0))
            .chain(retimings.iter().map(|&a| (When::RowsRefused, a)))
        {
            let timing = Timing::TimeOptimal {
                rows_any_length,
                accel_share,
            };
            out.push((when, timing));
        }
    }
    out
}

/// Plans `course` under the strategy's candidates in turn ([`When`] says which are planned) and
/// keeps the fastest plan every drive follows; the refusal of the last candidate planned when
/// none plans.
pub(super) fn plan_fastest<C: Timed>(
    course: &C,
    strategy: &Strategy,
) -> Result<C::Planned, PlanError> {
    let mut kept = search(course, strategy.first, 0.0);
    for &(when, timing) in &strategy.then {
        kept = match (when, kept) {
            (When::Refused, Err(_)) => search(course, timing, 0.0),
            (When::RowsRefused, Err(e)) if e.refuses_rows() => search(course, timing, 0.0),
            (When::Faster, kept) => {
                faster(kept, course.fastest_s(timing), C::duration_s, |floor| {
                    search(course, timing, floor)
                })
            }
            (_, kept) => kept,
        };
    }
    kept
}

/// Plans `course` under `timing`; a slowed timing at the largest share every drive follows,
/// no lower than `floor` ([`followed`]).
fn search<C: Timed>(course: &C, timing: Timing, floor: f64) -> Result<C::Planned, PlanError> {
    match timing {
        Timing::Slowed { .. } => followed(floor, |k| course.plan(Timing::Slowed { k })),
        timing => course.plan(timing),
    }
}

/// The faster of the plan `kept` and the one `rival(floor)` makes (by `duration_s`): the rival is
/// planned only when `kept` is refused or slower than the rival can be (`fastest_s`), and then
/// no slower than `kept` (`floor`, the least share of its accelerations a slowed rival tries:
/// slowed to share `k`, a motion takes `1 / sqrt(k)` of its time). On a tie, the rival; the
/// rival's refusal when both are refused.
fn faster<T>(
    kept: Result<T, PlanError>,
    fastest_s: Option<f64>,
    duration_s: impl Fn(&T) -> f64,
    rival: impl FnOnce(f64) -> Result<T, PlanError>,
) -> Result<T, PlanError> {
    let floor = match (&kept, fastest_s) {
        (Ok(plan), Some(fastest_s)) => {
            let kept_s = duration_s(plan);
            if kept_s <= fastest_s {
                return kept;
            }
            (fastest_s / kept_s).powi(2)
        }
        _ => 0.0,
    };
    match (kept, rival(floor)) {
        (Ok(a), Ok(s)) => Ok(if duration_s(&a) < duration_s(&s) {
            a
        } else {
            s
        }),
        (Ok(a), Err(_)) => Ok(a),
        (Err(_), rival) => rival,
    }
}

/// How many times the share is halved looking for one the drives follow: down to 1/64 (the
/// tool at 12.5 % of the speed asked; slower, a move's rows would outgrow its table area
/// before the drive's refusal could be named).
const HALVINGS: usize = 6;

/// How close the share found is to the largest the drives follow (a ratio).
const CLOSE: f64 = 1.05;

/// `plan` at share 1 of the accelerations, or, when a drive would not follow it, at the
/// largest share found that every drive follows; `plan(k)` plans the motion slowed to share
/// `k` ([`super::dynamics::slowed`]) and refuses one over a joint's `max_accel` or `max_jerk`
/// ([`super::dynamics::within_limits`]). No share below `floor` is tried (a faster plan is at
/// hand: a motion slowed to share `k` takes `1 / sqrt(k)` of its time). The refusal of the
/// slowest tried when none is followed; any other refusal at the largest share followed.
pub(super) fn followed<T>(
    floor: f64,
    plan: impl Fn(f64) -> Result<T, PlanError>,
) -> Result<T, PlanError> {
    let refused =
        |outcome: &Result<T, PlanError>| outcome.as_ref().is_err_and(PlanError::refused_by_a_drive);
    let first = plan(1.0);
    if !refused(&first) {
        return first;
    }
    let (mut bad, mut last) = (1.0, first);
    let mut found = None;
    for _ in 0..HALVINGS {
        let k = bad * 0.5;
        if k < floor {
            return last;
        }
        let outcome = plan(k);
        if !refused(&outcome) {
            found = Some((k, outcome));
            break;
        }
        (bad, last) = (k, outcome);
    }
    let Some((mut good, mut best)) = found else {
        return last;
    };
    // The outcome at the largest share followed: a plan, or why it is refused otherwise (a
    // slower motion has more rows: the fastest followed is the likeliest to fit its tables).
    while bad / good > CLOSE {
        let k = (good * bad).sqrt();
        let outcome = plan(k);
        if refused(&outcome) {
            bad = k;
        } else {
            (good, best) = (k, outcome);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Plans stood in for by their durations.
    fn faster(
        averaged: Result<f64, PlanError>,
        unslowed_s: Option<f64>,
        slowed: Result<f64, PlanError>,
    ) -> (Result<f64, PlanError>, Option<f64>) {
        let mut floor = None;
        let chosen = super::faster(
            averaged,
            unslowed_s,
            |d| *d,
            |f| {
                floor = Some(f);
                slowed
            },
        );
        (chosen, floor)
    }

    #[test]
    fn the_averaged_s_curve_is_taken_alone_when_no_slowing_could_beat_it() {
        // No slower than the S-curve unslowed: slowing only lengthens that.
        assert_eq!(faster(Ok(1.5), Some(1.5), Ok(1.4)), (Ok(1.5), None));
        // Slower than it: the slowed one is tried down to the share whose time is the
        // averaged one's, (1.5 / 2.0)^2, and the faster taken.
        assert_eq!(faster(Ok(2.0), Some(1.5), Ok(1.8)), (Ok(1.8), Some(0.5625)));
        assert_eq!(faster(Ok(2.0), Some(1.5), Ok(2.1)), (Ok(2.0), Some(0.5625)));
        // The slowed one refused (not even at that share): the averaged one.
        let refused = Err(PlanError::SCurveUnderDriveLimits);
        assert_eq!(
            faster(Ok(2.0), Some(1.5), refused.clone()),
            (Ok(2.0), Some(0.5625))
        );
        // The averaged one refused: the slowed one, searched all the way, or its refusal.
        assert_eq!(
            faster(refused.clone(), Some(1.5), Ok(2.6)),
            (Ok(2.6), Some(0.0))
        );
        assert_eq!(
            faster(refused.clone(), None, refused.clone()),
            (refused, Some(0.0))
        );
    }

    /// The search for the largest share every drive follows tries no share below its floor: a
    /// motion followed only at 0.45 of its accelerations is found from a floor of 0, and from a
    /// floor of 0.6 only share 1 is tried, its refusal the answer.
    #[test]
    fn slowing_as_a_whole_tries_no_share_below_its_floor() {
        let refusal = |k: f64| PlanError::SCurveOverMaxAccel {
            joint: "d3".into(),
            accel: 300.0 * 0.45 / k,
            max_accel: 300.0,
            unit: "mm",
            speed_pct: k.sqrt() * 100.0,
        };
        let tried = std::cell::RefCell::new(Vec::new());
        let plan = |k: f64| {
            tried.borrow_mut().push(k);
            if k <= 0.45 { Ok(k) } else { Err(refusal(k)) }
        };
        let found = followed(0.0, plan).unwrap();
        assert!((0.45 / 1.05..=0.45).contains(&found), "{found}");
        tried.borrow_mut().clear();
        let e = followed(0.6, plan).unwrap_err();
        assert_eq!(*tried.borrow(), vec![1.0]);
        assert!(matches!(e, PlanError::SCurveOverMaxAccel { .. }), "{e}");
    }
}
