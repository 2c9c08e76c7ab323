//! Property tests of path planning over random reachable paths (lines and arcs through
//! waypoints, corners blended or stopped at) for every kinematics, both methods and both
//! frequency models. For every plan that succeeds:
//!
//! - every start's tables keep the F174 rules (`table::problems` with the robot's channel
//!   limits) and the execution model really ends each channel on its table's last target;
//! - every start begins on exactly the counts the one before it ends on (within a section and
//!   across sections), the first on the counts of the path's start, and every section ends on
//!   the counts of the waypoint it stops at (the last: the path's end);
//! - a section is cut only into parts chained at speed, back to back on its profile;
//! - the executed path (every pulse event of the execution model, re-measured here with the
//!   planned path's own `distance_mm`) is what the plan's figures say, and for bounded-error
//!   within the tolerance of the path as planned, blends included, also with up to a 10 ms
//!   PLC scan between a channel's segments;
//! - the planned speed on every arc (finite differences of the planned positions) is within
//!   `sqrt(path_accel * r)`, the section slowing for its tight arcs alone.
//!
//! With random drive limits (`max_accel`, `start_hz`: [`super::drive_properties`]) every plan
//! keeps all of the above and every row of every table is within its joint's drive limits.
//!
//! Paths the planner rightly refuses (a pose out of reach or a joint limit, a tolerance below
//! what the pulse grid reaches, a joint that starts too late into a blended section) are
//! counted by reason and printed; each test requires most of its cases to be planned.

use crate::common;

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::time::Instant;

use linterpd::geometry::{ArcBy, Corner, Element, Path, PathSpec, Pose, ToolPath};
use linterpd::kinematics::{JOINTS, Kinematics};
use linterpd::plan::{Origin, PathPlan, PathRequest, Plan, PlanError, plan_path};
use linterpd::robot::{Method, OverSpeed, Ramp, Robot};
use linterpd::table::{FrequencyModel, TableProblem, problems};
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};

/// Cases per kinematics.
const CASES: u32 = 48;
/// Cases per kinematics under random drive limits.
const DRIVE_CASES: u32 = 16;
/// Cases per kinematics with S-curve ramps.
const S_CURVE_CASES: u32 = 24;
/// The seed of the cases drawn.
const SEED: u64 = 20_261_125;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kin {
    Cylindrical,
    Gantry,
    Scara,
}

impl Kin {
    fn robot(self) -> Robot {
        match self {
            Self::Cylindrical => common::cylindrical(),
            Self::Gantry => common::gantry(),
            Self::Scara => common::scara(),
        }
    }

    /// Whether the tool point may be at `p` (with a margin inside the robot's reach and joint
    /// limits): the region the waypoints are generated in, checked along the built path.
    fn reachable(self, p: &Vector3<f64>) -> bool {
        let r = p.x.hypot(p.y);
        match self {
            // d3 = r - 500 in 0..1000, d2 = z in -50..400, theta1 = atan2(-x, y) in +-170 deg.
            Self::Cylindrical => {
                (530.0..=1_480.0).contains(&r)
                    && (-40.0..=390.0).contains(&p.z)
                    && (-p.x).atan2(p.y).to_degrees().abs() <= 160.0
            }
            // Every axis +-2000 mm.
            Self::Gantry => p.iter().all(|c| c.abs() <= 1_900.0),
            // l1 = 400, l2 = 300: the annulus 100..700 mm, z +-1000.
            Self::Scara => (120.0..=680.0).contains(&r) && p.z.abs() <= 900.0,
        }
    }
}

/// One waypoint as generated: where the element ends, whether it is an arc (its via point
/// `bulge` chords off the chord's middle, at angle `phi` about the chord) and, after a line, the
/// corner's blend radius (`None`: a stop).
#[derive(Debug, Clone, Copy)]
struct Waypoint {
    to: Pose,
    arc: Option<(f64, f64)>,
    blend_mm: Option<f64>,
}

/// A random path: its start and waypoints.
#[derive(Debug, Clone)]
struct Route {
    start: Pose,
    waypoints: Vec<Waypoint>,
}

#[derive(Debug, Clone, Copy)]
struct Settings {
    /// `Some(tolerance)`: bounded-error; `None`: constant-period at `period_s`.
    tolerance_mm: Option<f64>,
    period_s: f64,
    ideal: bool,
    speed_mm_s: f64,
    accel_s: f64,
    path_accel_mm_s2: f64,
    /// `slow-down` (the section slowed where a joint would be too fast) or `reject`.
    slow_down: bool,
    /// Words in each channel's table area: the robots' 2000, or a small area that makes the
    /// planner cut sections into parts chained at speed.
    area_words: usize,
    /// Random drive limits on every joint (not drawn: set by the run).
    drives: bool,
}

