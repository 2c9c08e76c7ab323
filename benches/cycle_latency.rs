//! Input-to-motion in a cycle: from an input changing in the mock PLC to the PLC acting on the
//! start of the move the cycle waited to make, over MEWTOCOL-COM on an emulated serial line at
//! 19200 and 115200 baud (real time, 2 ms scans). The cycle alternates: wait for X5 on, a move
//! of 20 mm, wait for X5 off, the move back. What it costs: the status read that sees the input
//! (at most one poll interval, 20 ms, plus the read), then the start write: the move after a
//! wait is prepared ahead (planned, uploaded, read back and held; docs/CYCLES.md) while the move
//! before it runs, or during the wait for the first. An input that changes while an upload is
//! still being written during its wait is seen once it is done.
//!
//! Run: `cargo bench --bench cycle_latency`

use std::time::Duration;

use linterpd::config::CellSettings;
use linterpd::daemon::{CycleState, Daemon, DaemonOptions, RobotSetup};
use linterpd::kinematics::JOINTS;
use linterpd::mewtocol::Station;
use linterpd::mock::{MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, SharedMock};
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use linterpd::robot::seed_robot;

const P1: [f64; 3] = [-926.57, 535.03, 50.0];
const TOGGLES: usize = 20;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn program() -> String {
    let up = [P1[0], P1[1], P1[2] + 20.0];
    format!(
        "[[step]]\nlabel = \"w\"\nwait = \"X5\"\n[[step]]\nmove = {{ to = {up:?} }}\n\
         [[step]]\nwait = \"!X5\"\n[[step]]\nmove = {{ to = {P1:?} }}\n\
         [[step]]\nloop = {{ to = \"w\", until = \"stop\" }}\n"
    )
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() {
    for baud in [19_200, 115_200] {
        let (mut latency, mut seen) = run(baud).await;
        // The first wait's move is prepared during that wait, not during a move before it.
        let later_max = latency[1..].iter().copied().fold(0.0, f64::max);
        latency.sort_by(f64::total_cmp);
        seen.sort_by(f64::total_cmp);
        println!(
            "{baud} baud, MEWTOCOL %, {TOGGLES} input changes: input -> start acted on by the PLC: \
             median {:.1} ms, max {:.1} ms (after the first change: max {later_max:.1} ms); of it, \
             input -> the wait met (status read): median {:.1} ms, max {:.1} ms",
            percentile(&latency, 0.5),
            latency[latency.len() - 1],
            percentile(&seen, 0.5),
            seen[seen.len() - 1],
        );
    }
}

/// Per input change: ms to the start acted on, ms to the wait seen met.
async fn run(baud: u32) -> (Vec<f64>, Vec<f64>) {
    let robot = seed_robot();
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    let start = robot.pose_with_wrist_at_zero(P1[0], P1[1], P1[2]).unwrap();
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &start, None).unwrap();
    for (j, c) in robot.counts_of(&q).into_iter().enumerate() {
        mock.set_count(usize::from(robot.joints[j].channel), c);
    }
    let shared = SharedMock::new(mock);
    tokio::spawn(shared.clone().run_scans());
    let served = shared.clone();
    let connect: linterpd::daemon::Connector = Box::new(move || {
        let shared = served.clone();
        Box::pin(async move {
            let (ours, theirs) = tokio::io::duplex(4_096);
            let options = MewtocolServerOptions {
                baud: Some(baud),
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
    });
    let dir = std::env::temp_dir().join(format!(
        "linterpd-bench-cycles-{}-{baud}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("toggle.toml"), program()).unwrap();
    let setup = RobotSetup {
        robot,
        settings: ContractSettings::default(),
        connect,
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
    h.run_cycle("toggle", None).await.unwrap();
    let (mut latency, mut seen) = (Vec::new(), Vec::new());
    for i in 0..TOGGLES {
        // The cycle waits (and the robot stands) a while before the input changes.
        loop {
            let s = h.cycle().unwrap();
            if s.state == CycleState::Waiting && h.state().current_move.is_none() {
                break;
            }
            assert!(!s.state.is_final(), "{s:?}");
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
        let before = shared.with(|m| m.starts().len());
        let changed_s = shared.with(|m| {
            m.set_input(5, i % 2 == 0).unwrap();
            m.now_s()
        });
        let mut met = None;
        let started_s = loop {
            if met.is_none() && h.cycle().unwrap().state != CycleState::Waiting {
                met = Some(shared.now_s());
            }
            if let Some(r) = shared.with(|m| m.starts().get(before).copied()) {
                break r.at_s;
            }
            tokio::time::sleep(Duration::from_millis(1)).await;
        };
        latency.push((started_s - changed_s) * 1e3);
        seen.push((met.unwrap_or(started_s) - changed_s) * 1e3);
    }
    let _ = h.stop_cycle(true).await;
    daemon.shut_down().await;
    let _ = std::fs::remove_dir_all(&dir);
    (latency, seen)
}
