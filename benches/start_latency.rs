//! How soon a move starts: from the daemon accepting an order to the PLC acting on its start
//! command, less the upload (write and read back), over TCP to the mock PLC on loopback in real
//! time. The worker wakes on the order (no idle poll to wait for) and takes the heartbeat's
//! freshness from the reads it already makes; after the upload it reads the status until the
//! heartbeat is seen moving (a scan or two), then writes the start.
//!
//! Run: `cargo bench --bench start_latency`

use std::time::Duration;

use linterpd::daemon::{Daemon, DaemonOptions, MoveOrder, RobotSetup, Stage};
use linterpd::kinematics::JOINTS;
use linterpd::mewtocol::Station;
use linterpd::mock::{
    MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, SharedMock, StartOutcome,
};
use linterpd::order::OrderMotion;
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use linterpd::robot::seed_robot;
use tokio::net::{TcpListener, TcpStream};

const P1: [f64; 3] = [-926.57, 535.03, 50.0];
const P2: [f64; 3] = [-1144.43, 659.60, 186.60];
const MOVES: usize = 20;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

#[tokio::main(flavor = "current_thread")]
async fn main() {
    let robot = seed_robot();
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    let start = robot.pose_with_wrist_at_zero(P1[0], P1[1], P1[2]).unwrap();
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &start, None).unwrap();
    for (j, c) in robot.counts_of(&q).into_iter().enumerate() {
        mock.set_count(usize::from(robot.joints[j].channel), c);
    }
    let shared = SharedMock::new(mock);
    tokio::spawn(shared.clone().run_scans());
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let server = MewtocolServer::new(shared.clone(), MewtocolServerOptions::default());
    tokio::spawn(server.serve_tcp(listener));
    let connect: linterpd::daemon::Connector = Box::new(move || {
        Box::pin(async move {
            let stream =
                TcpStream::connect(address)
                    .await
                    .map_err(|e| linterpd::plc::PlcError::Link {
                        operation: "connect".into(),
                        source: e,
                    })?;
            stream.set_nodelay(true).ok();
            let options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Angle);
            Ok(AnyPlc::Mewtocol(MewtocolClient::new(
                Box::new(stream) as BoxedLink,
                options,
            )))
        })
    });
    let setup = RobotSetup {
        robot,
        settings: ContractSettings::default(),
        connect,
        home_counts: [0; JOINTS],
        gateway: linterpd::gateway::GatewaySettings::default(),
        cell: linterpd::config::CellSettings::default(),
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let h = daemon.robot("press-loader").unwrap().clone();
    while h.state().refuses.is_some() || !h.state().link.connected {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let (mut to_start, uploads, _) = latencies(&h, &shared, [P2, P1], None).await;
    let mut uploads = uploads;
    to_start.sort_by(f64::total_cmp);
    uploads.sort_by(f64::total_cmp);
    println!(
        "accepted -> start acted on by the PLC, less the upload, over TCP ({MOVES} moves, MEWTOCOL <, the seed's move back and forth, 2 ms scans):"
    );
    println!(
        "  median {:.1} ms, 90th percentile {:.1} ms, max {:.1} ms",
        percentile(&to_start, 0.5),
        percentile(&to_start, 0.9),
        to_start[to_start.len() - 1]
    );
    println!(
        "  upload with read-back: median {:.1} ms, max {:.1} ms",
        percentile(&uploads, 0.5),
        uploads[uploads.len() - 1]
    );
    // A line past a reversal is cut into two starts; its first is started once both are
    // uploaded and read back. Against the seed's move at the same tolerance, one start.
    let (sin, cos) = (-30_f64).to_radians().sin_cos();
    let turned = [P1[0] * cos - P1[1] * sin, P1[0] * sin + P1[1] * cos, P1[2]];
    for (name, ends) in [
        ("the seed's move, one start", [P2, P1]),
        ("P1 and P1 turned 30 deg, cut in two starts", [turned, P1]),
    ] {
        let (mut less, mut uploads, mut whole) = latencies(&h, &shared, ends, Some(0.05)).await;
        for v in [&mut less, &mut uploads, &mut whole] {
            v.sort_by(f64::total_cmp);
        }
        println!("bounded-error 0.05 mm, {name} ({MOVES} moves back and forth):");
        println!(
            "  accepted -> first start acted on: median {:.1} ms, max {:.1} ms; less its upload: median {:.1} ms, max {:.1} ms; upload with read-back: median {:.1} ms",
            percentile(&whole, 0.5),
            whole[whole.len() - 1],
            percentile(&less, 0.5),
            less[less.len() - 1],
            percentile(&uploads, 0.5),
        );
    }
    daemon.shut_down().await;
}

/// [`MOVES`] moves to `ends` in turn, each after 0.4 s of idling, at bounded-error `tolerance_mm`
/// or as configured: for each, from the daemon accepting it to the PLC acting on its first
/// start, less that start's upload with read-back (ms); the upload (ms); the whole (ms).
async fn latencies(
    h: &linterpd::daemon::RobotHandle,
    shared: &SharedMock,
    ends: [[f64; 3]; 2],
    tolerance_mm: Option<f64>,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let (mut to_start, mut uploads, mut whole) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..MOVES {
        // Idle for a while first, as between orders on a line.
        tokio::time::sleep(Duration::from_millis(400)).await;
        let to = ends[i % 2];
        let accepted_s = shared.now_s();
        let ids = h
            .submit_starts(MoveOrder {
                to: Some(to.to_vec()),
                motion: OrderMotion {
                    tolerance_mm,
                    ..OrderMotion::default()
                },
                ..MoveOrder::default()
            })
            .await
            .unwrap();
        let mut first = None;
        for id in &ids {
            let r = h.wait(*id, Duration::from_secs(10)).await.unwrap();
            assert_eq!(r.stage, Stage::Done, "{r:?}");
            first.get_or_insert(r);
        }
        let r = first.unwrap();
        let seq = r.seq.unwrap();
        let acted_s = shared.with(|m| {
            m.starts()
                .iter()
                .find(|s| s.block.seq == seq && s.outcome == StartOutcome::Started)
                .map(|s| s.at_s)
                .unwrap()
        });
        let upload_s = r.upload_s.unwrap();
        to_start.push((acted_s - accepted_s - upload_s) * 1e3);
        uploads.push(upload_s * 1e3);
        whole.push((acted_s - accepted_s) * 1e3);
    }
    (to_start, uploads, whole)
}