fn polar(radius_mm: f64, angle_deg: f64, z: f64, a_deg: f64) -> Pose {
    let t = angle_deg.to_radians();
    Pose::from_mm_deg(radius_mm * t.cos(), radius_mm * t.sin(), z, a_deg)
}

/// Per waypoint: the step (three coordinates' changes), the tool angle, arc or line, the arc's
/// bulge and its plane, stop or blend, the blend's radius.
/// A step may be vertical only (`true`): the joints that do not lift then stand still until a
/// blend, where a section must be cut for them to start late.
type Step = ((f64, f64, f64), f64, (bool, f64, f64), (bool, f64), bool);

fn steps(d: (f64, f64, f64)) -> impl Strategy<Value = Vec<Step>> {
    prop::collection::vec(
        (
            (-d.0..d.0, -d.1..d.1, -d.2..d.2),
            -45.0..45.0f64,
            (
                prop::bool::weighted(0.35),
                0.08..0.4f64,
                -std::f64::consts::PI..std::f64::consts::PI,
            ),
            (prop::bool::weighted(0.7), 2.0..30.0f64),
            prop::bool::weighted(0.2),
        ),
        2..=4,
    )
}

/// A step's changes, the first two none for a vertical step.
fn lift(s: Step) -> (f64, f64, f64) {
    let (a, b, dz) = s.0;
    if s.4 { (0.0, 0.0, dz) } else { (a, b, dz) }
}

fn waypoint(to: Pose, (_, _, (arc, bulge, phi), (blend, r), _): Step) -> Waypoint {
    Waypoint {
        to,
        arc: arc.then_some((bulge, phi)),
        blend_mm: blend.then_some(r),
    }
}

/// Cylindrical: waypoints in the band 700-1400 mm from the axis, +-60 deg about the y axis,
/// z 0-300 mm, each a step of at most 350 mm radially, 15 deg around and 150 mm up or down from
/// the one before (a chord then stays outside the d3 = 0 cylinder).
fn cylindrical_route() -> impl Strategy<Value = Route> {
    (
        (
            700.0..1400.0f64,
            -60.0..60.0f64,
            0.0..300.0f64,
            -45.0..45.0f64,
        ),
        steps((350.0, 15.0, 150.0)),
    )
        .prop_map(|((r, t, z, a), steps)| {
            let start = polar(r, t + 90.0, z, a);
            let (mut r, mut t, mut z) = (r, t, z);
            let waypoints = steps
                .into_iter()
                .map(|s| {
                    let (dr, dt, dz) = lift(s);
                    r = (r + dr).clamp(700.0, 1400.0);
                    t = (t + dt).clamp(-60.0, 60.0);
                    z = (z + dz).clamp(0.0, 300.0);
                    waypoint(polar(r, t + 90.0, z, s.1), s)
                })
                .collect();
            Route { start, waypoints }
        })
}

/// Gantry: waypoints in the cube +-800 mm, z +-300 mm, each a step of at most 400 mm per axis.
fn gantry_route() -> impl Strategy<Value = Route> {
    (
        (
            -800.0..800.0f64,
            -800.0..800.0f64,
            -300.0..300.0f64,
            -45.0..45.0f64,
        ),
        steps((400.0, 400.0, 200.0)),
    )
        .prop_map(|((x, y, z, a), steps)| {
            let start = Pose::from_mm_deg(x, y, z, a);
            let (mut x, mut y, mut z) = (x, y, z);
            let waypoints = steps
                .into_iter()
                .map(|s| {
                    let (dx, dy, dz) = lift(s);
                    x = (x + dx).clamp(-800.0, 800.0);
                    y = (y + dy).clamp(-800.0, 800.0);
                    z = (z + dz).clamp(-300.0, 300.0);
                    waypoint(Pose::from_mm_deg(x, y, z, s.1), s)
                })
                .collect();
            Route { start, waypoints }
        })
}

