//! A press cycle soaked through a lossy link: the press-loading program's shape (wait for the
//! press, an interlocked move in, outputs, a move out) run cycle after cycle by the daemon
//! against the mock PLC and a simulated press, over MEWTOCOL-COM in process on paused time,
//! with replies corrupted and dropped at random. The operator is simulated too: a faulted cycle
//! is left alone for 5 s (it must not go on by itself), then cleared and resumed.
//!
//! Checked over every start the mock acted on: I1 never from counts other than its plan's
//! (`from`), no seq acted on twice, I6 every start's permit held on the inputs of its scan;
//! I8 a faulted cycle started nothing while it waited for the operator; and every cycle ended
//! done, or faulted with a reason.
//!
//! Run: `cargo bench --bench cycle_soak` (1000 cycles; `CYCLES=N` for another count).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::Duration;

use linterpd::config::CellSettings;
use linterpd::contract::Layout;
use linterpd::daemon::{CycleState, Daemon, DaemonOptions, RobotHandle, RobotSetup};
use linterpd::gateway::{AccessList, Area, GatewaySettings};
use linterpd::kinematics::JOINTS;
use linterpd::mewtocol::Station;
use linterpd::mock::{
    MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, SharedMock, StartOutcome,
};
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use linterpd::robot::seed_robot;

/// The link's faults.
pub const SCRIPT: &str = "seed=5,corrupt@2%,drop@2%";
const A: [f64; 3] = [-926.57, 535.03, 50.0];
const B: [f64; 3] = [-950.0, 560.0, 80.0];
/// How long the press strokes after `press_go`, s.
const STROKE_S: f64 = 0.3;
/// How long the operator leaves a faulted cycle alone, s.
const OPERATOR_S: u64 = 5;

/// What the soak saw.
#[derive(Debug, Default)]
pub struct Summary {
    /// Cycles done.
    pub done: u64,
    /// Faults, by reason (digits left out).
    pub faults: BTreeMap<String, usize>,
    /// Starts the mock acted on.
    pub starts: usize,
    /// I1: starts acted on from counts other than their `from`.
    pub from_mismatches: usize,
    /// Seqs acted on twice.
    pub repeated_seqs: usize,
    /// I6: starts acted on whose permit did not hold on that scan's inputs.
    pub permit_violations: usize,
    /// I8: starts while a faulted cycle waited for the operator.
    pub resumed_by_itself: usize,
    /// Whether it ended done.
    pub finished: bool,
}

fn program() -> String {
    format!(
        "[[step]]\nwait = \"press_open & !press_moving\"\ntimeout = \"30s\"\n\
         [[step]]\nmove = {{ to = {B:?} }}\npermit = \"press_open & !press_moving\"\n\
         [[step]]\nset = {{ press_go = true }}\n\
         [[step]]\nmove = {{ to = {A:?} }}\n\
         [[step]]\nset = {{ press_go = false }}\n"
    )
}

fn counts_at(p: [f64; 3]) -> [i64; JOINTS] {
    let robot = seed_robot();
    let pose = robot.pose_with_wrist_at_zero(p[0], p[1], p[2]).unwrap();
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &pose, None).unwrap();
    robot.counts_of(&q)
}

/// The simulated press: open and still until `press_go`; then closed and moving for
/// [`STROKE_S`]; then open again once `press_go` is reset.
async fn press(shared: SharedMock) {
    let mut stroke_until: Option<f64> = None;
    loop {
        tokio::time::sleep(Duration::from_millis(5)).await;
        shared.with(|m| {
            let go = m.memory().bit(Area::Y, 0).unwrap_or(false);
            let now = m.now_s();
            match stroke_until {
                None if go => {
                    stroke_until = Some(now + STROKE_S);
                    let _ = m.set_input(5, false);
                    let _ = m.set_input(6, true);
                }
                Some(t) if now >= t && !go => {
                    stroke_until = None;
                    let _ = m.set_input(6, false);
                    let _ = m.set_input(5, true);
                }
                _ => {}
            }
        });
    }
}

