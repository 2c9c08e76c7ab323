//! PURE. The time-optimal motion along a line or a path section under every limit at once
//! ([`crate::geometry::topp`]), as the pace its profile runs at:
//! - the path's speed (the move's) and tangential acceleration (speed over acceleration time);
//! - on an arc, the path's centripetal acceleration (`v² <= a r`);
//! - under `slow-down`, every joint's speed within its channel's top frequency;
//! - every joint's `max_accel` through the path's derivatives (`q' s̈ + q'' ṡ²`, by inverse
//!   kinematics on a grid);
//! - around every standstill of a joint with `start_hz` (the move's ends, where it reverses),
//!   a lower acceleration, so the row that leaves or reaches it stays within `start_hz`.
//!
//! The speed drops only where a limit needs it (near the base axis, on a tight arc, where a
//! joint reverses), never over the whole move.

use crate::geometry::topp::{self, AccelLimit, GridPoint};
use crate::geometry::{Pace, Pose};
use crate::kinematics::{JOINTS, Joints, Kinematics};
use crate::robot::{Motion, OverSpeed, Robot};

use crate::plan::error::PlanError;

/// The grid's spacing along the path, mm.
const GRID_MM: f64 = 0.5;
/// The fewest and the most grid points.
const GRID_POINTS: (usize, usize) = (64, 4_000);
/// The shares of every joint's acceleration limit a path section is timed to again, in turn,
/// when the rows of the timing before were refused for a drive ([`Shares::accel`]).
pub(in crate::plan) const RETIMING: [f64; 2] = [0.85, 0.7];
/// The fewest grid steps on one piece of a path.
const PIECE_STEPS: usize = 4;
/// How far either side of where two pieces meet a joint's rate is measured, mm.
const KINK_PROBE_MM: f64 = 1e-5;
/// The share of a joint's `max_accel` over a period that its speed may jump by at a kink; the
/// rest of the acceleration is what its zone leaves ([`kink_zones`]).
const KINK_SHARE: f64 = 0.45;
/// A jump in a joint's rate by distance below this, per mm, is the probe's rounding (and a
/// smooth joint's curvature over it), not a kink.
const KINK_MIN_PER_MM: f64 = 1e-6;
/// The share of a joint's `max_accel` planned to: the limits hold at the grid's points, and
/// the joints' derivatives change a little between them.
pub(in crate::plan) const ACCEL_MARGIN: f64 = 0.98;
/// The share of a channel's top frequency planned to (the rows' rounding takes a pulse per
/// row more).
const SPEED_MARGIN: f64 = 0.99;
/// The share of `start_hz` a row from or to rest is planned to, before its pulse of rounding.
pub(in crate::plan) const START_MARGIN: f64 = 0.97;
/// The longest row from or to rest, in periods: a time-optimal profile's last period is up to
/// a period and a half ([`crate::geometry::Profile::paced`]).
pub(in crate::plan) const REST_ROW_PERIODS: f64 = 1.5;

/// A line or a path section, as the timing reads it.
pub(in crate::plan) struct Shape<'a> {
    /// Its length, mm.
    pub length_mm: f64,
    /// The pose at a distance along it.
    pub pose_at: &'a dyn Fn(f64) -> Pose,
    /// Its curvature at a distance along it, 1/mm (0 on a line).
    pub curvature_at: &'a dyn Fn(f64) -> f64,
    /// Where its pieces meet, mm from its start, ascending (none on a line): grid points, so
    /// that every step of the grid lies on one piece.
    pub breaks_mm: &'a [f64],
}