/// SCARA: waypoints 300-650 mm out, +-30 deg, z +-100 mm, each a step of at most 200 mm out,
/// 20 deg around and 100 mm up or down (a chord then stays inside the annulus).
fn scara_route() -> impl Strategy<Value = Route> {
    (
        (
            300.0..650.0f64,
            -30.0..30.0f64,
            -100.0..100.0f64,
            -45.0..45.0f64,
        ),
        steps((200.0, 20.0, 100.0)),
    )
        .prop_map(|((r, t, z, a), steps)| {
            let start = polar(r, t, z, a);
            let (mut r, mut t, mut z) = (r, t, z);
            let waypoints = steps
                .into_iter()
                .map(|s| {
                    let (dr, dt, dz) = lift(s);
                    r = (r + dr).clamp(300.0, 650.0);
                    t = (t + dt).clamp(-30.0, 30.0);
                    z = (z + dz).clamp(-100.0, 100.0);
                    waypoint(polar(r, t, z, s.1), s)
                })
                .collect();
            Route { start, waypoints }
        })
}

fn settings() -> impl Strategy<Value = Settings> {
    (
        prop::option::of(0.05..0.2f64),
        0.02..0.1f64,
        any::<bool>(),
        80.0..400.0f64,
        0.05..0.4f64,
        1_000.0..10_000.0f64,
        prop_oneof![Just(2_000usize), Just(120usize)],
        any::<bool>(),
    )
        .prop_map(
            |(
                tolerance_mm,
                period_s,
                ideal,
                speed_mm_s,
                accel_s,
                path_accel_mm_s2,
                area_words,
                slow_down,
            )| {
                Settings {
                    tolerance_mm,
                    period_s,
                    ideal,
                    speed_mm_s,
                    accel_s,
                    path_accel_mm_s2,
                    slow_down,
                    area_words,
                    drives: false,
                }
            },
        )
}

impl Route {
    /// The path's elements: arcs through a via point off the chord's middle; a waypoint after
    /// a line blended or stopped at as generated, one after an arc a stop. An arc after a
    /// blended corner lies in the plane of the line before it (a blend next to an arc needs
    /// one plane); others in any plane.
    fn elements(&self) -> Vec<(Element, Corner)> {
        let n = self.waypoints.len();
        let mut from = self.start.position_mm;
        let mut out = Vec::with_capacity(n);
        // The line before, when the corner into this element is blended.
        let mut blended_from: Option<Vector3<f64>> = None;
        for (i, w) in self.waypoints.iter().enumerate() {
            let to = w.to.position_mm;
            let element = match w.arc {
                None => Element::Line { to: w.to },
                Some((bulge, phi)) => {
                    let chord = to - from;
                    // Two unit vectors square to the chord and to each other.
                    let side = chord
                        .cross(&Vector3::z())
                        .try_normalize(1e-9)
                        .unwrap_or_else(Vector3::x);
                    let up = chord.cross(&side).normalize();
                    let in_plane = blended_from
                        .and_then(|d| d.cross(&chord).try_normalize(1e-6))
                        .map(|n| n.cross(&chord).normalize());
                    let off = match in_plane {
                        Some(across) => across * phi.signum() * bulge * chord.norm(),
                        None => (side * phi.cos() + up * phi.sin()) * bulge * chord.norm(),
                    };
                    Element::Arc {
                        to: w.to,
                        by: ArcBy::Via((from + to) / 2.0 + off),
                    }
                }
            };
            let corner = match w.blend_mm {
                Some(r) if i + 1 < n && w.arc.is_none() => Corner::Blend(r),
                _ => Corner::Stop,
            };
            blended_from = matches!(corner, Corner::Blend(_)).then(|| to - from);
            out.push((element, corner));
            from = to;
        }
        out
    }

    /// Whether every element is at least 10 mm long and the built path (blends included)
    /// stays in `kin`'s region; a path that cannot be built is kept (the planner must refuse
    /// it as a path error).
    fn fits(&self, kin: Kin) -> bool {
        let mut from = self.start.position_mm;
        for w in &self.waypoints {
            if (w.to.position_mm - from).norm() < 10.0 {
                return false;
            }
            from = w.to.position_mm;
        }
        let spec = PathSpec {
            start: self.start,
            elements: self.elements(),
        };
        let Ok(path) = Path::build(&spec) else {
            return true;
        };
        let n = (path.length_mm() / 2.0).ceil() as usize;
        (0..=n).all(|i| kin.reachable(&path.at(path.length_mm() * i as f64 / n as f64).position_mm))
    }
}

fn route(kin: Kin) -> BoxedStrategy<Route> {
    let s = match kin {
        Kin::Cylindrical => cylindrical_route().boxed(),
        Kin::Gantry => gantry_route().boxed(),
        Kin::Scara => scara_route().boxed(),
    };
    s.prop_filter(
        "path leaves the reachable region or has a short element",
        move |r| r.fits(kin),
    )
    .boxed()
}

