//! What the register gateway costs the moves: the seed's move back and forth on the mock PLC over
//! MEWTOCOL-COM at an emulated 19200 baud (the shipped config's line), first with the gateway
//! idle, then with a client keeping it busy (a 24-word write and a 24-word read of DT100, over and
//! over, as fast as they are answered). For each: how soon a move starts (accepted -> the PLC
//! acting on its start, less the upload), the upload and the motion, and, with the client, the
//! longest a due status read waited behind a gateway exchange and the longest gateway exchange.
//!
//! On paused tokio time: the emulated wire and the mock's scans take their time in virtual time,
//! so the figures are what the 19200-baud line gives, whatever the machine.
//!
//! Run: `cargo bench --bench gateway`

use std::time::Duration;

use linterpd::contract::Layout;
use linterpd::daemon::{
    Connector, Daemon, DaemonOptions, GatewayStats, MoveOrder, RobotHandle, RobotSetup, Stage,
    Values,
};
use linterpd::gateway::{AccessList, GatewaySettings};
use linterpd::kinematics::JOINTS;
use linterpd::mewtocol::Station;
use linterpd::mock::{
    MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, SharedMock, StartOutcome,
};
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use linterpd::robot::seed_robot;

const P1: [f64; 3] = [-926.57, 535.03, 50.0];
const P2: [f64; 3] = [-1144.43, 659.60, 186.60];
const MOVES: usize = 8;
const BAUD: u32 = 19_200;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// A fresh duplex MEWTOCOL link to the mock, served at 19200 baud, for every (re)connection.
fn connector(shared: &SharedMock) -> Connector {
    let shared = shared.clone();
    Box::new(move || {
        let shared = shared.clone();
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

fn spawn(shared: &SharedMock) -> (Daemon, RobotHandle) {
    let range = |t: &str| t.parse().unwrap();
    let access = AccessList::new(
        vec![range("DT0-DT999")],
        vec![range("DT100-DT199")],
        &Layout::default(),
    )
    .unwrap();
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect: connector(shared),
        home_counts: [0; JOINTS],
        cell: linterpd::config::CellSettings::default(),
        gateway: GatewaySettings {
            access,
            modbus: None,
        },
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let handle = daemon.robot("press-loader").unwrap().clone();
    (daemon, handle)
}

/// Keeps the gateway busy until the daemon shuts down; returns the requests it made.
async fn hammer(h: RobotHandle) -> u64 {
    let start = "DT100".parse().unwrap();
    let mut requests = 0;
    loop {
        let words: Vec<u16> = (0..24).map(|i| (requests as u16).wrapping_add(i)).collect();
        if h.write_registers(start, Values::Words(words))
            .await
            .is_err()
            || h.read_registers(start, 24).await.is_err()
        {
            return requests;
        }
        requests += 2;
    }
}

/// Figures of one run of [`MOVES`] moves.
struct Figures {
    to_start_ms: Vec<f64>,
    upload_s: Vec<f64>,
    motion_s: Vec<f64>,
    gateway: GatewayStats,
    served: u64,
}

async fn run(busy: bool) -> Figures {
    let robot = seed_robot();
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    let start = robot.pose_with_wrist_at_zero(P1[0], P1[1], P1[2]).unwrap();
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &start, None).unwrap();
    for (j, c) in robot.counts_of(&q).into_iter().enumerate() {
        mock.set_count(usize::from(robot.joints[j].channel), c);
    }
    let shared = SharedMock::new(mock);
    tokio::spawn(shared.clone().run_scans());
    let (daemon, h) = spawn(&shared);
    while h.state().refuses.is_some() || !h.state().link.connected || h.state().counts.is_none() {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let client = busy.then(|| tokio::spawn(hammer(h.clone())));
    let mut f = Figures {
        to_start_ms: Vec::new(),
        upload_s: Vec::new(),
        motion_s: Vec::new(),
        gateway: GatewayStats::default(),
        served: 0,
    };
    let before = h.state().gateway.requests;
    for i in 0..MOVES {
        tokio::time::sleep(Duration::from_millis(400)).await;
        let to = if i % 2 == 0 { P2 } else { P1 };
        let accepted_s = shared.now_s();
        let id = h
            .submit(MoveOrder {
                to: Some(to.to_vec()),
                ..MoveOrder::default()
            })
            .await
            .unwrap();
        let r = h.wait(id, Duration::from_secs(60)).await.unwrap();
        assert_eq!(r.stage, Stage::Done, "{r:?}");
        let seq = r.seq.unwrap();
        let acted_s = shared.with(|m| {
            m.starts()
                .iter()
                .find(|s| s.block.seq == seq && s.outcome == StartOutcome::Started)
                .map(|s| s.at_s)
                .unwrap()
        });
        let upload_s = r.upload_s.unwrap();
        f.to_start_ms.push((acted_s - accepted_s - upload_s) * 1e3);
        f.upload_s.push(upload_s);
        f.motion_s.push(r.motion_s.unwrap());
    }
    f.gateway = h.state().gateway;
    f.served = f.gateway.requests - before;
    daemon.shut_down().await;
    if let Some(client) = client {
        client.await.unwrap();
    }
    for v in [&mut f.to_start_ms, &mut f.upload_s, &mut f.motion_s] {
        v.sort_by(f64::total_cmp);
    }
    f
}

fn main() {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .unwrap();
    println!(
        "the seed's move back and forth, {MOVES} moves, MEWTOCOL-COM % frames at an emulated {BAUD} baud, paused time"
    );
    println!(
        "| gateway | start latency less upload: median / max | upload (median) | motion (median) | gateway requests served during the run | longest status-read wait behind a gateway exchange | longest gateway exchange |"
    );
    println!("|---|---|---|---|---|---|---|");
    for busy in [false, true] {
        let f = runtime.block_on(run(busy));
        println!(
            "| {} | {:.1} / {:.1} ms | {:.2} s | {:.2} s | {} | {} ms | {} ms |",
            if busy { "a client hammering" } else { "idle" },
            percentile(&f.to_start_ms, 0.5),
            f.to_start_ms[f.to_start_ms.len() - 1],
            percentile(&f.upload_s, 0.5),
            percentile(&f.motion_s, 0.5),
            f.served,
            f.gateway.longest_poll_delay_ms,
            f.gateway.longest_exchange_ms,
        );
    }
}
