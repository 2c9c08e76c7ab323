//! Issue 48's goal: a pick-and-place cycle with blended approach and retreat at least 20 %
//! shorter than the same steps stopped at every waypoint, measured on the mock's pulse trace.
//!
//! One cycle program, run by the daemon against the mock PLC in process (MEWTOCOL `%` on an
//! emulated 115200-baud line, real time, 2 ms scans, the seed robot at its defaults: 240 mm/s,
//! Ta 200 ms, constant-period 50 ms), from the pick (the seed's P1):
//!
//! ```text
//!   dwell 100 ms (the gripper closes)
//!   up 100 mm over the pick          blend_mm = B
//!   across to 100 mm over the place  blend_mm = B   (the seed's P2)
//!   down to the place
//!   dwell 100 ms (the gripper opens)
//!   up 100 mm over the place         blend_mm = B
//!   across to 100 mm over the pick   blend_mm = B
//!   down to the pick
//! ```
//!
//! once with every `blend_mm` (B = 20, 40 and 50 mm, 50 the most the 100 mm moves up and down
//! allow: a blend takes at most half of either move beside it; each run's corners at its default
//! acceleration, speed / Ta = 1200 mm/s2, and with `path_accel = "5000mm/s2"` on its first
//! move), once without (a stop at every waypoint). Measured on the trace:
//! the cycle time, from one arrival at the pick (the last pulse that puts every channel on the
//! pick's counts) to the next, over the cycles after the first; the motion from the first
//! pulse to the last, per cycle.
//!
//! Run: `cargo bench --bench cycle_blend`
//!
//! To see where the time goes: `BLEND_TIMELINE=1` prints one cycle's motions (pulses less than
//! 40 ms apart) and the gaps between them, per run; `RUST_LOG=linterpd=info` the daemon's
//! `start written` lines (`upload_s`, `chained`, `behind_s`); `BLEND_MOTION` is added to every
//! move step's table, e.g. `BLEND_MOTION=', method = "bounded-error", tolerance_mm = 0.05'`.

use std::time::Duration;

use linterpd::config::CellSettings;
use linterpd::daemon::{CycleState, Daemon, DaemonOptions, RobotSetup};
use linterpd::kinematics::{JOINTS, Kinematics};
use linterpd::mewtocol::Station;
use linterpd::mock::{MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, SharedMock};
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use linterpd::robot::seed_robot;

const PICK: [f64; 3] = [-926.57, 535.03, 50.0];
const PLACE: [f64; 3] = [-1144.43, 659.60, 186.60];
const CYCLES: u64 = 4;
const BAUD: u32 = 115_200;

/// How a run is blended: its corners' distance and, when given, its path acceleration.
#[derive(Debug, Clone, Copy)]
struct Blend {
    mm: f64,
    path_accel: Option<f64>,
}

fn above(p: [f64; 3]) -> [f64; 3] {
    [p[0], p[1], p[2] + 100.0]
}

/// The program, blended by `blend.mm` at the four waypoints over the pick and the place (each
/// run's corners at `blend.path_accel`, when given), or stopped at every one (`None`).
fn program(blend: Option<Blend>) -> String {
    let first = blend
        .map(|b| {
            let accel = b
                .path_accel
                .map(|a| format!("path_accel = \"{a}mm/s2\"\n"))
                .unwrap_or_default();
            format!("blend_mm = {}\n{accel}", b.mm)
        })
        .unwrap_or_default();
    let blend = blend
        .map(|b| format!("blend_mm = {}\n", b.mm))
        .unwrap_or_default();
    let extra = std::env::var("BLEND_MOTION").unwrap_or_default();
    let step =
        |p: [f64; 3], blend: &str| format!("[[step]]\nmove = {{ to = {p:?}{extra} }}\n{blend}");
    let dwell = "[[step]]\ndwell = \"100ms\"\n".to_owned();
    [
        dwell.clone(),
        step(above(PICK), &first),
        step(above(PLACE), &blend),
        step(PLACE, ""),
        dwell,
        step(above(PLACE), &first),
        step(above(PICK), &blend),
        step(PICK, ""),
    ]
    .concat()
}

/// The seed robot's counts at `p` (wrist at 0), per joint (joint j on channel j).
fn counts_at(p: [f64; 3]) -> [i64; JOINTS] {
    let robot = seed_robot();
    let pose = robot.pose_with_wrist_at_zero(p[0], p[1], p[2]).unwrap();
    robot.counts_of(&robot.kinematics.ik(&pose, None).unwrap())
}

/// What one run measured, s: the cycle time (arrival at the pick to the next, cycles after
/// the first) and the motion from first to last pulse, per cycle.
struct Measured {
    cycle_s: f64,
    motion_s: f64,
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() {
    // RUST_LOG=linterpd=info shows the daemon's `start written` lines (upload_s, behind_s).
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_default_env())
        .with_writer(std::io::stderr)
        .init();
    let stopped = run(None).await;
    println!(
        "stopped at every waypoint: cycle {:.3} s (first to last pulse {:.3} s a cycle)",
        stopped.cycle_s, stopped.motion_s
    );
    for blend in [20.0, 40.0, 50.0]
        .into_iter()
        .flat_map(|mm| [None, Some(5_000.0)].map(|path_accel| Blend { mm, path_accel }))
    {
        let blended = run(Some(blend)).await;
        let accel = blend
            .path_accel
            .map(|a| format!(", path_accel {a} mm/s2"))
            .unwrap_or_default();
        println!(
            "blend_mm = {}{accel}: cycle {:.3} s (first to last pulse {:.3} s a cycle): \
             {:.1} % shorter than stopped ({:.1} % by first to last pulse)",
            blend.mm,
            blended.cycle_s,
            blended.motion_s,
            (1.0 - blended.cycle_s / stopped.cycle_s) * 100.0,
            (1.0 - blended.motion_s / stopped.motion_s) * 100.0,
        );
    }
}