fn request(robot: &Robot, route: &Route, s: &Settings) -> PathRequest {
    let mut motion = robot.motion;
    motion.method = match s.tolerance_mm {
        Some(tolerance_mm) => Method::BoundedError { tolerance_mm },
        None => Method::ConstantPeriod,
    };
    motion.period_s = s.period_s;
    motion.speed_mm_s = s.speed_mm_s;
    motion.accel_s = s.accel_s;
    motion.over_speed = if s.slow_down {
        OverSpeed::SlowDown
    } else {
        OverSpeed::Reject
    };
    motion.frequency_model = if s.ideal {
        FrequencyModel::Ideal
    } else {
        FrequencyModel::FpxDivider
    };
    PathRequest {
        from: Origin::Pose(route.start),
        start: None,
        elements: route.elements(),
        motion,
        path_accel_mm_s2: s.path_accel_mm_s2,
    }
}

/// What the cases came to, for the report and the coverage asserts.
#[derive(Debug, Default)]
struct Tally {
    cases: usize,
    planned_bounded: usize,
    planned_constant: usize,
    /// Planned paths with more than one section (a stop between elements).
    multi_section: usize,
    /// Planned paths with a section cut into parts chained at speed.
    multi_part: usize,
    /// Planned paths with a blended corner / an arc element.
    with_blend: usize,
    with_arc: usize,
    /// Planned paths with a blend into an arc.
    blend_into_arc: usize,
    /// Starts whose rows were checked against random drive limits.
    drive_checked: usize,
    /// Refusals by reason.
    skipped: BTreeMap<String, usize>,
    /// The largest re-measured deviation over the tolerance, of every bounded-error plan.
    worst_ratio: f64,
    /// The largest re-measured deviation of a constant-period plan, mm.
    worst_constant_mm: f64,
    events: usize,
    /// Planned speeds checked on arcs.
    arc_speeds: usize,
    /// S-curve starts whose tool's jerk was checked.
    jerk_checked: usize,
    /// S-curve starts run on a pace that changes speed (the averaged one refused): not checked.
    jerk_stepped: usize,
}

/// The refusals that mean "this random path cannot be planned": the reason's name, or `None`
/// for an error that must not happen on a reachable path.
fn refusal(e: &PlanError, s: &Settings) -> Option<String> {
    let tolerance_mm = s.tolerance_mm;
    match e {
        PlanError::Section { source, .. } => refusal(source, s),
        // Only the small area: a part of MIN_PART_S that still does not fit.
        PlanError::InvalidTable {
            first: TableProblem::AreaOverflow { .. } | TableProblem::TooManySegments { .. },
            ..
        } if s.area_words < 2_000 => Some("small area: even a short part does not fit".into()),
        // A drive slower than the robot's channels makes more rows than its area takes.
        PlanError::InvalidTable {
            first: TableProblem::AreaOverflow { .. } | TableProblem::TooManySegments { .. },
            ..
        } if s.drives => Some("drive limits: the rows do not fit the area".into()),
        // Refused, never emitted: what the planner's timing cannot yet bring within a drive's
        // limits (counted and printed; see the closing note of stop 34).
        PlanError::RowStep { .. } | PlanError::RestRow { .. } | PlanError::Untimed { .. }
            if s.drives =>
        {
            Some(
                format!("drive limits: refused ({e})")
                    .chars()
                    .take(60)
                    .collect(),
            )
        }
        PlanError::Kinematics(_) => Some("unreachable (Kinematics)".into()),
        PlanError::OutOfLimit { .. } => Some("joint limit (OutOfLimit)".into()),
        PlanError::Path(p) => Some(format!("path cannot be built (Path: {p})")),
        PlanError::OverSpeed { .. } => Some("OverSpeed".into()),
        PlanError::ToleranceTooSmall { floor_mm, .. } => {
            let tol = tolerance_mm.unwrap_or(f64::NAN);
            // The floor is the grid's own deviation: a refusal with the floor within the
            // tolerance is the planner failing to find tables that exist in principle.
            Some(if *floor_mm > tol {
                "ToleranceTooSmall, floor above the tolerance".into()
            } else {
                "ToleranceTooSmall, floor within the tolerance".into()
            })
        }
        PlanError::LateStart { .. } => {
            Some("LateStart (from ToleranceTooSmall: a joint starts late)".into())
        }
        _ => None,
    }
}