/// The limits along the path beyond the joints'.
pub(in crate::plan) struct PathLimits {
    /// The path's centripetal acceleration limit, mm/s^2 (infinite on a line).
    pub centripetal_mm_s2: f64,
    /// The period, s: a row from or to rest lasts between half a period and a period and a
    /// half, and a standstill's zone of lower acceleration lasts the longest either side.
    pub rest_row_s: f64,
    /// Whether rows are of any length (`bounded-error`): a standstill's zone is then planned
    /// for the row from rest that leaves the joint the most acceleration ([`rest_accels`]),
    /// not for a period.
    pub rows_any_length: bool,
    /// The shares of the limits the timing plans to ([`Shares`]).
    pub shares: Shares,
}

/// The shares of the limits a path is timed to ([`PathLimits`]).
#[derive(Debug, Clone, Copy)]
pub(in crate::plan) struct Shares {
    /// The share of every joint's acceleration limit (`max_accel`, and what `start_hz` and a
    /// kink leave): 1, or less when a first timing's rows were refused ([`RETIMING`]).
    pub accel: f64,
    /// The share of every channel's top frequency: 1, or less where an averaged S-curve's
    /// speeds passed it (the average of a motion speeding up after a stretch slowed for a
    /// channel reaches that stretch faster than the motion did).
    pub speed: f64,
    /// The share of the centripetal limit: 1, or less where an averaged S-curve passed it (the
    /// average of a motion that slowed for an arc enters the arc faster than the motion did).
    pub centripetal: f64,
}

impl Shares {
    /// Every limit whole.
    pub(in crate::plan) const WHOLE: Self = Self {
        accel: 1.0,
        speed: 1.0,
        centripetal: 1.0,
    };
}

/// The joints along the grid: values, first and second derivatives by distance.
///
/// A point's derivatives are those of the step from it to the next, which its limits hold
/// over ([`zone`]): central differences on a piece, and where two pieces meet, the next
/// piece's own (a joint's rate there may step, even reverse: the two sides' mean is neither).
struct JointsAlong {
    s_mm: Vec<f64>,
    q: Vec<Joints>,
    dq: Vec<Joints>,
    ddq: Vec<Joints>,
    /// Where two pieces meet, the grid point and every joint's rate by distance on the piece
    /// that ends there (the speed at the point holds on both sides).
    rate_before: Vec<(usize, Joints)>,
    /// Where two pieces meet with a joint's rate by distance changing at once (a kink: the
    /// tool angle goes at each piece's own rate): the grid point and every joint's jump, per mm.
    kinks: Vec<(usize, Joints)>,
}

/// Every joint's second derivative by distance at every point of `s_mm` (`q` the joints
/// there): central differences, the ends taking their neighbour's.
fn second_rates(s_mm: &[f64], q: &[Joints]) -> Vec<Joints> {
    let n = s_mm.len() - 1;
    (0..=n)
        .map(|i| {
            let m = i.clamp(1, n - 1);
            let (h1, h2) = (s_mm[m] - s_mm[m - 1], s_mm[m + 1] - s_mm[m]);
            std::array::from_fn(|j| {
                let (back, on) = ((q[m][j] - q[m - 1][j]) / h1, (q[m + 1][j] - q[m][j]) / h2);
                2.0 * (on - back) / (h1 + h2)
            })
        })
        .collect()
}

/// At every break between pieces, every joint's jump in rate by distance, per mm: probed
/// [`KINK_PROBE_MM`] before and after the point.
fn kinks(
    robot: &Robot,
    shape: &Shape,
    s_mm: &[f64],
    q: &[Joints],
    breaks: &[usize],
) -> Result<Vec<(usize, Joints)>, PlanError> {
    let mut kinks = Vec::with_capacity(breaks.len());
    for &i in breaks {
        let s = s_mm[i];
        let back = robot
            .kinematics
            .ik(&(shape.pose_at)(s - KINK_PROBE_MM), Some(&q[i]))?;
        let on = robot
            .kinematics
            .ik(&(shape.pose_at)(s + KINK_PROBE_MM), Some(&q[i]))?;
        let jump: Joints = std::array::from_fn(|j| {
            ((on[j] - q[i][j]) - (q[i][j] - back[j])).abs() / KINK_PROBE_MM
        });
        kinks.push((i, jump));
    }
    Ok(kinks)
}

