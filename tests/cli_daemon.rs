//! The CLI against a running daemon: `linterpd serve` on `linterpd mock-plc`, both real
//! processes, and `linterpd move / status / stop` as an operator types them.

mod common;

use std::process::Command;

use serde_json::Value;

fn linterpd(socket: &std::path::Path, args: &[&str]) -> (Option<i32>, String, String) {
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

#[test]
fn operator_moves_checks_status_and_stops_through_the_cli() {
    let running = common::serve::start();
    let socket = running.socket.as_path();

    // The mock starts at counts 0: the tool at (0, 500, 0) mm, theta1 = 0.
    let (code, out, err) = linterpd(socket, &["move", "--to", "50,520,20"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.starts_with("move 1 done: upload ") && out.contains("final error ["),
        "{out}"
    );

    let (code, out, err) = linterpd(
        socket,
        &["move", "--to", "0,560,40", "--speed", "120", "--json"],
    );
    assert_eq!(code, Some(0), "{err}");
    let last: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(last["stage"], "done");
    assert!(
        last["final_error_pulses"]
            .as_array()
            .unwrap()
            .iter()
            .all(|p| p.as_i64().unwrap().abs() <= 1),
        "{last}"
    );

    let (code, out, err) = linterpd(socket, &["status", "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let robots: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(robots[0]["name"], "press-loader");
    assert_eq!(robots[0]["link"]["connected"], true);
    let (code, out, _) = linterpd(socket, &["status"]);
    assert_eq!(code, Some(0));
    assert!(
        out.starts_with("press-loader: connected, PLC run / done"),
        "{out}"
    );

    // A move the daemon refuses: exit 2, its reason, nothing printed as if it had worked.
    let (code, out, err) = linterpd(socket, &["move", "--to", "0,0,0"]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(
        out.is_empty() && err.contains("from the base axis"),
        "{err}"
    );
    let (code, _, err) = linterpd(socket, &["move", "--to", "0,560,40", "--robot", "welder"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("no robot \"welder\""), "{err}");

    // A long move started without waiting, then stopped.
    let (code, out, err) = linterpd(
        socket,
        &[
            "move",
            "--to",
            "0,900,300",
            "--speed",
            "20",
            "--no-wait",
            "--json",
        ],
    );
    assert_eq!(code, Some(0), "{err}");
    let accepted: Value = serde_json::from_str(out.trim()).unwrap();
    let id = accepted["id"].as_u64().unwrap();
    std::thread::sleep(std::time::Duration::from_millis(500));
    let (code, out, err) = linterpd(socket, &["stop"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out.trim(), "press-loader: stopped");
    // The state is as last read: the daemon sees the PLC stopped at its next poll.
    let mut robots = Value::Null;
    for _ in 0..50 {
        let (_, out, _) = linterpd(socket, &["status", "--json"]);
        robots = serde_json::from_str(out.trim()).unwrap();
        if robots[0]["state"] == "stopped" {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert_eq!(robots[0]["state"], "stopped", "{robots}");
    assert_eq!(
        robots[0]["current_move"],
        Value::Null,
        "move {id} still current: {robots}"
    );
}