/// The largest distance from the tool to `path` at the start of `plan` and after every pulse
/// event of its execution with `gap_s` between a channel's segments (the PLC's scan; the plan's
/// own figures take 0), computed here from the counts with forward kinematics.
fn executed_deviation_mm(robot: &Robot, plan: &Plan, path: &Path, gap_s: f64) -> f64 {
    let mut counts = plan.start_counts();
    let mut worst = path.distance_mm(&robot.pose_of(&counts).position_mm);
    for e in &plan.execution_with_scan(gap_s).events {
        counts[e.table] = e.count;
        worst = worst.max(path.distance_mm(&robot.pose_of(&counts).position_mm));
    }
    worst
}

fn counts_at(robot: &Robot, pose: &Pose) -> [i64; JOINTS] {
    robot.counts_of(&robot.kinematics.ik(pose, None).expect("waypoint reachable"))
}

fn check(
    robot: &Robot,
    route: &Route,
    s: &Settings,
    req: &PathRequest,
    planned: &PathPlan,
    tally: &mut Tally,
) -> Result<(), TestCaseError> {
    let starts: Vec<&Plan> = planned.starts().collect();
    prop_assert!(!starts.is_empty());
    prop_assert!(planned.valid());

    // Chaining: from the path's start, each start from the one before, across sections.
    prop_assert_eq!(starts[0].start_counts(), counts_at(robot, &route.start));
    for (k, pair) in starts.windows(2).enumerate() {
        prop_assert_eq!(
            pair[1].start_counts(),
            pair[0].end_counts(),
            "start {} does not begin where start {} ends",
            k + 2,
            k + 1
        );
    }

    // One section per stop; every section ends on the counts of its stop waypoint.
    let stops: Vec<usize> = req
        .elements
        .iter()
        .enumerate()
        .filter(|(i, (_, c))| *i + 1 == req.elements.len() || *c == Corner::Stop)
        .map(|(i, _)| i)
        .collect();
    sections_end_at_the_stops(robot, route, planned, &stops)?;
    for section in &planned.sections {
        let parts = &section.starts;
        prop_assert!(!parts.is_empty());
        prop_assert!(!parts[0].window.begins_at_speed());
        prop_assert!(!parts[parts.len() - 1].window.ends_at_speed);
        for pair in parts.windows(2) {
            prop_assert!(pair[0].window.ends_at_speed && pair[1].window.begins_at_speed());
            prop_assert!((pair[1].window.from_s - pair[0].window.to_s).abs() < 1e-9);
        }
        for part in parts {
            prop_assert_eq!(part.path.as_ref(), Some(&section.path));
        }
    }
    let last = route.waypoints[route.waypoints.len() - 1].to;
    prop_assert_eq!(
        starts[starts.len() - 1].end_counts(),
        counts_at(robot, &last)
    );

    for (k, plan) in starts.iter().enumerate() {
        // The F174 rules, and the execution reaches every table's end.
        prop_assert!(plan.valid(), "start {}: {:?}", k + 1, plan.problems);
        prop_assert!(plan.valid_tables(robot).is_some());
        for (j, table) in plan.tables.iter().enumerate() {
            let found = problems(table, robot.channel_limits(j));
            prop_assert!(found.is_empty(), "start {} joint {j}: {found:?}", k + 1);
            let executed = plan
                .execution()
                .events
                .iter()
                .rev()
                .find(|e| e.table == j)
                .map_or(table.start, |e| e.count);
            prop_assert_eq!(executed, table.end());
        }

        // The executed path against the path as planned (blends included), measured here.
        let path = plan
            .path
            .as_ref()
            .expect("a path section's start has its path");
        let measured = executed_deviation_mm(robot, plan, path, 0.0);
        tally.events += plan.execution().events.len();
        prop_assert!(
            (measured - plan.figures.path_deviation_mm).abs() <= 1e-9,
            "start {}: the execution deviates {measured} mm, the figures say {} mm",
            k + 1,
            plan.figures.path_deviation_mm
        );
        match s.tolerance_mm {
            Some(tol) => {
                prop_assert!(
                    plan.figures.path_deviation_mm <= tol,
                    "start {}: {} mm > {tol} mm",
                    k + 1,
                    plan.figures.path_deviation_mm
                );
                prop_assert!(measured <= tol, "start {}: {measured} mm > {tol} mm", k + 1);
                // Whatever the PLC's scan between a channel's segments.
                for gap_s in [0.002, 0.010] {
                    let late = executed_deviation_mm(robot, plan, path, gap_s);
                    prop_assert!(
                        late <= tol,
                        "start {}: {late} mm > {tol} mm with {gap_s} s between segments",
                        k + 1
                    );
                }
                tally.worst_ratio = tally.worst_ratio.max(measured / tol);
            }
            None => tally.worst_constant_mm = tally.worst_constant_mm.max(measured),
        }

        check_arc_speeds(plan, path, s, k, tally)?;
    }
    Ok(())
}