impl JointsAlong {
    fn new(robot: &Robot, shape: &Shape, start: &Joints) -> Result<Self, PlanError> {
        let (s_mm, breaks) = grid_points(shape);
        let n = s_mm.len() - 1;
        let mut q = Vec::with_capacity(n + 1);
        let mut near = *start;
        for &s in &s_mm {
            near = robot.kinematics.ik(&(shape.pose_at)(s), Some(&near))?;
            q.push(near);
        }
        let rate = |a: usize, b: usize| -> Joints {
            std::array::from_fn(|j| (q[b][j] - q[a][j]) / (s_mm[b] - s_mm[a]))
        };
        let mut dq: Vec<Joints> = (0..=n)
            .map(|i| rate(i.saturating_sub(1), (i + 1).min(n)))
            .collect();
        let mut ddq = second_rates(&s_mm, &q);
        // Where two pieces meet, the next piece's derivatives: its rate over the step from
        // the point, and its second derivative at the step's end (every piece is at least
        // PIECE_STEPS steps, so both are on it).
        let mut rate_before = Vec::with_capacity(breaks.len());
        for &i in &breaks {
            rate_before.push((i, rate(i - 1, i)));
            dq[i] = rate(i, i + 1);
            ddq[i] = ddq[i + 1];
        }
        let kinks = kinks(robot, shape, &s_mm, &q, &breaks)?;
        Ok(Self {
            s_mm,
            q,
            dq,
            ddq,
            rate_before,
            kinks,
        })
    }

    /// Every grid point where joint `j` stands still: the ends, and where it reverses.
    fn rests(&self, j: usize) -> Vec<usize> {
        let mut out = vec![0];
        let mut way = 0.0;
        for i in 1..self.q.len() {
            let d = self.q[i][j] - self.q[i - 1][j];
            if d != 0.0 {
                if way * d < 0.0 {
                    out.push(i - 1);
                }
                way = d;
            }
        }
        out.push(self.q.len() - 1);
        out
    }
}

/// The grid's distances: about [`GRID_MM`] apart ([`GRID_POINTS`] in all, at least), every
/// place where two pieces meet among them, and every piece at least [`PIECE_STEPS`] steps (a
/// blend of a fraction of a millimetre is seen from the inside).
fn grid_points(shape: &Shape) -> (Vec<f64>, Vec<usize>) {
    let n = ((shape.length_mm / GRID_MM).ceil() as usize).clamp(GRID_POINTS.0, GRID_POINTS.1);
    let h = shape.length_mm / n as f64;
    let ends: Vec<f64> = shape
        .breaks_mm
        .iter()
        .copied()
        .filter(|&b| b > 0.0 && b < shape.length_mm)
        .chain(std::iter::once(shape.length_mm))
        .collect();
    let mut s_mm = vec![0.0];
    let mut breaks = Vec::new();
    let mut from = 0.0;
    for to in ends {
        if to <= from {
            continue;
        }
        if from > 0.0 {
            breaks.push(s_mm.len() - 1);
        }
        let steps = (((to - from) / h).ceil() as usize).max(PIECE_STEPS);
        s_mm.extend((1..=steps).map(|k| from + (to - from) * k as f64 / steps as f64));
        from = to;
    }
    (s_mm, breaks)
}

