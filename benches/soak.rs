//! The soak: hundreds of moves back and forth (singly and in chained pairs) through a link that
//! corrupts, drops and delays replies at random, over MEWTOCOL-COM (in process, on paused time)
//! and over Modbus TCP (loopback, real time). Every move must end done or with a reason, no start
//! may act from counts other than its `from`, and no channel may run away.
//!
//! Run: `cargo bench --bench soak` (500 moves a link; `SOAK_MOVES=100` for fewer).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::Duration;

use linterpd::daemon::{
    Connector, Daemon, DaemonOptions, MoveOrder, RobotHandle, RobotSetup, Stage,
};
use linterpd::kinematics::JOINTS;
use linterpd::mewtocol::Station;
use linterpd::mock::{
    Anomaly, MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, ModbusServer,
    ModbusServerOptions, SharedMock, StartOutcome,
};
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{
    AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions, ModbusClient, ModbusFraming,
    ModbusOptions, PlcError,
};
use linterpd::robot::seed_robot;
use tokio::net::{TcpListener, TcpStream};

/// The faults: 2 % of replies corrupted, 2 % dropped, 1 % held back past the timeout.
pub const SCRIPT: &str = "seed=11,corrupt@2%,drop@2%,delay1000@1%";

/// Short moves out and back (about 0.4 s each).
const A: [f64; 3] = [-926.57, 535.03, 50.0];
const B: [f64; 3] = [-950.0, 560.0, 80.0];

/// How the daemon reaches the mock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SoakLink {
    /// MEWTOCOL-COM over `duplex` (runs on paused time).
    Mewtocol,
    /// Modbus TCP on loopback (real time).
    ModbusTcp,
}

/// What a soak saw.
#[derive(Debug, Default)]
pub struct Summary {
    /// Orders accepted.
    pub moves: usize,
    /// Orders refused at once (the link was down at that moment).
    pub refused: usize,
    /// Final stages.
    pub stages: BTreeMap<&'static str, usize>,
    /// The reasons of moves that did not end done.
    pub reasons: BTreeMap<String, usize>,
    /// Orders that did not end within their bound.
    pub unfinished: usize,
    /// Done moves off their target by more than a pulse.
    pub off_target: usize,
    /// Starts the mock acted on.
    pub starts: usize,
    /// Starts (acted on or refused) whose `from` was not the counts.
    pub from_mismatches: usize,
    /// Channels that ran on without end.
    pub runaways: usize,
}

fn counts_at(p: [f64; 3]) -> [i64; JOINTS] {
    let robot = seed_robot();
    let pose = robot.pose_with_wrist_at_zero(p[0], p[1], p[2]).unwrap();
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &pose, None).unwrap();
    robot.counts_of(&q)
}

fn link_error(e: std::io::Error) -> PlcError {
    PlcError::Link {
        operation: "connect".into(),
        source: e,
    }
}

async fn connector(link: SoakLink, shared: &SharedMock) -> Connector {
    match link {
        SoakLink::Mewtocol => {
            let shared = shared.clone();
            Box::new(move || {
                let shared = shared.clone();
                Box::pin(async move {
                    let (ours, theirs) = tokio::io::duplex(4_096);
                    let server = MewtocolServer::new(shared, MewtocolServerOptions::default());
                    tokio::spawn(async move { server.serve(theirs).await });
                    let options =
                        MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
                    Ok(AnyPlc::Mewtocol(MewtocolClient::new(
                        Box::new(ours) as BoxedLink,
                        options,
                    )))
                })
            })
        }
        SoakLink::ModbusTcp => {
            let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
            let address = listener.local_addr().unwrap();
            let server = ModbusServer::new(shared.clone(), ModbusServerOptions::default());
            tokio::spawn(server.serve_tcp(listener));
            Box::new(move || {
                Box::pin(async move {
                    let stream = TcpStream::connect(address).await.map_err(link_error)?;
                    let options = ModbusOptions::new(ModbusFraming::Tcp, 1);
                    Ok(AnyPlc::Modbus(ModbusClient::new(
                        Box::new(stream) as BoxedLink,
                        options,
                    )))
                })
            })
        }
    }
}