/// The planned speed on every arc of `plan`'s `path` (finite differences of the planned
/// positions, every millisecond) within what the centripetal limit allows for its radius.
fn check_arc_speeds(
    plan: &Plan,
    path: &Path,
    s: &Settings,
    k: usize,
    tally: &mut Tally,
) -> Result<(), TestCaseError> {
    let dt = 1e-3;
    let steps = (plan.duration_s() / dt).floor() as usize;
    for i in 0..steps {
        let t = i as f64 * dt;
        let (a, b) = (
            plan.course_mm(plan.window.from_s + t),
            plan.course_mm(plan.window.from_s + t + dt),
        );
        let curvature = path.curvature_per_mm(a).max(path.curvature_per_mm(b));
        if curvature <= 0.0 {
            continue;
        }
        let on_arc = path
            .pieces()
            .iter()
            .any(|p| p.start_mm <= a && b <= p.start_mm + p.primitive.length_mm());
        if !on_arc {
            continue;
        }
        let speed = (plan.planned_position_mm(t + dt) - plan.planned_position_mm(t)).norm() / dt;
        let allowed = (s.path_accel_mm_s2 / curvature).sqrt();
        prop_assert!(
            speed <= allowed * (1.0 + 1e-6) + 1e-6,
            "start {}: {speed} mm/s on an arc of radius {} mm, {allowed} mm/s allowed",
            k + 1,
            1.0 / curvature
        );
        tally.arc_speeds += 1;
    }
    Ok(())
}

fn run(kin: Kin, drives: bool) {
    run_with(kin, drives, None);
}

/// [`run`], every path with S-curve ramps of `s_curve` mm/s^3 if given: every start then keeps
/// that jerk along its course too ([`super::drive_properties::tool_jerk`], 5 % allowed for its
/// third differences), as well as the centripetal limit on every arc.
fn run_with(kin: Kin, drives: bool, s_curve: Option<f64>) {
    let began = Instant::now();
    let robot = kin.robot();
    let tally = RefCell::new(Tally::default());
    let mut runner = TestRunner::new(Config {
        cases: match (drives, s_curve) {
            (true, _) => DRIVE_CASES,
            (false, Some(_)) => S_CURVE_CASES,
            (false, None) => CASES,
        },
        source_file: Some(file!()),
        // The same cases on every run, so that the coverage asserted below is the same too
        // (`PROPTEST_RNG_SEED=N` explores others).
        rng_seed: std::env::var("PROPTEST_RNG_SEED")
            .ok()
            .and_then(|seed| seed.parse().ok())
            .map_or(RngSeed::Fixed(SEED), RngSeed::Fixed),
        ..Config::default()
    });
    // `Just` draws nothing: the cases without drive limits are the ones drawn before.
    let drive_limits = if drives {
        super::drive_properties::limits().prop_map(Some).boxed()
    } else {
        Just(None).boxed()
    };
    let result = runner.run(
        &(route(kin), settings(), drive_limits),
        |(route, mut s, l)| {
            let mut robot = match &l {
                Some(l) => super::drive_properties::limited(robot.clone(), l),
                None => robot.clone(),
            };
            s.drives = l.is_some();
            robot.area_words = s.area_words;
            let robot = &robot;
            let mut req = request(robot, &route, &s);
            if let Some(jerk_mm_s3) = s_curve {
                req.motion.ramp = Ramp::SCurve { jerk_mm_s3 };
            }
            let outcome = plan_path(robot, &req);
            let mut t = tally.borrow_mut();
            t.cases += 1;
            match outcome {
                Ok(planned) => {
                    check(robot, &route, &s, &req, &planned, &mut t)?;
                    if let Some(jerk_mm_s3) = s_curve {
                        check_jerk(&planned, jerk_mm_s3, &mut t)?;
                    }
                    if s.drives {
                        for plan in planned.starts() {
                            super::drive_properties::check_rows(robot, plan)?;
                            t.drive_checked += 1;
                        }
                    }
                    if s.tolerance_mm.is_some() {
                        t.planned_bounded += 1;
                    } else {
                        t.planned_constant += 1;
                    }
                    t.multi_section += usize::from(planned.sections.len() > 1);
                    t.multi_part +=
                        usize::from(planned.sections.iter().any(|s| s.starts.len() > 1));
                    t.with_blend += usize::from(
                        req.elements
                            .iter()
                            .any(|(_, c)| matches!(c, Corner::Blend(_))),
                    );
                    t.with_arc += usize::from(
                        req.elements
                            .iter()
                            .any(|(e, _)| matches!(e, Element::Arc { .. })),
                    );
                    t.blend_into_arc += usize::from(req.elements.windows(2).any(|w| {
                        matches!(w[0].1, Corner::Blend(_)) && matches!(w[1].0, Element::Arc { .. })
                    }));
                    Ok(())
                }
                Err(e) => match refusal(&e, &s) {
                    Some(reason) => {
                        *t.skipped.entry(reason).or_default() += 1;
                        Ok(())
                    }
                    None => Err(TestCaseError::fail(format!("{e}"))),
                },
            }
        },
    );
    let t = tally.into_inner();
    println!("{kin:?}: {} s, {:#?}", began.elapsed().as_secs_f64(), t);
    if let Err(e) = result {
        panic!("{kin:?}: {e}");
    }
    if s_curve.is_some() {
        assert_s_curve_coverage(kin, &t);
    } else {
        assert_coverage(kin, drives, &t);
    }
}

