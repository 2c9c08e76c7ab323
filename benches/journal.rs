//! The cell's journal (issue 48, item 5): how fast entries are appended, what the disk holds
//! against its caps, and a cycle's time on the mock with the journal off against on and
//! flooded (10 000 entries a second from a task of the daemon's runtime, the follower running).
//!
//! Run: `cargo bench --bench journal`

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use linterpd::config::{CellSettings, JournalSettings};
use linterpd::daemon::{CycleState, Daemon, DaemonOptions, RobotSetup};
use linterpd::journal::{Journal, Query};
use linterpd::kinematics::JOINTS;
use linterpd::mewtocol::Station;
use linterpd::mock::{MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, SharedMock};
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use linterpd::robot::seed_robot;
use linterpd::wire::journal::{Kind, Source};

const P1: [f64; 3] = [-926.57, 535.03, 50.0];
const CYCLES: u64 = 8;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "linterpd-bench-journal-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn command(n: u64) -> Kind {
    Kind::Command {
        source: Source::Api,
        who: Some(format!("uid {}", 1000 + n % 7)),
        action: "POST moves {\"to\":[-926.57,535.03,50.0],\"speed_mm_s\":240}".into(),
        status: Some(202),
        refused: None,
    }
}

fn fault(n: u64) -> Kind {
    Kind::Fault {
        code: Some(3),
        reason: format!("stopped from outside (e-stop input) #{n}"),
    }
}

fn dir_bytes(dir: &Path) -> (usize, u64) {
    let files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .collect();
    let bytes = files.iter().map(|f| f.metadata().unwrap().len()).sum();
    (files.len(), bytes)
}

