//! The accuracy figures of an executed start (ACCURACY.md, "Figures"), evaluated exactly at every
//! pulse event, where the pose changes.

use nalgebra::Vector3;

use super::{Execution, PulseEvent};
use crate::geometry::{LineDistance, ToolPath};
use crate::kinematics::{JOINTS, Positions};
use crate::robot::Robot;
use crate::table::{ChannelTable, encoded_words};

/// The seed's sampling period for the "sampled deviation" figure, s.
pub const SAMPLE_PERIOD_S: f64 = 0.010;

/// How well an executed start follows its line.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Figures {
    /// Largest distance from the executed pose to the planned path (the segment P1P2 of a line
    /// move), at every pulse event, mm.
    pub path_deviation_mm: f64,
    /// Largest distance from the executed pose to the planned pose at the same time, mm.
    pub tracking_error_mm: f64,
    /// Path deviation sampled every 10 ms, as the seed measured it, mm.
    pub sampled_deviation_mm: f64,
    /// Largest difference between the channels' finish times, ms.
    pub end_skew_ms: f64,
    /// Distance from the final pose to P2, mm.
    pub end_error_mm: f64,
    /// When the last pulse of the start landed, s.
    pub finish_s: f64,
    /// Table rows over all channels.
    pub rows: usize,
    /// DT words of every channel area the start writes.
    pub words: usize,
}

/// Measures an execution of `tables` (one per joint, in joint order) against the planned `path`
/// (a line move's [`crate::geometry::Line`]) and the planned position `planned(t)`.
///
/// # Panics
/// Never: without a limit the measurement always completes.
#[must_use]
pub fn measure(
    robot: &Robot,
    tables: &[ChannelTable],
    exec: &Execution,
    path: &dyn ToolPath,
    planned: &dyn Fn(f64) -> Vector3<f64>,
    planned_duration_s: f64,
) -> Figures {
    measure_within(
        robot,
        tables,
        exec.events.iter().copied(),
        &exec.finish_s,
        path,
        &planned,
        planned_duration_s,
        f64::INFINITY,
    )
    .expect("no limit")
}

/// [`measure`] of a run given as its `events` in time order (read once, as they come: see
/// [`super::pulses`]) and when each table finished, giving up (`None`) as soon as the path
/// deviation passes `path_limit_mm`.
#[must_use]
#[allow(clippy::too_many_arguments)]
// Inlined into each planner's measurement: one copy per planned-position kind, each with its
// position made in the loop (out of line, the seed's constant-period move planned 11 % slower).
#[allow(clippy::inline_always)]
#[inline(always)]
pub fn measure_within(
    robot: &Robot,
    tables: &[ChannelTable],
    events: impl IntoIterator<Item = PulseEvent>,
    finish_s: &[Option<f64>],
    path: &dyn ToolPath,
    planned: &impl Planned,
    planned_duration_s: f64,
    path_limit_mm: f64,
) -> Option<Figures> {
    let counts: [i64; JOINTS] = std::array::from_fn(|j| tables.get(j).map_or(0, |t| t.start));
    // One joint changes per event: only its value is converted, and the kinematics' sines and
    // cosines are reused while their angles hold (bit for bit what forward kinematics gives).
    let mut q = robot.values_of(&counts);
    let mut positions = Positions::new(&robot.kinematics);
    path.restart();
    let mut p = positions.at(&q);
    let mut deviation = Deviation::new(path);
    deviation.see(&p);
    // Squared, the root taken once at the end (the root is monotonic: the same maximum).
    let mut tracking2 = (p - planned.at(0.0)).norm_squared();
    let mut tracking = tracking2.sqrt();
    let mut sampled: f64 = 0.0;
    let mut next_sample = 0.0;
    let mut last_finish_s = 0.0;
    for e in events {
        last_finish_s = e.t_s;
        while next_sample < e.t_s {
            sampled = sampled.max(path.distance_mm(&p));
            next_sample += SAMPLE_PERIOD_S;
        }
        // The planned pose moves while the executed one holds: check both ends of the hold.
        let held = p;
        set_joint(&mut q, e.table, robot.joints[e.table].value_of(e.count));
        p = positions.at(&q);
        if deviation.see(&p) > path_limit_mm {
            return None;
        }
        // First against a planned position within `off` of the exact one: only a hold whose
        // ends may pass the largest so far is measured exactly (a <= T, so (a + off)^2 <= ...).
        let (near, off) = planned.near(e.t_s);
        let a2 = (held - near).norm_squared().max((p - near).norm_squared());
        if a2 + off * (2.0 * tracking + off) > tracking2 {
            let target = planned.at(e.t_s);
            tracking2 = tracking2
                .max((held - target).norm_squared())
                .max((p - target).norm_squared());
            tracking = tracking2.sqrt();
        }
    }
    tracking2 =
        tracking2.max((p - planned.at(planned_duration_s.max(last_finish_s))).norm_squared());
    while next_sample <= planned_duration_s.max(last_finish_s) + 1e-12 {
        sampled = sampled.max(path.distance_mm(&p));
        next_sample += SAMPLE_PERIOD_S;
    }
    let finishes: Vec<f64> = finish_s.iter().flatten().copied().collect();
    let skew = finishes.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - finishes.iter().copied().fold(f64::INFINITY, f64::min);
    Some(Figures {
        path_deviation_mm: deviation.max_mm,
        tracking_error_mm: tracking2.sqrt(),
        sampled_deviation_mm: sampled,
        end_skew_ms: if finishes.is_empty() { 0.0 } else { skew * 1e3 },
        end_error_mm: (p - path.end_mm()).norm(),
        finish_s: last_finish_s,
        rows: tables.iter().map(ChannelTable::rows).sum(),
        words: tables
            .iter()
            .filter(|t| !t.segments.is_empty())
            .map(encoded_words)
            .sum(),
    })
}