/// Runs `cycles` cycles of the press program through [`SCRIPT`]'s faults.
///
/// # Panics
/// If the mock or the daemon cannot be set up.
pub async fn cycle_soak(cycles: u64) -> Summary {
    let robot = seed_robot();
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    for (j, c) in counts_at(A).into_iter().enumerate() {
        mock.set_count(usize::from(robot.joints[j].channel), c);
    }
    let _ = mock.set_input(5, true);
    let shared = SharedMock::new(mock);
    let driver = tokio::spawn(shared.clone().run_scans());
    let pressing = tokio::spawn(press(shared.clone()));
    let served = shared.clone();
    let connect: linterpd::daemon::Connector = Box::new(move || {
        let shared = served.clone();
        Box::pin(async move {
            let (ours, theirs) = tokio::io::duplex(4_096);
            let server = MewtocolServer::new(shared, MewtocolServerOptions::default());
            tokio::spawn(async move { server.serve(theirs).await });
            let options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
            Ok(AnyPlc::Mewtocol(MewtocolClient::new(
                Box::new(ours) as BoxedLink,
                options,
            )))
        })
    });
    let dir = std::env::temp_dir().join(format!("linterpd-cycle-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("press.toml"), program()).unwrap();
    let signals = [
        ("press_open", "X5"),
        ("press_moving", "X6"),
        ("press_go", "Y0"),
    ]
    .into_iter()
    .map(|(n, a)| (n.to_owned(), a.parse().unwrap()))
    .collect();
    let access =
        AccessList::new(vec![], vec!["Y0-Y7".parse().unwrap()], &Layout::default()).unwrap();
    let setup = RobotSetup {
        robot,
        settings: ContractSettings::default(),
        connect,
        home_counts: counts_at(A),
        gateway: GatewaySettings {
            access,
            modbus: None,
        },
        cell: CellSettings {
            signals,
            programs: Some(dir.clone()),
            require_wait_timeout: true,
            face: None,
        },
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let h = daemon.robot("press-loader").unwrap().clone();
    until_ready(&h).await;
    shared.with(|m| m.set_faults(SCRIPT.parse().unwrap()));
    let mut summary = Summary::default();
    h.run_cycle("press", Some(cycles)).await.unwrap();
    // At most a minute of virtual time a cycle, all told.
    let limit = tokio::time::Instant::now() + Duration::from_secs(60 * cycles + 60);
    while tokio::time::Instant::now() < limit {
        tokio::time::sleep(Duration::from_millis(20)).await;
        let Some(s) = h.cycle() else { continue };
        match s.state {
            CycleState::Done => {
                summary.finished = true;
                break;
            }
            CycleState::Faulted => {
                let why = s.reason.unwrap_or_else(|| "no reason".into());
                let key: String = why.chars().filter(|c| !c.is_ascii_digit()).collect();
                *summary.faults.entry(key).or_default() += 1;
                operator(&h, &shared, &mut summary).await;
            }
            CycleState::Paused => {
                let _ = h.resume_cycle().await;
            }
            CycleState::Stopped => break,
            CycleState::Running | CycleState::Waiting => {}
        }
    }
    summary.done = h.cycle().map_or(0, |s| s.done);
    tally(&shared, &mut summary);
    let _ = h.stop_cycle(true).await;
    daemon.shut_down().await;
    driver.abort();
    pressing.abort();
    let _ = std::fs::remove_dir_all(&dir);
    summary
}

/// Every start the mock acted on, against I1, repeated seqs and I6.
fn tally(shared: &SharedMock, summary: &mut Summary) {
    shared.with(|m| {
        let mut seqs = BTreeMap::new();
        for r in m
            .starts()
            .iter()
            .filter(|r| r.outcome == StartOutcome::Started)
        {
            summary.starts += 1;
            if r.from_mismatch() {
                summary.from_mismatches += 1;
            }
            if !r.block.permit.holds(&r.inputs) {
                summary.permit_violations += 1;
            }
            *seqs.entry(r.block.seq).or_insert(0usize) += 1;
        }
        // Seqs wrap at 65535; a soak of this length never wraps.
        summary.repeated_seqs = seqs.values().filter(|&&n| n > 1).count();
    });
}

/// The operator at a faulted cycle: leaves it alone for [`OPERATOR_S`] (nothing may start),
/// then clears the fault and resumes.
async fn operator(h: &RobotHandle, shared: &SharedMock, summary: &mut Summary) {
    let before = shared.with(|m| m.starts().len());
    tokio::time::sleep(Duration::from_secs(OPERATOR_S)).await;
    let after = shared.with(|m| m.starts().len());
    if h.cycle().is_some_and(|s| s.state != CycleState::Faulted) || after != before {
        summary.resumed_by_itself += 1;
    }
    until_ready(h).await;
    for _ in 0..50 {
        if h.clear_fault().await.is_ok() && h.resume_cycle().await.is_ok() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
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
}

/// The summary as text.
#[must_use]
pub fn report(s: &Summary) -> String {
    let mut out = format!(
        "{SCRIPT}: {} cycles done (finished: {}), starts acted on {}; I1 from wrong counts {}, \
         seqs acted on twice {}, I6 permits not holding {}, I8 resumed by itself {}",
        s.done,
        s.finished,
        s.starts,
        s.from_mismatches,
        s.repeated_seqs,
        s.permit_violations,
        s.resumed_by_itself
    );
    for (why, n) in &s.faults {
        let _ = write!(out, "\n  faulted {n} x {why}");
    }
    out
}

/// Whether every invariant held and the cycles finished.
#[must_use]
pub fn clean(s: &Summary) -> bool {
    s.finished
        && s.from_mismatches == 0
        && s.repeated_seqs == 0
        && s.permit_violations == 0
        && s.resumed_by_itself == 0
}

#[allow(dead_code)]
fn main() {
    let cycles: u64 = std::env::var("CYCLES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1_000);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .start_paused(true)
        .build()
        .unwrap();
    let began = std::time::Instant::now();
    let summary = rt.block_on(cycle_soak(cycles));
    println!("{}", report(&summary));
    println!("(took {:.1} s of wall time)", began.elapsed().as_secs_f64());
}
