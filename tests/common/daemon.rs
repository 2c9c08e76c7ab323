//! The daemon in process on a mock PLC: a connector that opens a fresh MEWTOCOL `duplex`
//! connection to the mock for every (re)connection, and spawning a daemon for the seed's robot.

use linterpd::daemon::{Connector, Daemon, DaemonOptions, RobotHandle, RobotSetup};
use linterpd::kinematics::JOINTS;
use linterpd::mewtocol::Station;
use linterpd::mock::{MewtocolServer, MewtocolServerOptions, SharedMock};
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use linterpd::robot::seed_robot;

/// MEWTOCOL options of the test links: station 1, `%` frames.
pub fn mewtocol_options() -> MewtocolOptions {
    MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent)
}

/// Opens a fresh `duplex` connection to the mock for every (re)connection, served at `baud`.
pub fn duplex_connector(shared: &SharedMock, baud: Option<u32>) -> Connector {
    duplex_connector_with(shared, baud, mewtocol_options())
}

/// [`duplex_connector`] with the client's `options`.
pub fn duplex_connector_with(
    shared: &SharedMock,
    baud: Option<u32>,
    options: MewtocolOptions,
) -> Connector {
    let shared = shared.clone();
    Box::new(move || {
        let shared = shared.clone();
        Box::pin(async move {
            let (ours, theirs) = tokio::io::duplex(4_096);
            let server = MewtocolServer::new(
                shared,
                MewtocolServerOptions {
                    baud,
                    ..MewtocolServerOptions::default()
                },
            );
            tokio::spawn(async move { server.serve(theirs).await });
            Ok(AnyPlc::Mewtocol(MewtocolClient::new(
                Box::new(ours) as BoxedLink,
                options,
            )))
        })
    })
}

/// A daemon for the seed's robot on `connect`, homed at counts 0.
pub fn spawn(connect: Connector, settings: ContractSettings) -> (Daemon, RobotHandle) {
    spawn_with(connect, settings, &DaemonOptions::default(), [0; JOINTS])
}

/// As [`spawn`], with daemon options and the counts each joint is homed to.
pub fn spawn_with(
    connect: Connector,
    settings: ContractSettings,
    options: &DaemonOptions,
    home_counts: [i64; JOINTS],
) -> (Daemon, RobotHandle) {
    spawn_robot(connect, settings, options, home_counts, seed_robot())
}

/// As [`spawn_with`], for `robot` (the seed's, named `press-loader`, with changes).
pub fn spawn_robot(
    connect: Connector,
    settings: ContractSettings,
    options: &DaemonOptions,
    home_counts: [i64; JOINTS],
    robot: linterpd::robot::Robot,
) -> (Daemon, RobotHandle) {
    let setup = RobotSetup {
        robot,
        settings,
        connect,
        home_counts,
        gateway: linterpd::gateway::GatewaySettings::default(),
        cell: linterpd::config::CellSettings::default(),
    };
    let d = Daemon::spawn(vec![setup], options);
    let h = d.robot("press-loader").unwrap().clone();
    (d, h)
}

/// Signal names for a cell, from (name, bit) pairs.
#[allow(dead_code)] // not every test binary has a cell
pub fn signals(
    pairs: &[(&str, &str)],
) -> std::collections::BTreeMap<String, linterpd::gateway::Address> {
    pairs
        .iter()
        .map(|(n, a)| ((*n).to_owned(), a.parse().unwrap()))
        .collect()
}

/// A daemon for the seed's robot on `connect` in a cell: its signals and programs, and its
/// gateway.
#[allow(dead_code)] // not every test binary has a cell
pub fn spawn_in_cell(
    connect: Connector,
    cell: linterpd::config::CellSettings,
    gateway: linterpd::gateway::GatewaySettings,
) -> (Daemon, RobotHandle) {
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect,
        home_counts: [0; JOINTS],
        gateway,
        cell,
    };
    let d = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let h = d.robot("press-loader").unwrap().clone();
    (d, h)
}

/// Waits until the daemon takes moves: connected, nothing refusing them, the counts read.
#[allow(dead_code)] // not every test binary waits so
pub async fn taking_moves(h: &RobotHandle) {
    for _ in 0..500 {
        let s = h.state();
        if s.link.connected && s.refuses.is_none() && s.counts.is_some() {
            return;
        }
        tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    }
    panic!("never connected: {:?}", h.state());
}

/// A directory of cycle programs of its own for one test: `files` are (name, text) pairs,
/// written as `name.toml`.
#[allow(dead_code)] // not every test binary has a cell
pub fn programs_dir(prefix: &str, test: &str, files: &[(&str, String)]) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("linterpd-{prefix}-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text) in files {
        std::fs::write(dir.join(format!("{name}.toml")), text).unwrap();
    }
    dir
}

/// How long a move's report may take to come to what a test waits for.
const REPORT_LIMIT: std::time::Duration = std::time::Duration::from_secs(60);

/// Waits until the report on `feed` satisfies `until`, and returns it. Fails the test, naming
/// `what` and the last report, when the move ends first (a report that ended never changes
/// again) or after [`REPORT_LIMIT`]: a test never hangs on a move that went another way.
#[allow(dead_code)] // not every test binary follows a move
pub async fn report_until(
    feed: &mut tokio::sync::watch::Receiver<linterpd::wire::MoveReport>,
    what: &str,
    mut until: impl FnMut(&linterpd::wire::MoveReport) -> bool,
) -> linterpd::wire::MoveReport {
    let seen = tokio::time::timeout(REPORT_LIMIT, async {
        feed.wait_for(|r| until(r) || r.stage.is_final())
            .await
            .map(|r| r.clone())
    })
    .await;
    match seen {
        Ok(Ok(r)) if until(&r) => r,
        Ok(Ok(r)) => panic!("the move ended before {what}: {r:?}"),
        Ok(Err(_)) => panic!("the move's feed closed before {what}: {:?}", feed.borrow()),
        Err(elapsed) => panic!(
            "not {what} within {REPORT_LIMIT:?} ({elapsed}): {:?}",
            feed.borrow()
        ),
    }
}
