//! `linterpd status`: each robot's phase, link, PLC state, pose and moves, from the daemon, in
//! words (never `null`); exits like `systemctl status`: 0 when every robot's link is up and no
//! fault is latched, 3 when a robot's PLC link is down or stalled, else 1 when a robot reports a
//! fault (with `--json` too).
//!
//! ```text
//! press-loader: idle; link up; PLC in RUN, program idle, homed, heartbeat 12 ms ago;
//!   pose (0.000, 500.000, 0.000 mm, 0.000 deg); no move running, nothing queued
//! ```
//! (one line per robot; wrapped here).

use std::fmt::Write as _;

use clap::Args;
use hyper::Method;
use serde_json::Value;

use super::client::Client;
use super::{DaemonArgs, EXIT_FAILURE, EXIT_NOT_DONE, EXIT_OK, Failure};

/// Arguments of `linterpd status`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// One robot only.
    #[arg(long)]
    pub robot: Option<String>,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// The link: up, or its last error; and how often it was opened, when more than once.
fn link(r: &Value) -> String {
    let opened = match r["link"]["reconnects"].as_u64().unwrap_or(0) {
        0 | 1 => String::new(),
        n => format!(" (opened {n} times)"),
    };
    if connected(r) {
        format!("link up{opened}")
    } else {
        match r["link"]["error"].as_str() {
            Some(why) => format!("link error: {why}{opened}"),
            None => format!("not connected yet{opened}"),
        }
    }
}

fn connected(r: &Value) -> bool {
    r["link"]["connected"].as_bool() == Some(true)
}

/// The PLC as last read: mode, program state, homed, fault, heartbeat (its age only while the
/// link is up: the daemon keeps the last values while it is down).
fn plc(r: &Value) -> String {
    let Some(mode) = r["plc_mode"].as_str() else {
        return "PLC not read yet".to_owned();
    };
    let mut text = format!(
        "PLC {}in {}, program {}, {}",
        if connected(r) { "" } else { "as last read: " },
        mode.to_uppercase(),
        r["state"].as_str().unwrap_or("state unknown"),
        if r["homed"].as_bool() == Some(true) {
            "homed"
        } else {
            "not homed"
        }
    );
    if let Some(fault) = r["fault"].as_u64() {
        let _ = write!(text, ", fault {fault}");
    }
    match r["heartbeat_age_ms"].as_u64() {
        Some(ms) if connected(r) => {
            let _ = write!(text, ", heartbeat {ms} ms ago");
        }
        None if connected(r) => text.push_str(", no heartbeat seen"),
        _ => {}
    }
    text
}

/// The pose, or that it is unknown.
fn pose(r: &Value) -> String {
    let Some(p) = r["pose"].as_array().filter(|p| p.len() == 4) else {
        return "pose unknown".to_owned();
    };
    // (+ 0.0: no "-0.000")
    let v: Vec<f64> = p
        .iter()
        .map(|x| x.as_f64().unwrap_or(f64::NAN) + 0.0)
        .collect();
    format!(
        "pose ({:.3}, {:.3}, {:.3} mm, {:.3} deg)",
        v[0], v[1], v[2], v[3]
    )
}

/// The move running and the moves queued.
fn moves(r: &Value) -> String {
    let running = r["current_move"]
        .as_u64()
        .map_or("no move running".to_owned(), |id| {
            format!("move {id} running")
        });
    let queued: Vec<String> = r["queued"]
        .as_array()
        .map(|q| q.iter().map(Value::to_string).collect())
        .unwrap_or_default();
    if queued.is_empty() {
        format!("{running}, nothing queued")
    } else {
        format!("{running}, queued {}", queued.join(", "))
    }
}

/// One robot in one line.
fn line(r: &Value) -> String {
    let phase = r["phase"].as_str().unwrap_or("unknown").replace('-', " ");
    let mut text = format!(
        "{}: {phase}; {}; {}; {}; {}",
        r["name"].as_str().unwrap_or("?"),
        link(r),
        plc(r),
        pose(r),
        moves(r)
    );
    if let Some(why) = r["refuses"].as_str() {
        let _ = write!(text, "; new moves refused: {why}");
    }
    text
}