/// `n` entries recorded back to back, then flushed: entries a second, and the drops.
async fn append_rate(name: &str, n: u64, kind: fn(u64) -> Kind, settings: JournalSettings) {
    let dir = temp(name);
    let journal = Journal::open(&dir, &settings).unwrap();
    let began = Instant::now();
    for i in 0..n {
        journal.record(Some("press-loader"), kind(i));
    }
    journal.flush().await;
    let s = began.elapsed().as_secs_f64();
    let c = journal.counts();
    let (files, bytes) = dir_bytes(&dir);
    println!(
        "append {name}: {n} entries in {:.3} s = {:.0} entries/s written ({} written, {} dropped, \
         {} fsyncs); on disk {files} files, {bytes} bytes (cap {} x {} = {} bytes)",
        s,
        c.written as f64 / s,
        c.written,
        c.dropped,
        c.syncs,
        settings.files,
        settings.file_bytes,
        u64::from(settings.files) * settings.file_bytes
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `rate` entries a second for `for_s`, as a task would record them: what is dropped.
async fn paced(rate: u64, for_s: u64) {
    let dir = temp("paced");
    let journal = Journal::open(&dir, &JournalSettings::default()).unwrap();
    let mut tick = tokio::time::interval(Duration::from_millis(1));
    let per_ms = rate / 1000;
    for i in 0..for_s * 1000 {
        tick.tick().await;
        for j in 0..per_ms {
            journal.record(Some("press-loader"), command(i * per_ms + j));
        }
    }
    journal.flush().await;
    let c = journal.counts();
    let read = journal
        .read(&Query {
            limit: usize::MAX,
            ..Query::default()
        })
        .unwrap()
        .len();
    println!(
        "paced {rate} entries/s for {for_s} s (queue 4096): {} written, {} dropped, {} fsyncs; \
         {read} read back",
        c.written, c.dropped, c.syncs
    );
    let _ = std::fs::remove_dir_all(&dir);
}

fn connector(shared: &SharedMock) -> linterpd::daemon::Connector {
    let served = shared.clone();
    Box::new(move || {
        let shared = served.clone();
        Box::pin(async move {
            let (ours, theirs) = tokio::io::duplex(4_096);
            let options = MewtocolServerOptions {
                baud: Some(115_200),
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

/// The mock with the seed robot at P1, its scans running.
fn mock_at_p1() -> SharedMock {
    let robot = seed_robot();
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    let start = robot.pose_with_wrist_at_zero(P1[0], P1[1], P1[2]).unwrap();
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &start, None).unwrap();
    for (j, c) in robot.counts_of(&q).into_iter().enumerate() {
        mock.set_count(usize::from(robot.joints[j].channel), c);
    }
    let shared = SharedMock::new(mock);
    tokio::spawn(shared.clone().run_scans());
    shared
}

/// A cycle of two 60 mm moves run [`CYCLES`] times: each cycle's time, s. With `flood`, the
/// journal is on, followed, and a task records `flood` entries a second meanwhile.
async fn cycle_times(flood: Option<u64>) -> Vec<f64> {
    let shared = mock_at_p1();
    let dir = temp(if flood.is_some() {
        "cycle-on"
    } else {
        "cycle-off"
    });
    let up = [P1[0], P1[1], P1[2] + 60.0];
    let program =
        format!("[[step]]\nmove = {{ to = {up:?} }}\n[[step]]\nmove = {{ to = {P1:?} }}\n");
    std::fs::write(dir.join("updown.toml"), program).unwrap();
    let journal = match flood {
        Some(_) => Journal::open(&dir.join("journal"), &JournalSettings::default()).unwrap(),
        None => Journal::off(),
    };
    let options = DaemonOptions {
        journal: journal.clone(),
        ..DaemonOptions::default()
    };
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect: connector(&shared),
        home_counts: [0; JOINTS],
        gateway: linterpd::gateway::GatewaySettings::default(),
        cell: CellSettings {
            programs: Some(dir.clone()),
            ..CellSettings::default()
        },
    };
    let daemon = Daemon::spawn(vec![setup], &options);
    let h = daemon.robot("press-loader").unwrap().clone();
    let closing = tokio_util::sync::CancellationToken::new();
    linterpd::daemon::journal::follow(daemon.robots(), &journal, &closing);
    while h.state().refuses.is_some() || !h.state().link.connected {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let flooding = flood.map(|rate| tokio::spawn(flood_task(journal.clone(), rate)));
    h.run_cycle("updown", Some(CYCLES)).await.unwrap();
    let mut times = Vec::new();
    let mut seen = 0;
    loop {
        let s = h.cycle().unwrap();
        if s.done > seen {
            seen = s.done;
            times.push(s.last_cycle_s.unwrap());
        }
        if s.state == CycleState::Done {
            break;
        }
        assert!(
            !s.state.is_final() && s.state != CycleState::Faulted,
            "{s:?}"
        );
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    if let Some(task) = flooding {
        task.abort();
        journal.flush().await;
        let c = journal.counts();
        println!(
            "  flooded: {} entries written, {} dropped during the cycles",
            c.written, c.dropped
        );
    }
    closing.cancel();
    daemon.shut_down().await;
    let _ = std::fs::remove_dir_all(&dir);
    times
}

async fn flood_task(journal: Journal, rate: u64) {
    let mut tick = tokio::time::interval(Duration::from_millis(1));
    let mut n = 0;
    loop {
        tick.tick().await;
        for _ in 0..rate / 1000 {
            journal.record(Some("press-loader"), command(n));
            n += 1;
        }
    }
}

fn summary(times: &mut [f64]) -> String {
    times.sort_by(f64::total_cmp);
    format!(
        "median {:.3} s, min {:.3} s, max {:.3} s ({} cycles)",
        times[times.len() / 2],
        times[0],
        times[times.len() - 1],
        times.len()
    )
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() {
    let big_queue = JournalSettings {
        queue: 200_000,
        ..JournalSettings::default()
    };
    append_rate("commands (fsync batched)", 200_000, command, big_queue).await;
    append_rate("faults (each batch fsync'd)", 20_000, fault, big_queue).await;
    let small = JournalSettings {
        file_bytes: 1 << 20,
        files: 4,
        queue: 200_000,
    };
    append_rate("commands, caps 4 x 1 MiB", 200_000, command, small).await;
    paced(10_000, 2).await;
    let mut off = cycle_times(None).await;
    println!("cycle, journal off: {}", summary(&mut off));
    let mut on = cycle_times(Some(10_000)).await;
    println!(
        "cycle, journal on, 10000 entries/s flooding it: {}",
        summary(&mut on)
    );
}