/// The time-optimal pace of `shape` for `robot` from `start` (the joints where it begins),
/// under `motion`'s speed and acceleration and every joint's limits.
pub(in crate::plan) fn pace(
    robot: &Robot,
    shape: &Shape,
    start: &Joints,
    motion: &Motion,
    limits: &PathLimits,
) -> Result<Pace, PlanError> {
    let along = JointsAlong::new(robot, shape, start)?;
    let rest = rest_accels(robot, &along, limits)?;
    let free = grid(robot, shape, &along, motion, limits, &[]);
    let first = solve(&free)?;
    let times = times(&free, &first);
    let mut zones = rest_zones(&along, &times, &rest);
    zones.extend(kink_zones(
        robot,
        &along,
        &times,
        REST_ROW_PERIODS * limits.rest_row_s,
        limits.shares.accel,
    ));
    let x = if zones.is_empty() {
        first
    } else {
        solve(&grid(robot, shape, &along, motion, limits, &zones))?
    };
    let speeds: Vec<f64> = x.iter().map(|x| x.max(0.0).sqrt()).collect();
    Pace::from_speeds(&along.s_mm, &speeds, motion.speed_mm_s).ok_or(PlanError::Untimed {
        at_mm: 0.0,
        reason: "the time-optimal motion stands still between two points",
    })
}

/// A joint's limit around a standstill ([`rest_accels`]).
#[derive(Debug, Clone, Copy)]
struct RestLimit {
    /// Its acceleration there, joint units/s^2.
    accel: f64,
    /// The row from or to rest it is planned for, s.
    row_s: f64,
}

/// Every joint's acceleration limit around a standstill (`start_hz`), joint units/s^2
/// (and the share of the limits planned to): its longest row from rest ([`REST_ROW_PERIODS`] of
/// the row `row_s` it is planned for) reaches `START_MARGIN * start_hz` less a pulse of
/// rounding over that row.
///
/// Under constant-period `row_s` is the period. Rows of any length (bounded-error) take the
/// row that leaves the most acceleration, `2 / (START_MARGIN * start_hz)`: a row from rest of
/// `r` lets the joint accelerate at `(4/3) (c / r - 1 / r^2)` pulses/s^2 (`c` the start
/// frequency planned to), at most `c^2 / 3` at `r = 2 / c`. The rows of the plan are judged as
/// ever: where the windows make the row from rest longer and too fast for `start_hz`, the
/// joint's windows are narrowed ([`crate::plan::bounded`]).
fn rest_accels(
    robot: &Robot,
    along: &JointsAlong,
    limits: &PathLimits,
) -> Result<[Option<RestLimit>; JOINTS], PlanError> {
    let mut out = [None; JOINTS];
    for (j, joint) in robot.joints.iter().enumerate() {
        let Some(start_hz) = joint.dynamics.start_hz else {
            continue;
        };
        // A joint that does not move has no standstill to leave.
        if along.dq.iter().all(|d| d[j] == 0.0) {
            continue;
        }
        let row_s = if limits.rows_any_length {
            any_length_rest_row_s(start_hz)
        } else {
            limits.rest_row_s
        };
        let room_hz = START_MARGIN * start_hz - 1.0 / row_s;
        if room_hz <= 0.0 {
            return Err(PlanError::StartHzTooLow {
                joint: joint.name.clone(),
                start_hz,
                min_hz: 1.0 / row_s / START_MARGIN,
                row_s,
            });
        }
        out[j] = Some(RestLimit {
            accel: 2.0 * room_hz / (REST_ROW_PERIODS * row_s)
                * joint.step.abs()
                * limits.shares.accel,
            row_s,
        });
    }
    Ok(out)
}

/// The row from or to rest of any length that leaves a joint with `start_hz` the most
/// acceleration ([`rest_accels`]), s.
pub(in crate::plan) fn any_length_rest_row_s(start_hz: f64) -> f64 {
    2.0 / (START_MARGIN * start_hz)
}

/// A zone of lower acceleration: joint `joint` within `accel` at grid points `from..=to`.
#[derive(Debug, Clone, Copy)]
struct Zone {
    joint: usize,
    from: usize,
    to: usize,
    accel: f64,
}