/// The exit code for these robots: 3 if a PLC link is down or stalled, else 1 if a robot reports
/// a fault, else 0.
fn exit_code(robots: &[Value]) -> u8 {
    let down = robots
        .iter()
        .any(|r| !connected(r) || matches!(r["phase"].as_str(), Some("link-down" | "stalled")));
    let faulted = robots
        .iter()
        .any(|r| r["fault"].as_u64().is_some() || r["state"].as_str() == Some("fault"));
    if down {
        EXIT_NOT_DONE
    } else if faulted {
        EXIT_FAILURE
    } else {
        EXIT_OK
    }
}

/// Runs `linterpd status`.
pub fn run(args: &StatusArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    args.daemon.block_on(async {
        let client = Client::new(&args.daemon.socket);
        let path = args
            .robot
            .as_ref()
            .map_or("/v1/robots".to_owned(), |r| format!("/v1/robots/{r}"));
        let answer = client.expect(Method::GET, &path, None).await?;
        let robots = match &answer {
            Value::Array(list) => list.clone(),
            one => vec![one.clone()],
        };
        let text: Vec<String> = robots.iter().map(line).collect();
        super::print(out, args.daemon.json, &answer, &text.join("\n"))?;
        match exit_code(&robots) {
            EXIT_OK => Ok(()),
            code => Err(Failure::Quiet(code)),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn idle() -> Value {
        json!({"name": "press-loader", "link": {"connected": true, "error": null,
            "reconnects": 1}, "phase": "idle", "homed": true, "refuses": null,
            "plc_mode": "run", "heartbeat_age_ms": 12, "state": "idle", "fault": null,
            "counts": [0, 0, 0, 0], "pose": [-0.0, 500.0, 0.0, 0.0], "current_move": null,
            "queued": []})
    }

    #[test]
    fn an_idle_robot_is_said_in_words() {
        assert_eq!(
            line(&idle()),
            "press-loader: idle; link up; PLC in RUN, program idle, homed, heartbeat 12 ms ago; \
             pose (0.000, 500.000, 0.000 mm, 0.000 deg); no move running, nothing queued"
        );
        assert_eq!(exit_code(&[idle()]), EXIT_OK);
    }

    #[test]
    fn a_robot_never_read_has_no_null_in_its_line() {
        let r = json!({"name": "press-loader", "link": {"connected": false,
            "error": "connection refused", "reconnects": 0}, "phase": "link-down",
            "homed": false, "refuses": "the PLC link is down", "plc_mode": null,
            "heartbeat_age_ms": null, "state": null, "fault": null, "counts": null,
            "pose": null, "current_move": null, "queued": []});
        let text = line(&r);
        assert!(!text.contains("null"), "{text}");
        assert!(
            text.starts_with("press-loader: link down; link error: connection refused; PLC not read yet; pose unknown")
                && text.ends_with("new moves refused: the PLC link is down"),
            "{text}"
        );
        assert_eq!(exit_code(&[idle(), r]), EXIT_NOT_DONE);
    }

    #[test]
    fn a_link_lost_shows_the_plc_as_last_read_without_a_heartbeat_age() {
        let mut r = idle();
        r["link"] = json!({"connected": false, "error": "connection refused",
            "reconnects": 3});
        r["phase"] = json!("link-down");
        let text = line(&r);
        assert!(
            text.contains(
                "link down; link error: connection refused (opened 3 times); PLC as last read: \
                 in RUN, program idle, homed;"
            ),
            "{text}"
        );
        assert_eq!(exit_code(&[r]), EXIT_NOT_DONE);
    }

    #[test]
    fn a_fault_exits_1_and_is_named() {
        let mut r = idle();
        r["state"] = json!("fault");
        r["fault"] = json!(3);
        r["current_move"] = json!(7);
        r["queued"] = json!([8, 9]);
        let text = line(&r);
        assert!(
            text.contains("program fault, homed, fault 3")
                && text.contains("move 7 running, queued 8, 9"),
            "{text}"
        );
        assert_eq!(exit_code(&[r]), EXIT_FAILURE);
    }
}
