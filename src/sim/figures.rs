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
    let against = Against {
        tables,
        finish_s,
        path,
        planned,
        planned_duration_s,
        path_limit_mm,
    };
    match Executed::<true>::new(robot, &counts) {
        Some(executed) => against.measure(executed, events),
        None => against.measure(Executed::<false>::new(robot, &counts)?, events),
    }
}

/// What [`measure_within`] measures a run against.
struct Against<'a, P> {
    tables: &'a [ChannelTable],
    finish_s: &'a [Option<f64>],
    path: &'a dyn ToolPath,
    planned: &'a P,
    planned_duration_s: f64,
    path_limit_mm: f64,
}

impl<P: Planned> Against<'_, P> {
    /// [`measure_within`] of `events` from `executed` at the start's counts: made once for an
    /// arm with a tool offset and once for one without.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn measure<const TOOL: bool>(
        &self,
        mut executed: Executed<'_, TOOL>,
        events: impl IntoIterator<Item = PulseEvent>,
    ) -> Option<Figures> {
        let Self {
            tables,
            finish_s,
            path,
            planned,
            planned_duration_s,
            path_limit_mm,
        } = *self;
        let mut p = executed.position();
        let mut deviation = Deviation::from_start(path, &p);
        let mut tracking = Tracking::new(p, planned);
        let mut sampled = Sampled::default();
        let mut last_finish_s = 0.0;
        for e in events {
            last_finish_s = e.t_s;
            sampled.before(e.t_s, &p, path);
            // The planned pose moves while the executed one holds: check both ends of the hold.
            let held = p;
            p = executed.take(&e);
            if deviation.see(&p) > path_limit_mm {
                return None;
            }
            tracking.hold(&held, &p, e.t_s, planned);
        }
        let end_s = planned_duration_s.max(last_finish_s);
        tracking.see(&p, &planned.at(end_s));
        sampled.through(end_s + 1e-12, &p, path);
        Some(Figures {
            path_deviation_mm: deviation.max_mm,
            tracking_error_mm: tracking.squared.sqrt(),
            sampled_deviation_mm: sampled.max_mm,
            end_skew_ms: end_skew_ms(finish_s),
            end_error_mm: (p - path.end_mm()).norm(),
            finish_s: last_finish_s,
            ..Figures::sizes(tables)
        })
    }
}

impl Figures {
    /// The sizes of `tables` (their rows, and the words of every channel area written), every
    /// measured figure 0.
    fn sizes(tables: &[ChannelTable]) -> Self {
        Self {
            rows: tables.iter().map(ChannelTable::rows).sum(),
            words: tables
                .iter()
                .filter(|t| !t.segments.is_empty())
                .map(encoded_words)
                .sum(),
            ..Self::default()
        }
    }
}

/// The executed pose as the run's events come. One joint changes per event: only its value is
/// converted, and the kinematics' sines and cosines are reused while their angles hold (bit for
/// bit what forward kinematics gives).
struct Executed<'a, const TOOL: bool> {
    robot: &'a Robot,
    positions: Positions<'a, TOOL>,
    /// The joint values now.
    q: [f64; JOINTS],
}

impl<'a, const TOOL: bool> Executed<'a, TOOL> {
    /// At `counts`; `None` unless `TOOL` is whether the robot has a tool offset.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn new(robot: &'a Robot, counts: &[i64; JOINTS]) -> Option<Self> {
        Some(Self {
            robot,
            positions: Positions::new(&robot.kinematics)?,
            q: robot.values_of(counts),
        })
    }

    /// The position now.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn position(&mut self) -> Vector3<f64> {
        self.positions.at(&self.q)
    }

    /// Takes event `e`; returns the position after it.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn take(&mut self, e: &PulseEvent) -> Vector3<f64> {
        let value = self.robot.joints[e.table].value_of(e.count);
        set_joint(&mut self.q, e.table, value);
        self.position()
    }
}