/// Every standstill's zone: the grid points whose step to the next the fastest motion (`t`,
/// when it passes each point) runs within [`REST_ROW_PERIODS`] of the joint's row from rest.
/// A slower motion passes fewer, so the zone holds the rows either side of the standstill of
/// the motion planned with it too.
fn rest_zones(along: &JointsAlong, t: &[f64], rest: &[Option<RestLimit>; JOINTS]) -> Vec<Zone> {
    let mut zones = Vec::new();
    for (joint, limit) in rest.iter().enumerate() {
        let Some(RestLimit { accel, row_s }) = *limit else {
            continue;
        };
        for r in along.rests(joint) {
            zones.push(zone(t, joint, r, REST_ROW_PERIODS * row_s, accel));
        }
    }
    zones
}

/// When the motion `x` reaches every grid point, s from its start.
fn times(grid: &[GridPoint], x: &[f64]) -> Vec<f64> {
    let mut t = vec![0.0; x.len()];
    for i in 1..x.len() {
        let v = x[i - 1].max(0.0).sqrt() + x[i].max(0.0).sqrt();
        t[i] = t[i - 1] + 2.0 * (grid[i].s - grid[i - 1].s) / v.max(1e-12);
    }
    t
}

/// Joint `joint` within `accel` over the steps within `span_s` either side of point `r`.
fn zone(t: &[f64], joint: usize, r: usize, span_s: f64, accel: f64) -> Zone {
    // Point i's limit holds over the step from it to the next: every step that overlaps the
    // time either side of point r.
    let from = t
        .partition_point(|&ti| ti <= t[r] - span_s)
        .saturating_sub(1);
    let to = t
        .partition_point(|&ti| ti < t[r] + span_s)
        .saturating_sub(1);
    Zone {
        joint,
        from: from.min(r.saturating_sub(1)),
        to: to.max(r),
        accel,
    }
}

/// Around every kink of a joint with `max_accel`, that joint's acceleration held to what its
/// jump there leaves ([`KINK_SHARE`]): the rows either side then step by the jump and at most
/// the rest.
fn kink_zones(robot: &Robot, along: &JointsAlong, t: &[f64], span_s: f64, share: f64) -> Vec<Zone> {
    let mut zones = Vec::new();
    for &(i, jump) in &along.kinks {
        for (j, joint) in robot.joints.iter().enumerate() {
            if let Some(a) = joint.dynamics.max_accel
                && jump[j] > KINK_MIN_PER_MM
            {
                let accel = (1.0 - KINK_SHARE) * a * ACCEL_MARGIN * share;
                zones.push(zone(t, j, i, span_s, accel));
            }
        }
    }
    zones
}

/// The grid's limits at every point.
fn grid(
    robot: &Robot,
    shape: &Shape,
    along: &JointsAlong,
    motion: &Motion,
    limits: &PathLimits,
    zones: &[Zone],
) -> Vec<GridPoint> {
    let tangential = if motion.accel_s > 0.0 {
        motion.speed_mm_s / motion.accel_s
    } else {
        f64::INFINITY
    };
    let at = PointLimits::new(robot, along, motion, limits, zones);
    along
        .s_mm
        .iter()
        .enumerate()
        .map(|(i, &s)| {
            let mut x_max = motion.speed_mm_s * motion.speed_mm_s;
            // The tightest curvature of the steps either side (each on one piece): the speed
            // between two points goes no higher than at either.
            let mid =
                |a: usize, b: usize| (shape.curvature_at)(0.5 * (along.s_mm[a] + along.s_mm[b]));
            let last = along.s_mm.len() - 1;
            let k = mid(i.saturating_sub(1), i.max(1)).max(mid(i.min(last - 1), (i + 1).min(last)));
            if k > 0.0 {
                x_max = x_max.min(limits.centripetal_mm_s2 * limits.shares.centripetal / k);
            }
            let mut accels = Vec::with_capacity(JOINTS + 1);
            if tangential.is_finite() {
                accels.push(AccelLimit::symmetric(1.0, 0.0, tangential));
            }
            at.joints(i, &mut x_max, &mut accels);
            GridPoint { s, x_max, accels }
        })
        .collect()
}

