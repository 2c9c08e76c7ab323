//! linterpd's time-optimal speed against an independent reference: `toppra` (`PyPI`; `TOPP-RA`,
//! Pham & Pham 2018) computes the shortest duration of the same path under the same joint speed
//! and acceleration limits (and the path's own speed, acceleration and centripetal limits as a
//! coordinate of its own), and checks linterpd's emitted tables row by row against the limits
//! with code of its own (`tests/interop/toppra_duration.py`).
//!
//! The cases (issue 28): the seed's move, a line passing 100 mm from the base axis of a
//! cylindrical robot with a 50 mm arm, a SCARA line near its elbow singularity (the arm almost
//! stretched), and the example path `config/examples/pick-and-place.toml`; each with both
//! methods. linterpd's duration must be within 3 % of toppra's, and no row may break a limit.
//!
//! Python is `$LINTERPD_INTEROP_PYTHON`, else `.venv-interop/bin/python` (`.ci/run` installs
//! `tests/interop/requirements.txt` there). Run with
//! `cargo test --features third-party-peers --test interop_toppra -- --nocapture` for the table.

mod common;

use std::io::Write;
use std::path::{Path as FsPath, PathBuf};
use std::process::{Command, Stdio};

use linterpd::config::PathDoc;
use linterpd::geometry::{Path, Pose};
use linterpd::kinematics::{Cylindrical, JOINTS, Kinematics, Model};
use linterpd::plan::{MoveRequest, Origin, PathRequest, Plan, plan_path};
use linterpd::robot::{Dynamics, Method, Motion, OverSpeed, Robot, seed_robot};
use linterpd::table::{Direction, FrequencyModel};
use serde_json::{Value, json};

/// How far linterpd's duration may be from toppra's.
const WITHIN: f64 = 0.03;
/// Points along a section handed to toppra (its spline passes through them).
const WAYPOINTS: usize = 600;
/// toppra's grid.
const GRIDPOINTS: usize = 2_000;

fn python() -> PathBuf {
    let python = std::env::var_os("LINTERPD_INTEROP_PYTHON").map_or_else(
        || FsPath::new(env!("CARGO_MANIFEST_DIR")).join(".venv-interop/bin/python"),
        PathBuf::from,
    );
    assert!(
        python.is_file(),
        "interop peer missing: no Python with toppra at {} (install it with `python3 -m venv \
         .venv-interop && .venv-interop/bin/pip install -r tests/interop/requirements.txt`, as \
         .ci/run does, or point LINTERPD_INTEROP_PYTHON at one)",
        python.display()
    );
    python
}

/// `robot` with every joint's `max_accel` in user units/s^2.
fn limited(mut robot: Robot, accel_user: [f64; JOINTS]) -> Robot {
    for (joint, a) in robot.joints.iter_mut().zip(accel_user) {
        joint.dynamics = Dynamics {
            max_accel: Some(joint.kind.from_user(a)),
            start_hz: None,
            max_jerk: None,
        };
    }
    robot
}

/// One section as planned: its path, the joints where it starts, its starts.
struct Section<'a> {
    path: Path,
    start: [f64; JOINTS],
    starts: Vec<&'a Plan>,
}

/// What toppra is asked for one section, and the tables it checks.
fn request(robot: &Robot, section: &Section, motion: &Motion, path_accel_mm_s2: f64) -> Value {
    let length = section.path.length_mm();
    let mut s = Vec::with_capacity(WAYPOINTS + 1);
    let mut q = Vec::with_capacity(WAYPOINTS + 1);
    let mut along = Vec::with_capacity(WAYPOINTS + 1);
    let mut near = section.start;
    for i in 0..=WAYPOINTS {
        let at = length * i as f64 / WAYPOINTS as f64;
        near = robot
            .kinematics
            .ik(&section.path.at(at), Some(&near))
            .unwrap();
        let mut row: Vec<f64> = near.to_vec();
        row.push(at);
        s.push(at);
        q.push(row);
        let k = section.path.curvature_per_mm(at);
        along.push(if k > 0.0 {
            motion.speed_mm_s.min((path_accel_mm_s2 / k).sqrt())
        } else {
            motion.speed_mm_s
        });
    }
    let speeds = motion.over_speed == OverSpeed::SlowDown;
    let mut vmax: Vec<Value> = robot
        .joints
        .iter()
        .map(|j| {
            if speeds {
                json!(f64::from(j.max_freq_hz) * j.step.abs())
            } else {
                Value::Null
            }
        })
        .collect();
    vmax.push(json!(motion.speed_mm_s));
    let mut amax: Vec<Value> = robot
        .joints
        .iter()
        .map(|j| json!(j.dynamics.max_accel))
        .collect();
    amax.push(if motion.accel_s > 0.0 {
        json!(motion.speed_mm_s / motion.accel_s)
    } else {
        Value::Null
    });
    let tables: Vec<Value> = section
        .starts
        .iter()
        .flat_map(|plan| tables(robot, plan))
        .collect();
    json!({
        "s": s, "q": q, "vmax": vmax, "amax": amax, "vmax_along": along,
        "gridpoints": GRIDPOINTS, "tables": tables,
    })
}

