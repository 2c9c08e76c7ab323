//! `linterpd io read / write` as an integrator types them, against a daemon in process on the mock
//! PLC (its API on a Unix socket in a temp dir): what the access list lets through lands in the
//! mock's memory and prints a line per address; what it does not is refused with exit 2 naming
//! the address and the list, never reaching the PLC; a link that is down exits 4, a PLC that
//! refuses exits 1.

use crate::common;

use std::path::Path;
use std::time::Duration;

use common::daemon::duplex_connector;
use common::exchange::mock_at_seed_start;
use common::process::TempDir;
use linterpd::contract::Layout;
use linterpd::daemon::api::Api;
use linterpd::daemon::{Connector, Daemon, DaemonOptions, RobotHandle, RobotSetup};
use linterpd::gateway::{AccessList, Area, GatewaySettings, Range};
use linterpd::kinematics::JOINTS;
use linterpd::mock::SharedMock;
use linterpd::plc::exchange::ContractSettings;
use linterpd::robot::seed_robot;
use serde_json::Value;
use tokio::net::UnixListener;

fn ranges(texts: &[&str]) -> Vec<Range> {
    texts.iter().map(|t| t.parse().unwrap()).collect()
}

/// Reads DT0-DT999, X0-X1F and R2560-R256F (past the mock's R255F); writes DT100-DT199, R10-R1F.
fn gateway() -> GatewaySettings {
    GatewaySettings {
        access: AccessList::new(
            ranges(&["DT0-DT999", "X0-X1F", "R2560-R256F"]),
            ranges(&["DT100-DT199", "R10-R1F"]),
            &Layout::default(),
        )
        .unwrap(),
        modbus: None,
    }
}

/// The daemon on `connect`, its API on `socket`.
fn serve(connect: Connector, socket: &Path) -> (Daemon, RobotHandle) {
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect,
        home_counts: [0; JOINTS],
        gateway: gateway(),
        cell: linterpd::config::CellSettings::default(),
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let handle = daemon.robot("press-loader").unwrap().clone();
    let listener = UnixListener::bind(socket).unwrap();
    let router = Api::new(daemon.robots().clone()).router(None);
    tokio::spawn(async move { axum::serve(listener, router).await });
    (daemon, handle)
}

async fn wait_connected(h: &RobotHandle) {
    for _ in 0..500 {
        let s = h.state();
        if s.link.connected && s.counts.is_some() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("never connected: {:?}", h.state());
}

/// Runs `linterpd ARGS --socket SOCKET`: exit code, stdout, stderr.
async fn linterpd(socket: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = tokio::process::Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(args)
        .arg("--socket")
        .arg(socket)
        .output()
        .await
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn words(shared: &SharedMock, start: u32, count: usize) -> Vec<u16> {
    shared.with(|m| m.read_words(start, count).unwrap())
}

#[tokio::test]
async fn registers_are_read_and_written_a_line_per_address() {
    let shared = mock_at_seed_start("");
    shared.with(|m| {
        m.write_words(100, &[1234, 7, 65535]).unwrap();
        m.set_input(0x13, true).unwrap();
    });
    let dir = TempDir::new("io-cli");
    let socket = dir.path().join("api.sock");
    let (d, h) = serve(duplex_connector(&shared, None), &socket);
    wait_connected(&h).await;

    let (code, out, err) = linterpd(&socket, &["io", "read", "DT100", "--count", "3"]).await;
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out, "DT100 = 1234\nDT101 = 7\nDT102 = 65535\n");

    let (code, out, err) = linterpd(&socket, &["io", "read", "X12", "--count", "2"]).await;
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out, "X12 = 0\nX13 = 1\n");

    let (code, out, err) = linterpd(&socket, &["io", "write", "DT150", "-1", "0x10", "42"]).await;
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out, "DT150 = 65535\nDT151 = 16\nDT152 = 42\n");
    assert_eq!(words(&shared, 149, 5), [0, 65535, 16, 42, 0]);

    let (code, out, err) = linterpd(&socket, &["io", "write", "R0010", "1", "--json"]).await;
    assert_eq!(code, Some(0), "{err}");
    let answer: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(answer["address"], "R10");
    assert_eq!(answer["values"], serde_json::json!([true]));
    shared.with(|m| {
        assert!(m.read_bit(Area::R, 0x10).unwrap());
        assert!(!m.read_bit(Area::R, 0x11).unwrap());
    });
    let (code, out, _) = linterpd(&socket, &["io", "read", "R0010", "--count", "2"]).await;
    assert_eq!((code, out.as_str()), (Some(0), "R10 = 1\nR11 = 0\n"));
    d.shut_down().await;
}

#[tokio::test]
async fn what_is_refused_says_why_and_never_reaches_the_plc() {
    let shared = mock_at_seed_start("");
    let dir = TempDir::new("io-cli-refused");
    let socket = dir.path().join("api.sock");
    let (d, h) = serve(duplex_connector(&shared, None), &socket);
    wait_connected(&h).await;
    let command_block = words(&shared, 1_032, 17);

    for (args, says) in [
        // The contract's command block: never writable through the gateway.
        (
            &["io", "write", "DT1032", "1"][..],
            "DT1032 is not in this robot's gateway write list (DT100-DT199, R10-R1F) (reason: not-allowed)",
        ),
        (
            &["io", "read", "DT1000"],
            "DT1000 is not in this robot's gateway read list",
        ),
        (
            &["io", "write", "X0", "1"],
            "X0 is in X, the inputs: they cannot be written",
        ),
        (
            &["io", "read", "DT0", "--count", "1001"],
            "count = 1001: must be within 1..=1000 for DT",
        ),
        (
            &["io", "write", "DT100", "70000"],
            "values[0] = 70000: a DT word is a whole number within -32768..=65535",
        ),
        (
            &["io", "write", "R10", "2"],
            "value \"2\": R holds bits: give 1/0, true/false or on/off",
        ),
        (
            &["io", "read", "Q7"],
            "address \"Q7\" is not an address: DT100, X1F, Y7 or R0010",
        ),
        (&["io", "read", "DT0", "--robot", "welder"], "welder"),
    ] {
        let (code, out, err) = linterpd(&socket, args).await;
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(out.is_empty(), "{args:?}: {out}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
    assert_eq!(words(&shared, 1_032, 17), command_block);
    assert_eq!(h.state().gateway.exchanges, 0, "nothing refused was sent");

    // R256F is listed but past the mock's R255F: the PLC refuses it (exit 1).
    let (code, out, err) = linterpd(&socket, &["io", "read", "R2560"]).await;
    assert_eq!(code, Some(1), "{out}{err}");
    assert!(err.contains("(reason: plc)"), "{err}");
    d.shut_down().await;
}

#[tokio::test]
async fn a_link_that_is_down_exits_4() {
    let connect: Connector = Box::new(|| {
        Box::pin(async {
            Err(linterpd::plc::PlcError::Link {
                operation: "connect".into(),
                source: std::io::Error::new(std::io::ErrorKind::ConnectionRefused, "refused"),
            })
        })
    });
    let dir = TempDir::new("io-cli-down");
    let socket = dir.path().join("api.sock");
    let (d, _h) = serve(connect, &socket);
    let (code, out, err) = linterpd(&socket, &["io", "read", "DT0"]).await;
    assert_eq!(code, Some(4), "{out}{err}");
    assert!(
        err.contains("the PLC link is down") && err.contains("(reason: link-down)"),
        "{err}"
    );
    d.shut_down().await;
}