/// Every S-curve start of `planned` keeps `jerk_mm_s3` along its course
/// ([`super::drive_properties::tool_jerk`], 5 % allowed for its third differences), but those
/// run on a pace that changes speed (where the averaged S-curve could not be planned), which
/// keep that pace's steps: counted.
fn check_jerk(planned: &PathPlan, jerk_mm_s3: f64, t: &mut Tally) -> Result<(), TestCaseError> {
    for (k, plan) in planned.starts().enumerate() {
        let stepped = plan
            .pace
            .as_ref()
            .is_some_and(|p| !p.from_rest() && !p.is_uniform());
        if stepped {
            t.jerk_stepped += 1;
            continue;
        }
        let jerk = super::drive_properties::tool_jerk(plan);
        prop_assert!(
            jerk <= jerk_mm_s3 * 1.05,
            "start {}: the tool's jerk {jerk} over {jerk_mm_s3}",
            k + 1
        );
        t.jerk_checked += 1;
    }
    Ok(())
}

/// With S-curves: most plan, arcs and S-curve starts among them were checked, and at most one
/// start in ten checked ran on a stepping pace.
fn assert_s_curve_coverage(kin: Kin, t: &Tally) {
    let planned = t.planned_bounded + t.planned_constant;
    let over_speed = t.skipped.get("OverSpeed").copied().unwrap_or(0);
    assert!(2 * planned >= t.cases - over_speed, "{kin:?}: {t:?}");
    assert!(t.arc_speeds > 0 && t.jerk_checked > 0, "{kin:?}: {t:?}");
    assert!(t.jerk_stepped * 10 <= t.jerk_checked, "{kin:?}: {t:?}");
}

/// Most cases plan, with every feature among them (under drive limits: every start checked).
fn assert_coverage(kin: Kin, drives: bool, t: &Tally) {
    let planned = t.planned_bounded + t.planned_constant;
    if drives {
        // Fewer cases: most plan, and their rows were checked.
        assert!(
            2 * planned >= t.cases && t.drive_checked >= planned,
            "{kin:?}: {t:?}"
        );
        return;
    }
    // Most random reachable paths plan, under both methods, with blends and arcs among them;
    // under `reject` a path too fast for a joint is refused, as it must be.
    let over_speed = t.skipped.get("OverSpeed").copied().unwrap_or(0);
    assert!(
        2 * planned >= t.cases - over_speed,
        "{kin:?}: {planned} of {} planned ({over_speed} refused for over-speed)",
        t.cases
    );
    assert!(
        t.planned_bounded > 0 && t.planned_constant > 0,
        "{kin:?}: {t:?}"
    );
    assert!(
        t.with_blend > 0 && t.with_arc > 0 && t.blend_into_arc > 0,
        "{kin:?}: {t:?}"
    );
    assert!(
        t.arc_speeds > 0,
        "{kin:?}: no planned speed on an arc checked"
    );
    assert!(t.multi_section > 0 && t.multi_part > 0, "{kin:?}: {t:?}");
}

#[test]
fn cylindrical_paths_chain_keep_the_rules_and_stay_within_tolerance() {
    run(Kin::Cylindrical, false);
}

#[test]
fn gantry_paths_chain_keep_the_rules_and_stay_within_tolerance() {
    run(Kin::Gantry, false);
}