/// Every moving channel of `plan`, for `toppra_duration.py`'s row check.
fn tables(robot: &Robot, plan: &Plan) -> Vec<Value> {
    plan.tables
        .iter()
        .zip(&robot.joints)
        .filter(|(t, _)| !t.segments.is_empty())
        .map(|(t, joint)| {
            let rows: Vec<Value> = t
                .segments
                .iter()
                .flat_map(|seg| {
                    let way = if seg.control.direction == Direction::Up {
                        1
                    } else {
                        -1
                    };
                    seg.rows
                        .iter()
                        .map(move |r| json!([r.freq_hz, r.target, way]))
                })
                .collect();
            json!({
                "name": joint.name, "max_hz": joint.max_freq_hz,
                "start_hz": joint.dynamics.start_hz,
                "accel_pulses": joint.dynamics.max_accel.map(|a| a / joint.step.abs()),
                "begins_at_rest": !plan.window.begins_at_speed(),
                "ends_at_rest": !plan.window.ends_at_speed,
                "start": t.start, "rows": rows,
            })
        })
        .collect()
}

/// toppra's duration of one section, and the problems its check finds in the tables.
fn toppra(doc: &Value) -> (f64, Vec<String>) {
    let script = FsPath::new(env!("CARGO_MANIFEST_DIR")).join("tests/interop/toppra_duration.py");
    let mut child = Command::new(python())
        .arg(&script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python runs");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(doc.to_string().as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "toppra_duration.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let answer: Value = serde_json::from_slice(&out.stdout).expect("one JSON document");
    let problems = answer["table_problems"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap().to_owned())
        .collect();
    (answer["duration_s"].as_f64().unwrap(), problems)
}

/// Plans `req` and compares every section with toppra: (linterpd's, toppra's) durations.
fn compare(name: &str, robot: &Robot, req: &PathRequest) -> (f64, f64) {
    let planned = plan_path(robot, req).unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut ours = 0.0;
    let mut theirs = 0.0;
    for (k, section) in planned.sections.iter().enumerate() {
        let first = &section.starts[0];
        let view = Section {
            path: section.path.clone(),
            start: robot.values_of(&first.start_counts()),
            starts: section.starts.iter().collect(),
        };
        let (reference, problems) =
            toppra(&request(robot, &view, &req.motion, req.path_accel_mm_s2));
        assert!(
            problems.is_empty(),
            "{name}, section {}: {problems:?}",
            k + 1
        );
        ours += section.starts.iter().map(Plan::duration_s).sum::<f64>();
        theirs += reference;
    }
    (ours, theirs)
}

/// A line as the path of one line element, as `plan_line` plans a line it cuts into starts.
fn line(from: Pose, to: Pose, motion: Motion) -> PathRequest {
    linterpd::plan::line_as_path(&MoveRequest {
        from: Origin::Pose(from),
        to,
        motion,
    })
}

fn motion(robot: &Robot, method: Method) -> Motion {
    Motion {
        method,
        frequency_model: FrequencyModel::Ideal,
        ..robot.motion
    }
}

fn seed_move(robot: &Robot, method: Method) -> PathRequest {
    let from = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let mut to = Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0);
    to.a_rad = from.a_rad;
    line(from, to, motion(robot, method))
}

fn short_arm() -> Robot {
    let mut robot = seed_robot();
    robot.kinematics = Model::Cylindrical(Cylindrical {
        l0_mm: 50.0,
        min_axis_distance_mm: 20.0,
    })
    .into();
    robot.joints[0].max_freq_hz = 20_000;
    robot.joints[0].min = (-360f64).to_radians();
    robot.joints[0].max = 360f64.to_radians();
    robot.motion.over_speed = OverSpeed::SlowDown;
    limited(robot, [2_000.0, 5_000.0, 2_000.0, 2_000.0])
}

fn near_the_axis(robot: &Robot, method: Method) -> PathRequest {
    let from = robot.pose_with_wrist_at_zero(-400.0, 100.0, 100.0).unwrap();
    let mut to = Pose::from_mm_deg(400.0, 100.0, 100.0, 0.0);
    to.a_rad = from.a_rad;
    line(from, to, motion(robot, method))
}