/// The largest distance between the executed and the planned position so far, squared (the
/// root taken once at the end: the root is monotonic, the same maximum) and its root as of the
/// last exact check.
struct Tracking {
    squared: f64,
    root: f64,
}

impl Tracking {
    /// At the start, with the executed position `p`.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn new(p: Vector3<f64>, planned: &impl Planned) -> Self {
        let squared = (p - planned.at(0.0)).norm_squared();
        Self {
            squared,
            root: squared.sqrt(),
        }
    }

    /// Takes a hold that ends at `t_s`, at `held` before the event and at `p` after it. First
    /// against a planned position within `off` of the exact one: only a hold whose ends may
    /// pass the largest so far is measured exactly (a <= T, so (a + off)^2 <= ...).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn hold(&mut self, held: &Vector3<f64>, p: &Vector3<f64>, t_s: f64, planned: &impl Planned) {
        let (near, off) = planned.near(t_s);
        let a2 = (held - near).norm_squared().max((p - near).norm_squared());
        if a2 + off * (2.0 * self.root + off) > self.squared {
            let target = planned.at(t_s);
            self.see(held, &target);
            self.see(p, &target);
            self.root = self.squared.sqrt();
        }
    }

    /// Takes the executed position `p` against the planned `target`.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn see(&mut self, p: &Vector3<f64>, target: &Vector3<f64>) {
        self.squared = self.squared.max((p - target).norm_squared());
    }
}

/// The path deviation sampled every [`SAMPLE_PERIOD_S`], as the seed measured it.
#[derive(Default)]
struct Sampled {
    /// The largest so far, mm.
    max_mm: f64,
    /// When the next sample is due, s.
    next_s: f64,
}

impl Sampled {
    /// Samples the position `p`, held until `t_s`, at every sample time before `t_s`.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn before(&mut self, t_s: f64, p: &Vector3<f64>, path: &dyn ToolPath) {
        while self.next_s < t_s {
            self.sample(p, path);
        }
    }

    /// Samples the position `p` at every sample time up to `t_s`, the end.
    fn through(&mut self, t_s: f64, p: &Vector3<f64>, path: &dyn ToolPath) {
        while self.next_s <= t_s {
            self.sample(p, path);
        }
    }

    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn sample(&mut self, p: &Vector3<f64>, path: &dyn ToolPath) {
        self.max_mm = self.max_mm.max(path.distance_mm(p));
        self.next_s += SAMPLE_PERIOD_S;
    }
}

/// The largest difference between the channels' finish times, ms (0 when none finished).
fn end_skew_ms(finish_s: &[Option<f64>]) -> f64 {
    let finishes: Vec<f64> = finish_s.iter().flatten().copied().collect();
    if finishes.is_empty() {
        return 0.0;
    }
    let skew = finishes.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - finishes.iter().copied().fold(f64::INFINITY, f64::min);
    skew * 1e3
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
    match Executed::<true>::new(robot, start) {
        Some(executed) => deviation_from(executed, events, path),
        // One of the two always is; were neither, the run would count as off its path (never
        // NaN, which passes no limit check and so would pass every one).
        None => Executed::<false>::new(robot, start).map_or(f64::INFINITY, |executed| {
            deviation_from(executed, events, path)
        }),
    }
}

/// [`path_deviation_mm`] from `executed` at the start's counts.
fn deviation_from<const TOOL: bool>(
    mut executed: Executed<'_, TOOL>,
    events: impl IntoIterator<Item = PulseEvent>,
    path: &dyn ToolPath,
) -> f64 {
    let mut deviation = Deviation::from_start(path, &executed.position());
    for e in events {
        deviation.see(&executed.take(&e));
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
    /// From a run's start at `p`, along `path` restarted.
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn from_start(path: &'a dyn ToolPath, p: &Vector3<f64>) -> Self {
        path.restart();
        let mut deviation = Self::new(path);
        deviation.see(p);
        deviation
    }

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