/// The joints' limits at every grid point ([`grid`]): what holds at a point made once (a path
/// of many blends has as many kinks and zones).
struct PointLimits<'a> {
    robot: &'a Robot,
    along: &'a JointsAlong,
    limits: &'a PathLimits,
    /// Whether a joint's speed is held within its channel's top frequency (`slow-down`).
    speeds: bool,
    /// Every point's lowest zone limit, by joint.
    zone_at: Vec<[f64; JOINTS]>,
    /// Every point's kink: every joint's jump in rate, per mm.
    kink_at: Vec<Option<&'a Joints>>,
    /// Where two pieces meet, every joint's rate on the piece before.
    before_at: Vec<Option<&'a Joints>>,
}

impl<'a> PointLimits<'a> {
    fn new(
        robot: &'a Robot,
        along: &'a JointsAlong,
        motion: &Motion,
        limits: &'a PathLimits,
        zones: &[Zone],
    ) -> Self {
        let mut zone_at = vec![[f64::INFINITY; JOINTS]; along.s_mm.len()];
        for z in zones {
            for at in &mut zone_at[z.from..=z.to.min(along.s_mm.len() - 1)] {
                at[z.joint] = at[z.joint].min(z.accel);
            }
        }
        let mut kink_at = vec![None; along.s_mm.len()];
        for (i, jump) in &along.kinks {
            kink_at[*i] = Some(jump);
        }
        let mut before_at = vec![None; along.s_mm.len()];
        for (i, rate) in &along.rate_before {
            before_at[*i] = Some(rate);
        }
        Self {
            robot,
            along,
            limits,
            speeds: motion.over_speed == OverSpeed::SlowDown,
            zone_at,
            kink_at,
            before_at,
        }
    }

    /// Every joint's limits at point `i`: its speed at a kink and within its channel's top
    /// frequency, lowering `x_max`, and its acceleration (in a zone, the zone's), pushed onto
    /// `accels`.
    fn joints(&self, i: usize, x_max: &mut f64, accels: &mut Vec<AccelLimit>) {
        let (along, limits) = (self.along, self.limits);
        for (j, joint) in self.robot.joints.iter().enumerate() {
            let (d, dd) = (along.dq[i][j], along.ddq[i][j]);
            if let (Some(a), Some(jump)) = (joint.dynamics.max_accel, self.kink_at[i])
                && jump[j] > KINK_MIN_PER_MM
            {
                let v = KINK_SHARE * a * ACCEL_MARGIN * limits.shares.accel * limits.rest_row_s
                    / jump[j];
                *x_max = x_max.min(v * v);
            }
            // Where pieces meet, the speed at the point is the piece before's as well.
            let fastest_rate =
                self.before_at[i].map_or(d.abs(), |before| d.abs().max(before[j].abs()));
            if self.speeds && fastest_rate != 0.0 {
                let v = SPEED_MARGIN
                    * limits.shares.speed
                    * f64::from(joint.max_freq_hz)
                    * joint.step.abs();
                *x_max = x_max.min((v / fastest_rate).powi(2));
            }
            let accel = joint
                .dynamics
                .max_accel
                .map_or(f64::INFINITY, |a| a * ACCEL_MARGIN * limits.shares.accel)
                .min(self.zone_at[i][j]);
            if accel.is_finite() {
                accels.push(AccelLimit::symmetric(d, dd, accel));
            }
        }
    }
}

fn solve(grid: &[GridPoint]) -> Result<Vec<f64>, PlanError> {
    topp::time_optimal(grid).map_err(|e| {
        let index = match e {
            topp::ToppError::BadGrid { index } | topp::ToppError::Stuck { index } => index,
        };
        PlanError::Untimed {
            at_mm: grid.get(index).map_or(0.0, |p| p.s),
            reason: "no acceleration there keeps every joint within its limits",
        }
    })
}