/// The property tests' SCARA at 600 mm/s, its arms' channels at 50 kHz (50 deg/s) and
/// 1000 deg/s^2: near full stretch its elbow turns fastest.
fn scara() -> Robot {
    let mut robot = common::scara();
    robot.motion.over_speed = OverSpeed::SlowDown;
    robot.motion.speed_mm_s = 600.0;
    robot.motion.accel_s = 0.1;
    robot.joints[0].max_freq_hz = 50_000;
    robot.joints[1].max_freq_hz = 50_000;
    limited(robot, [1_000.0, 1_000.0, 2_000.0, 3_000.0])
}

/// A line at x = 680 mm past a SCARA of 400 + 300 mm arms: 696 mm out at its ends, the elbow
/// within 13 degrees of straight.
fn scara_stretched(robot: &Robot, method: Method) -> PathRequest {
    let from = Pose::from_mm_deg(680.0, -150.0, 0.0, 0.0);
    let to = Pose::from_mm_deg(680.0, 150.0, 0.0, 0.0);
    line(from, to, motion(robot, method))
}

fn pick_and_place(robot: &Robot, method: Method) -> PathRequest {
    let text = include_str!("../config/examples/pick-and-place.toml");
    let doc = PathDoc::from_toml(text).unwrap();
    let here = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let start = doc
        .start_pose(here.a_rad, &|_| None)
        .unwrap()
        .unwrap_or(here);
    PathRequest {
        from: Origin::Pose(start),
        start: Some(start),
        elements: doc.resolve(start, &|_| None).unwrap(),
        motion: motion(robot, method),
        path_accel_mm_s2: doc.path_accel_mm_s2.unwrap(),
    }
}

/// A case: its name, its robot, its request by method.
type Case = (&'static str, Robot, fn(&Robot, Method) -> PathRequest);

/// The cases compared with toppra: the seed's move, a line near a short arm's axis, a SCARA
/// line near full stretch and the example pick and place.
fn cases() -> [Case; 4] {
    let seed = limited(seed_robot(), [200.0, 1_000.0, 1_000.0, 200.0]);
    [
        ("the seed's move", seed.clone(), seed_move),
        (
            "a line 100 mm from the axis, l0 50 mm",
            short_arm(),
            near_the_axis,
        ),
        ("a SCARA line near full stretch", scara(), scara_stretched),
        ("pick-and-place.toml", seed, pick_and_place),
    ]
}

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs toppra (the second suite: cargo test --features third-party-peers)"
)]
fn linterpd_runs_within_three_percent_of_toppra_and_no_row_breaks_a_limit() {
    let bounded = Method::BoundedError { tolerance_mm: 0.05 };
    println!("| case | method | linterpd s | toppra s | difference |");
    println!("|---|---|---|---|---|");
    let mut worst = 0.0_f64;
    let mut beyond = Vec::new();
    for (name, robot, request) in cases() {
        for method in [Method::ConstantPeriod, bounded] {
            let (ours, theirs) = compare(name, &robot, &request(&robot, method));
            let difference = ours / theirs - 1.0;
            println!(
                "| {name} | {} | {ours:.3} | {theirs:.3} | {:+.1} % |",
                method.name(),
                difference * 100.0
            );
            worst = worst.max(difference.abs());
            if difference.abs() > WITHIN {
                beyond.push(format!(
                    "{name}, {}: {ours:.3} s against toppra's {theirs:.3} s",
                    method.name()
                ));
            }
        }
    }
    println!("largest difference {:.1} %", worst * 100.0);
    assert!(beyond.is_empty(), "beyond {} %: {beyond:?}", WITHIN * 100.0);
}

/// S-curve ramps (jerk 20000 mm/s^3) on the same cases: slowed as a whole until the drives
/// follow them, so slower than toppra's time-optimal timing by what the jerk limit and the
/// whole-move slowing cost (reported, not bounded), never faster than it by more than the 3 %
/// the trapezoid is held to, and `toppra_duration.py`'s own check of the tables finds no row over
/// a limit.
#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs toppra (the second suite: cargo test --features third-party-peers)"
)]
fn s_curves_under_drive_limits_keep_every_limit_and_report_their_cost_against_toppra() {
    let bounded = Method::BoundedError { tolerance_mm: 0.05 };
    println!("| case | method | linterpd S-curve s | toppra s | difference |");
    println!("|---|---|---|---|---|");
    for (name, robot, request) in cases() {
        for method in [Method::ConstantPeriod, bounded] {
            let mut req = request(&robot, method);
            req.motion.ramp = linterpd::robot::Ramp::SCurve {
                jerk_mm_s3: 20_000.0,
            };
            let (ours, theirs) = compare(name, &robot, &req);
            let difference = ours / theirs - 1.0;
            println!(
                "| {name} | {} | {ours:.3} | {theirs:.3} | {:+.1} % |",
                method.name(),
                difference * 100.0
            );
            assert!(
                difference > -WITHIN,
                "{name}, {}: {ours:.3} s, faster than toppra's optimum {theirs:.3} s",
                method.name()
            );
        }
    }
}