async fn until_ready(h: &RobotHandle) {
    for _ in 0..6_000 {
        let s = h.state();
        if s.link.connected && s.refuses.is_none() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    panic!("not ready within 30 s: {:?}", h.state());
}

fn order(p: [f64; 3]) -> MoveOrder {
    MoveOrder {
        to: Some(p.to_vec()),
        ..MoveOrder::default()
    }
}

/// Runs `moves` orders through `link` with [`SCRIPT`]'s faults.
///
/// # Panics
/// If the mock or the daemon cannot be set up, or the daemon never takes a move.
pub async fn soak(link: SoakLink, moves: usize) -> Summary {
    let robot = seed_robot();
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    for (j, c) in counts_at(A).into_iter().enumerate() {
        mock.set_count(usize::from(robot.joints[j].channel), c);
    }
    let shared = SharedMock::new(mock);
    let driver = tokio::spawn(shared.clone().run_scans());
    let setup = RobotSetup {
        robot,
        settings: ContractSettings::default(),
        connect: connector(link, &shared).await,
        home_counts: counts_at(A),
        gateway: linterpd::gateway::GatewaySettings::default(),
        cell: linterpd::config::CellSettings::default(),
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let h = daemon.robot("press-loader").unwrap().clone();
    until_ready(&h).await;
    shared.with(|m| m.set_faults(SCRIPT.parse().unwrap()));
    let mut summary = Summary::default();
    let (mut round, mut at_a) = (0, true);
    while summary.moves < moves {
        // Out and back; every third time from A both at once: the second chains behind the first.
        round += 1;
        let targets: &[[f64; 3]] = match (at_a, round % 3 == 0) {
            (true, true) => &[B, A],
            (true, false) => &[B],
            (false, _) => &[A],
        };
        at_a = targets.last() == Some(&A);
        let mut ids = Vec::new();
        for &to in targets {
            match h.submit(order(to)).await {
                Ok(id) => ids.push(id),
                Err(_) => summary.refused += 1,
            }
        }
        if ids.is_empty() {
            until_ready(&h).await;
            continue;
        }
        for id in ids {
            summary.moves += 1;
            let r = h.wait(id, Duration::from_secs(60)).await.unwrap();
            if !r.stage.is_final() {
                summary.unfinished += 1;
                continue;
            }
            *summary.stages.entry(r.stage.name()).or_default() += 1;
            if r.stage == Stage::Done {
                if r.final_error_pulses
                    .is_some_and(|e| e.iter().any(|p| p.abs() > 1))
                {
                    summary.off_target += 1;
                }
            } else {
                let why = r.error.unwrap_or_else(|| "no reason".into());
                // Group by the reason's words, not the numbers in it.
                let key: String = why.chars().filter(|c| !c.is_ascii_digit()).collect();
                *summary.reasons.entry(key).or_default() += 1;
            }
        }
    }
    shared.with(|m| {
        summary.starts = m
            .starts()
            .iter()
            .filter(|s| s.outcome == StartOutcome::Started)
            .count();
        summary.from_mismatches = m.starts().iter().filter(|s| s.from_mismatch()).count();
        summary.runaways = m
            .anomalies()
            .iter()
            .filter(|a| matches!(a, Anomaly::RunOn { .. }))
            .count();
    });
    daemon.shut_down().await;
    driver.abort();
    summary
}

/// The summary as text.
#[must_use]
pub fn report(link: SoakLink, s: &Summary) -> String {
    let mut out = format!(
        "{link:?}, {SCRIPT}: {} moves ({} refused at once while the link was down), final: {:?}; \
         unfinished {}, done off target {}, starts acted on {}, starts from wrong counts {}, \
         runaways {}",
        s.moves,
        s.refused,
        s.stages,
        s.unfinished,
        s.off_target,
        s.starts,
        s.from_mismatches,
        s.runaways
    );
    for (why, n) in &s.reasons {
        let _ = write!(out, "\n  {n} x {why}");
    }
    out
}

/// Whether the soak kept every invariant.
#[must_use]
pub fn clean(s: &Summary) -> bool {
    s.unfinished == 0 && s.off_target == 0 && s.from_mismatches == 0 && s.runaways == 0
}

#[allow(dead_code)]
fn main() {
    let moves: usize = std::env::var("SOAK_MOVES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(500);
    for link in [SoakLink::Mewtocol, SoakLink::ModbusTcp] {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .start_paused(link == SoakLink::Mewtocol)
            .build()
            .unwrap();
        let began = std::time::Instant::now();
        let summary = rt.block_on(soak(link, moves));
        println!("{}", report(link, &summary));
        println!("  ({:.1} s)", began.elapsed().as_secs_f64());
        assert!(clean(&summary), "an invariant broke");
    }
}