fn connector(shared: &SharedMock) -> linterpd::daemon::Connector {
    let served = shared.clone();
    Box::new(move || {
        let shared = served.clone();
        Box::pin(async move {
            let (ours, theirs) = tokio::io::duplex(4_096);
            let options = MewtocolServerOptions {
                baud: Some(BAUD),
                ..MewtocolServerOptions::default()
            };
            let server = MewtocolServer::new(shared, options);
            tokio::spawn(async move { server.serve(theirs).await });
            let options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
            Ok(AnyPlc::Mewtocol(MewtocolClient::new(
                Box::new(ours) as BoxedLink,
                options,
            )))
        })
    })
}

async fn run(blend: Option<Blend>) -> Measured {
    let robot = seed_robot();
    let pick = counts_at(PICK);
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    for (j, c) in pick.into_iter().enumerate() {
        mock.set_count(usize::from(robot.joints[j].channel), c);
    }
    mock.record_pulses(true);
    let shared = SharedMock::new(mock);
    let scans = tokio::spawn(shared.clone().run_scans());
    let dir = std::env::temp_dir().join(format!(
        "linterpd-bench-blend-{}-{}-{}",
        std::process::id(),
        blend.map_or(0.0, |b| b.mm),
        blend.and_then(|b| b.path_accel).unwrap_or(0.0)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("pp.toml"), program(blend)).unwrap();
    let setup = RobotSetup {
        robot,
        settings: ContractSettings::default(),
        connect: connector(&shared),
        home_counts: [0; JOINTS],
        gateway: linterpd::gateway::GatewaySettings::default(),
        cell: CellSettings {
            programs: Some(dir.clone()),
            ..CellSettings::default()
        },
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let h = daemon.robot("press-loader").unwrap().clone();
    while h.state().refuses.is_some() || !h.state().link.connected {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    h.run_cycle("pp", Some(CYCLES)).await.unwrap();
    let s = loop {
        let s = h.cycle().unwrap();
        // A faulted cycle stands until cleared: the run ends there (the assert names it).
        if s.state.is_final() || s.state == CycleState::Faulted {
            break s;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    };
    assert_eq!((s.state, s.done), (CycleState::Done, CYCLES), "{s:?}");
    let mut pulses = shared.with(MockPlc::take_pulses);
    daemon.shut_down().await;
    scans.abort();
    let _ = std::fs::remove_dir_all(&dir);
    pulses.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let mut counts = pick;
    let mut arrivals = Vec::new();
    for p in &pulses {
        counts[usize::from(p.channel)] = p.count;
        if counts == pick {
            arrivals.push(p.time_s);
        }
    }
    assert_eq!(
        arrivals.len() as u64,
        CYCLES,
        "one arrival at the pick a cycle"
    );
    if std::env::var_os("BLEND_TIMELINE").is_some() {
        let each: Vec<String> = arrivals
            .windows(2)
            .map(|w| format!("{:.3}", w[1] - w[0]))
            .collect();
        eprintln!("cycles after the first: {} s", each.join(" / "));
        timeline(&pulses, arrivals[1], arrivals[2]);
    }
    let (first, last) = (pulses[0].time_s, pulses[pulses.len() - 1].time_s);
    Measured {
        cycle_s: (arrivals[arrivals.len() - 1] - arrivals[0]) / (CYCLES - 1) as f64,
        motion_s: (last - first) / CYCLES as f64,
    }
}

/// With `BLEND_TIMELINE` set: the motions of one cycle (from `from` to `to`, s on the trace),
/// a motion being pulses less than 40 ms apart, with the gaps between them.
fn timeline(pulses: &[linterpd::mock::PulsePoint], from: f64, to: f64) {
    let times: Vec<f64> = pulses
        .iter()
        .map(|p| p.time_s)
        .filter(|t| *t > from && *t <= to)
        .collect();
    let (mut moving, mut gaps) = (0.0, times[0] - from);
    let (mut start, mut prev) = (times[0], times[0]);
    eprintln!("gap {:.3}", times[0] - from);
    for &t in &times[1..] {
        if t - prev > 0.040 {
            eprintln!(
                "motion {:.3} (at {:.3})\ngap {:.3}",
                prev - start,
                start - from,
                t - prev
            );
            moving += prev - start;
            gaps += t - prev;
            start = t;
        }
        prev = t;
    }
    eprintln!("motion {:.3} (at {:.3})", prev - start, start - from);
    moving += prev - start;
    eprintln!("cycle {:.3}: motion {moving:.3}, gaps {gaps:.3}", to - from);
}
