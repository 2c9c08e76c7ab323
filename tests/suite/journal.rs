//! The cell's journal (issue 48, item 5) with the daemon: the follower journals a cycle's start
//! and end and a PLC fault with its reason on the in-process mock; a command through the API is
//! journaled with who sent it and read back through `GET /v1/journal`; and, with real
//! processes, `linterpd log` reads what `linterpd stop` and a reload did, and a restarted daemon
//! numbers on where the last one stopped.

use crate::common;

use std::os::unix::fs::MetadataExt as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::daemon::{duplex_connector, taking_moves};
use common::exchange::{P2, mock_at_seed_start};
use common::http::Endpoint;
use linterpd::config::{CellSettings, JournalSettings};
use linterpd::daemon::api::Api;
use linterpd::daemon::{CycleState, Daemon, DaemonOptions, RobotSetup};
use linterpd::journal::{Journal, Query};
use linterpd::kinematics::JOINTS;
use linterpd::plc::exchange::ContractSettings;
use linterpd::robot::seed_robot;
use linterpd::wire::journal::{CycleOutcome, Entry, Kind, Source};
use serde_json::Value;
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(20);

fn temp(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linterpd-journal-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Everything journaled, once `done` holds for it (the follower sees a change at the next
/// status read).
async fn journaled(journal: &Journal, done: impl Fn(&[Entry]) -> bool) -> Vec<Entry> {
    let began = Instant::now();
    loop {
        journal.flush().await;
        let entries = journal
            .read(&Query {
                limit: usize::MAX,
                ..Query::default()
            })
            .unwrap();
        if done(&entries) {
            return entries;
        }
        assert!(began.elapsed() < LIMIT, "never journaled: {entries:#?}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test]
async fn the_follower_journals_a_cycle_and_a_fault_and_the_api_a_command_with_who() {
    let shared = mock_at_seed_start("");
    let dir = temp("follower");
    let program = format!(
        "[[step]]\nmove = {{ to = [{}, {}, {}] }}\n",
        P2[0], P2[1], P2[2]
    );
    let programs = common::daemon::programs_dir("journal", "follower", &[("p", program)]);
    let journal = Journal::open(&dir.join("journal"), &JournalSettings::default()).unwrap();
    let options = DaemonOptions {
        journal: journal.clone(),
        ..DaemonOptions::default()
    };
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect: duplex_connector(&shared, None),
        home_counts: [0; JOINTS],
        gateway: linterpd::gateway::GatewaySettings::default(),
        cell: CellSettings {
            programs: Some(programs),
            ..CellSettings::default()
        },
    };
    let daemon = Daemon::spawn(vec![setup], &options);
    let h = daemon.robot("press-loader").unwrap().clone();
    let closing = CancellationToken::new();
    linterpd::daemon::journal::follow(daemon.robots(), &journal, &closing);
    let socket = dir.join("api.sock");
    let router = Api::new(daemon.robots().clone())
        .with_journal(journal.clone())
        .router(None);
    let listener = tokio::net::UnixListener::bind(&socket).unwrap();
    tokio::spawn(linterpd::daemon::api::serve(
        listener,
        router,
        closing.clone().cancelled_owned(),
    ));
    taking_moves(&h).await;

    h.run_cycle("p", Some(1)).await.unwrap();
    let began = Instant::now();
    while h.cycle().is_none_or(|c| c.state != CycleState::Done) {
        assert!(
            began.elapsed() < LIMIT,
            "the cycle never ended: {:?}",
            h.cycle()
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    // The e-stop input opens: the PLC latches fault 3.
    shared.with(|m| m.set_estop_open(true));
    let api = Endpoint::unix(&socket);
    let answer = api.post("/v1/robots/press-loader/stop", "").await;
    let entries = journaled(&journal, |e| {
        e.iter().any(|e| e.kind.name() == "fault") && e.iter().any(|e| e.kind.name() == "command")
    })
    .await;
    let of =
        |name: &str| -> Vec<&Entry> { entries.iter().filter(|e| e.kind.name() == name).collect() };

    assert_eq!(
        of("cycle-started")[0].kind,
        Kind::CycleStarted {
            program: "p".into(),
            cycle: 1
        }
    );
    let Kind::CycleEnded {
        program,
        cycle,
        outcome,
        cycle_s,
    } = &of("cycle-ended")[0].kind
    else {
        unreachable!()
    };
    assert_eq!(
        (program.as_str(), *cycle, *outcome),
        ("p", 1, CycleOutcome::Done)
    );
    assert!(cycle_s.is_some_and(|s| s > 0.5), "{cycle_s:?}");
    assert_eq!(
        of("fault")[0].kind,
        Kind::Fault {
            code: Some(3),
            reason: "stopped from outside (e-stop input)".into()
        }
    );
    assert!(of("fault")[0].robot.as_deref() == Some("press-loader"));
    let uid = std::fs::metadata(&socket).unwrap().uid();
    assert_eq!(
        of("command")[0].kind,
        Kind::Command {
            source: Source::Api,
            who: Some(format!("uid {uid}")),
            action: "POST stop".into(),
            status: Some(answer.status.as_u16()),
            refused: None,
        }
    );
    // In order, numbered from 1 without a gap.
    assert!(
        entries
            .windows(2)
            .all(|w| w[1].seq == w[0].seq + 1 && w[1].at_ms >= w[0].at_ms)
    );
    assert_eq!(entries[0].seq, 1);

    // Read back through the API: the command, by number.
    let after = of("command")[0].seq - 1;
    let page = api.get(&format!("/v1/journal?after={after}&limit=1")).await;
    assert_eq!(page.status, 200, "{}", page.text());
    let page = page.json();
    assert_eq!(page["entries"][0]["kind"], "command");
    assert_eq!(page["entries"][0]["who"], format!("uid {uid}"));
    assert_eq!(page["last_seq"], after + 1);
    let bad = api.get("/v1/journal?since=yesterday").await;
    assert_eq!(bad.status, 400);
    assert!(
        bad.text().contains("\\\"yesterday\\\" is not"),
        "{}",
        bad.text()
    );
    closing.cancel();
    daemon.shut_down().await;
    let _ = std::fs::remove_dir_all(&dir);
}

fn linterpd(socket: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(args)
        .arg("--socket")
        .arg(socket)
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `linterpd log --json --since 1h` until `done` holds for its lines.
fn log_until(socket: &Path, done: impl Fn(&[Value]) -> bool) -> Vec<Value> {
    let began = Instant::now();
    loop {
        let (code, out, err) = linterpd(socket, &["log", "--json", "--since", "1h"]);
        assert_eq!(code, Some(0), "{out}{err}");
        let lines: Vec<Value> = out
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        if done(&lines) {
            return lines;
        }
        assert!(began.elapsed() < LIMIT, "never logged: {out}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn kinds(lines: &[Value]) -> Vec<String> {
    lines
        .iter()
        .map(|l| l["kind"].as_str().unwrap().to_owned())
        .collect()
}

#[test]
fn linterpd_log_reads_what_the_cli_and_a_reload_did_and_a_restart_numbers_on() {
    let mut running = common::serve::start();
    let socket = running.socket.clone();
    let (code, out, err) = linterpd(&socket, &["stop"]);
    assert_eq!(code, Some(0), "{out}{err}");
    running.serve.hangup();
    running
        .serve
        .wait_for_stderr("SIGHUP", common::serve::READY);
    let lines = log_until(&socket, |l| {
        kinds(l).contains(&"config-reloaded".to_owned())
    });
    assert_eq!(kinds(&lines)[0], "daemon-started");
    assert_eq!(lines[0]["seq"], 1);
    let uid = std::fs::metadata(&socket).unwrap().uid();
    let stop = lines.iter().find(|l| l["kind"] == "command").unwrap();
    assert_eq!(stop["source"], "cli", "{stop}");
    assert_eq!(stop["who"], format!("uid {uid}"));
    assert_eq!(stop["action"], "POST stop");
    assert_eq!(stop["robot"], "press-loader");
    // The same as a person reads it.
    let (_, text, _) = linterpd(&socket, &["log", "--since", "1h"]);
    assert!(
        text.lines().any(|l| l.contains(&format!(
            "press-loader command: POST stop from cli (uid {uid}) -> 200"
        ))),
        "{text}"
    );
    // Nothing after a time to come; a time that is not one is refused before asking.
    let (code, out, _) = linterpd(&socket, &["log", "--since", "2100-01-01T00:00:00Z"]);
    assert_eq!((code, out.as_str()), (Some(0), ""));
    let (code, _, err) = linterpd(&socket, &["log", "--since", "yesterday"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("\"yesterday\" is not"), "{err}");

    // Stopped and started again: the entries are there and the numbers go on.
    let last = lines.last().unwrap()["seq"].as_u64().unwrap();
    assert!(running.serve.terminate(common::serve::READY).success());
    let mut again = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    again.arg("serve").arg("--config").arg(&running.config);
    running.serve = common::process::Spawned::spawn("linterpd serve (again)", again);
    running
        .serve
        .wait_for_stderr("API listening", common::serve::READY);
    let lines = log_until(&socket, |l| {
        kinds(l).iter().filter(|k| *k == "daemon-started").count() == 2
    });
    let seqs: Vec<u64> = lines.iter().map(|l| l["seq"].as_u64().unwrap()).collect();
    assert!(seqs.windows(2).all(|w| w[1] == w[0] + 1), "{seqs:?}");
    let stopping = lines
        .iter()
        .position(|l| l["kind"] == "daemon-stopping")
        .unwrap();
    assert!(lines[stopping]["seq"].as_u64().unwrap() > last);
    assert_eq!(lines[stopping + 1]["kind"], "daemon-started");
    // --counts over the same entries: no cycle ran, one shift.
    let (code, out, err) = linterpd(&socket, &["log", "--counts", "--json", "--since", "1h"]);
    assert_eq!(code, Some(0), "{err}");
    let shifts: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert!(
        !shifts.is_empty() && shifts.iter().all(|s| s["cycles"] == 0),
        "{out}"
    );
}