/// `q` with joint `j` set to `value`, every joint chosen without an indexed store: `q` stays in
/// registers (stored at an index and read back whole, it stalled every event on the store).
#[allow(clippy::inline_always)]
#[inline(always)]
fn set_joint(q: &mut [f64; JOINTS], j: usize, value: f64) {
    *q = std::array::from_fn(|i| if i == j { value } else { q[i] });
}

/// The planned position of a start at its own time, as the measurement reads it.
pub trait Planned {
    /// The planned position at `t_s`, mm.
    fn at(&self, t_s: f64) -> Vector3<f64>;

    /// A position within the returned distance (mm) of [`Self::at`]'s, quicker to make: by
    /// default that very position.
    fn near(&self, t_s: f64) -> (Vector3<f64>, f64) {
        (self.at(t_s), 0.0)
    }
}

impl<F: Fn(f64) -> Vector3<f64>> Planned for F {
    fn at(&self, t_s: f64) -> Vector3<f64> {
        self(t_s)
    }
}

/// The path deviation alone (see [`measure`]) of `events` played from counts `start`: the
/// largest distance from the tool to `path` at the start and after every event, mm.
#[must_use]
pub fn path_deviation_mm(
    robot: &Robot,
    start: &[i64; JOINTS],
    events: impl IntoIterator<Item = PulseEvent>,
    path: &dyn ToolPath,
) -> f64 {
    let mut q = robot.values_of(start);
    let mut positions = Positions::new(&robot.kinematics);
    path.restart();
    let mut deviation = Deviation::new(path);
    deviation.see(&positions.at(&q));
    for e in events {
        set_joint(&mut q, e.table, robot.joints[e.table].value_of(e.count));
        deviation.see(&positions.at(&q));
    }
    deviation.max_mm
}

/// The largest distance from a run of points to a path. On a straight segment it compares
/// squared distances and takes a square root only for a new largest (the same value
/// `distance_mm` gives: the root is monotonic). On a path of many pieces a point nearer to the
/// piece the last one was nearest than the largest so far is not measured further: it cannot
/// be a new largest.
struct Deviation<'a> {
    path: &'a dyn ToolPath,
    line: Option<LineDistance>,
    max_mm: f64,
    max_mm2: f64,
    /// On a line: what a point must stay within to be surely no new largest
    /// ([`LineDistance::clear`] of `max_mm`).
    clear: f64,
    hint: usize,
}

impl<'a> Deviation<'a> {
    fn new(path: &'a dyn ToolPath) -> Self {
        Self {
            path,
            line: path.as_line().map(LineDistance::new),
            max_mm: 0.0,
            max_mm2: f64::NEG_INFINITY,
            clear: f64::NEG_INFINITY,
            hint: 0,
        }
    }

    /// Takes `p` into account; returns the largest distance so far, mm. Inlined into the
    /// measurement's loop: `p` stays in registers (passed through memory, it was read back
    /// whole from two halves just stored, which stalled every event).
    #[allow(clippy::inline_always)] // measured: inlined, the seed's move plans 20 % faster
    #[inline(always)]
    fn see(&mut self, p: &Vector3<f64>) -> f64 {
        if let Some(line) = &self.line {
            if let Some(d2) = line.squared_beyond_mm2(p, self.max_mm2, self.clear) {
                let d = d2.sqrt();
                self.max_mm2 = d2;
                self.max_mm = self.max_mm.max(d);
                self.clear = line.clear(d);
            }
            self.max_mm
        } else {
            self.see_on_path(p)
        }
    }

    /// [`Self::see`] on a path of many pieces.
    #[inline(never)]
    fn see_on_path(&mut self, p: &Vector3<f64>) -> f64 {
        if let Some(d) = self.path.distance_beyond_mm(p, self.max_mm, &mut self.hint) {
            self.max_mm = d;
        }
        self.max_mm
    }
}