#[test]
fn scara_paths_chain_keep_the_rules_and_stay_within_tolerance() {
    run(Kin::Scara, false);
}

/// S-curve paths keep their jerk along the path and the centripetal limit on every arc: an
/// S-curve whose pace changes speed (a tight arc, a channel too fast under `slow-down`) is the
/// time-optimal motion averaged, and timed again where its average enters an arc too fast.
/// Where that one is refused (a bounded-error part a joint starts late into, say), the S-curve
/// runs on the trapezoid's pace and keeps its steps at arcs: those starts are counted, at most
/// one in ten of those checked.
#[test]
fn paths_with_s_curves_keep_their_jerk_and_the_centripetal_limit() {
    for kin in [Kin::Cylindrical, Kin::Gantry, Kin::Scara] {
        run_with(kin, false, Some(20_000.0));
    }
}

#[test]
fn cylindrical_paths_under_drive_limits_keep_every_row_within_them() {
    run(Kin::Cylindrical, true);
}

#[test]
fn gantry_paths_under_drive_limits_keep_every_row_within_them() {
    run(Kin::Gantry, true);
}

#[test]
fn scara_paths_under_drive_limits_keep_every_row_within_them() {
    run(Kin::Scara, true);
}

/// A gantry's tool angle turning up a line and back down the next, a blend between them: the
/// wrist reverses where the blend ends, a kink the path nearly stops at. The timing took the
/// joints' rates at a point where two pieces meet as the mean of both sides (for the wrist
/// there, about 0), so the step leaving the kink accelerated the joints far past their
/// `max_accel` (the wrist at about seven times its own in the case found by
/// `gantry_paths_under_drive_limits_...` at 160 cases) and the rows were refused after both
/// retimings. Now it plans, every row within every limit, and every joint's planned
/// acceleration within its `max_accel`.
#[test]
fn a_wrist_reversing_at_a_blend_leaves_it_within_its_max_accel() {
    let mut robot = common::gantry();
    // Every joint's max_accel in user units/s^2 (the wrist's in deg/s^2).
    let accel_user = [2_900.0, 1_550.0, 3_800.0, 66.0];
    for (joint, a) in robot.joints.iter_mut().zip(accel_user) {
        joint.dynamics.max_accel = Some(joint.kind.from_user(a));
    }
    let p = |x: f64, y: f64, z: f64, a: f64| Pose {
        position_mm: Vector3::new(x, y, z),
        a_rad: a,
    };
    let route = Route {
        start: p(615.7, 171.4, -82.7, -0.56),
        waypoints: vec![
            Waypoint {
                to: p(615.7, 171.4, 11.5, 0.717),
                arc: None,
                blend_mm: Some(11.8),
            },
            Waypoint {
                to: p(564.4, 308.0, -62.1, -0.206),
                arc: None,
                blend_mm: None,
            },
        ],
    };
    let s = Settings {
        tolerance_mm: None,
        period_s: 0.026,
        ideal: true,
        speed_mm_s: 370.0,
        accel_s: 0.16,
        path_accel_mm_s2: 8_500.0,
        slow_down: true,
        area_words: 2_000,
        drives: true,
    };
    let planned = plan_path(&robot, &request(&robot, &route, &s)).unwrap();
    for plan in planned.starts() {
        super::drive_properties::check_rows(&robot, plan).unwrap();
        for ((joint, max_accel), drive) in robot.joints.iter().zip(accel_user).zip(&plan.drive) {
            let peak = drive.peak_accel;
            assert!(
                peak <= max_accel * 1.02,
                "{}: planned at {peak}, max_accel {max_accel}",
                joint.name
            );
        }
    }
}

/// Every stop waypoint (`stops`, their indices) ends a section of `planned`, in order; the
/// planner may stop the tool inside a section too, where a part too short to chain behind would
/// have been (src/plan/path/short.rs), and each such stop ends a section of its own.
fn sections_end_at_the_stops(
    robot: &Robot,
    route: &Route,
    planned: &linterpd::plan::PathPlan,
    stops: &[usize],
) -> Result<(), TestCaseError> {
    prop_assert!(planned.sections.len() >= stops.len());
    let mut ends = planned
        .sections
        .iter()
        .map(linterpd::plan::SectionPlan::end_counts);
    for &w in stops {
        let want = counts_at(robot, &route.waypoints[w].to);
        prop_assert!(
            ends.any(|end| end == want),
            "no section ends at waypoint {}",
            w + 1
        );
    }
    prop_assert!(ends.next().is_none());
    Ok(())
}
