//! `linterpd status`: each robot's phase, link, PLC state, pose and moves, from the daemon, in
//! words (never `null`); exits like `systemctl status`: 0 when every robot's link is up, no
//! fault is latched and no cycle is faulted, 3 when a robot's PLC link is down or stalled, else
//! 1 when a robot reports a fault or its cycle is faulted (with `--json` too).
//!
//! ```text
//! press-loader: idle; link up; PLC in RUN, program idle, homed, heartbeat 12 ms ago;
//!   pose (0.000, 500.000, 0.000 mm, 0.000 deg); no move running, nothing queued
//! ```
//! (one line per robot; wrapped here). `--wait 10s` first waits, at most that long, for the
//! daemon to answer and every robot's link to be up with its PLC read (a script's "is it ready?"
//! after starting the daemon), then says the same. `--watch` follows the daemon's live stream
//! (`GET /v1/live`, the console's): a robot's line again each time it changes (the heartbeat's
//! age aside), until Ctrl-C or the daemon ends it; `--json` prints the stream's lines as sent.

use std::fmt::Write as _;

use anyhow::Context as _;
use clap::Args;
use hyper::Method;
use serde_json::Value;

use super::client::{Client, Received};
use super::{DaemonArgs, EXIT_FAILURE, EXIT_NOT_DONE, EXIT_OK, Failure};
use crate::contract::State;
use crate::daemon::{RobotPhase, RobotState};
use crate::plc::PlcMode;

/// Arguments of `linterpd status`.
#[derive(Debug, Args)]
pub struct StatusArgs {
    /// One robot only.
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// Wait, at most this long (e.g. `10s`), for the daemon to answer and every robot's PLC link
    /// to be up with its PLC read; then print and exit as without it.
    #[arg(long, allow_hyphen_values = true)]
    pub wait: Option<String>,
    /// Follow the daemon's live stream: a robot's line each time it changes, until Ctrl-C
    /// (`--json`: the stream's messages as sent, a whole snapshot then merge patches).
    #[arg(long)]
    pub watch: bool,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// The link: up, or its last error; and how often it was opened, when more than once.
fn link(r: &RobotState) -> String {
    let opened = match r.link.reconnects {
        0 | 1 => String::new(),
        n => format!(" (opened {n} times)"),
    };
    if r.link.connected {
        format!("link up{opened}")
    } else {
        match &r.link.error {
            Some(why) => format!("link error: {why}{opened}"),
            None => format!("not connected yet{opened}"),
        }
    }
}

/// The PLC's mode as the operator's panel writes it.
fn mode_word(mode: PlcMode) -> &'static str {
    match mode {
        PlcMode::Run => "RUN",
        PlcMode::Prog => "PROG",
    }
}

/// The PLC as last read: mode, program state, homed, fault, heartbeat (its age only while the
/// link is up: the daemon keeps the last values while it is down).
fn plc(r: &RobotState) -> String {
    let Some(mode) = r.plc_mode else {
        return "PLC not read yet".to_owned();
    };
    let connected = r.link.connected;
    let mut text = format!(
        "PLC {}in {}, program {}, {}",
        if connected { "" } else { "as last read: " },
        mode_word(mode),
        r.state.map_or("state unknown", State::name),
        if r.homed { "homed" } else { "not homed" }
    );
    if let Some(fault) = r.fault {
        let _ = write!(text, ", fault {fault}");
    }
    match r.heartbeat_age_ms {
        Some(ms) if connected => {
            let _ = write!(text, ", heartbeat {ms} ms ago");
        }
        None if connected => text.push_str(", no heartbeat seen"),
        _ => {}
    }
    text
}

/// The pose, or that it is unknown.
fn pose(r: &RobotState) -> String {
    let Some(p) = r.pose else {
        return "pose unknown".to_owned();
    };
    // (+ 0.0: no "-0.000")
    let v = p.map(|x| x + 0.0);
    format!(
        "pose ({:.3}, {:.3}, {:.3} mm, {:.3} deg)",
        v[0], v[1], v[2], v[3]
    )
}

/// The move running and the moves queued.
fn moves(r: &RobotState) -> String {
    let running = r.current_move.map_or("no move running".to_owned(), |id| {
        format!("move {id} running")
    });
    let queued: Vec<String> = r.queued.iter().map(u64::to_string).collect();
    if queued.is_empty() {
        format!("{running}, nothing queued")
    } else {
        format!("{running}, queued {}", queued.join(", "))
    }
}

/// One robot in one line.
fn line(r: &RobotState) -> String {
    let phase = r.phase.name().replace('-', " ");
    let mut text = format!(
        "{}: {phase}; {}; {}; {}; {}",
        r.name,
        link(r),
        plc(r),
        pose(r),
        moves(r)
    );
    if let Some(why) = &r.refuses {
        let _ = write!(text, "; new moves refused: {why}");
    }
    if let Some(inputs) = r.inputs {
        let words: Vec<String> = inputs.iter().map(|w| format!("{w:04X}")).collect();
        let _ = write!(text, "; inputs {}", words.join(" "));
    }
    if r.mode == crate::cell::Mode::Remote {
        text.push_str("; remote mode (the cell face drives it)");
    }
    if let Some(face) = &r.face {
        let _ = write!(text, "\n  {}", describe_face(face));
    }
    if let Some(cycle) = &r.cycle {
        let _ = write!(text, "\n  cycle {}", super::cycle::describe(cycle));
    }
    text
}

/// The cell face in one line.
fn describe_face(face: &crate::daemon::FaceState) -> String {
    let program = match &face.program_name {
        Some(name) => format!("program {} ({name}) selected", face.program),
        None => "no program selected".to_owned(),
    };
    let enable = if face.enabled { "on" } else { "off" };
    let mut text = format!("cell face: {program}, move-enable {enable}");
    if let Some(r) = &face.refused {
        let _ = write!(text, "; last command refused: {} ({})", r.code, r.meaning);
    }
    text
}

/// The exit code for these robots: 3 if a PLC link is down or stalled, else 1 if a robot reports
/// a fault or its cycle is faulted, else 0.
fn exit_code(robots: &[RobotState]) -> u8 {
    let down = robots.iter().any(|r| {
        !r.link.connected || matches!(r.phase, RobotPhase::LinkDown | RobotPhase::Stalled)
    });
    let faulted = robots.iter().any(|r| {
        r.fault.is_some()
            || r.state == Some(State::Fault)
            || r.cycle
                .as_ref()
                .is_some_and(|c| c.state == crate::daemon::CycleState::Faulted)
    });
    if down {
        EXIT_NOT_DONE
    } else if faulted {
        EXIT_FAILURE
    } else {
        EXIT_OK
    }
}

/// The robots of an answer: a list, or one robot.
fn robots(answer: &Value) -> anyhow::Result<Vec<RobotState>> {
    Ok(match answer {
        Value::Array(_) => Received::read(answer.clone(), "a list of robots")?.value,
        one => vec![Received::read(one.clone(), "a robot's state")?.value],
    })
}

/// Whether every robot is ready for orders: its link up and its PLC read.
fn ready(robots: &[RobotState]) -> bool {
    robots
        .iter()
        .all(|r| r.link.connected && r.plc_mode.is_some() && r.state.is_some())
}

/// How often `--wait` asks.
const WAIT_POLL: std::time::Duration = std::time::Duration::from_millis(100);

/// The daemon's answer at `path`, waiting until `until` (if given) for it to answer and for
/// its robots to be [`ready`].
async fn answer(
    client: &Client,
    path: &str,
    until: Option<tokio::time::Instant>,
) -> Result<Value, Failure> {
    loop {
        let answer = client.expect(Method::GET, path, None).await;
        let Some(until) = until else { return answer };
        let done = match &answer {
            Ok(value) => robots(value).is_ok_and(|r| ready(&r)),
            Err(Failure::Unreachable(_)) => false,
            Err(_) => true,
        };
        if done || tokio::time::Instant::now() >= until {
            return answer;
        }
        tokio::time::sleep(WAIT_POLL).await;
    }
}

/// Runs `linterpd status`.
pub fn run(args: &StatusArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let wait = args
        .wait
        .as_deref()
        .map(|t| super::args::parse_duration(t).context("--wait"))
        .transpose()
        .map_err(Failure::BadInput)?;
    args.daemon.block_on(async {
        let client = Client::new(&args.daemon.socket);
        let path = args
            .robot
            .as_ref()
            .map_or("/v1/robots".to_owned(), |r| format!("/v1/robots/{r}"));
        let until = wait.map(|w| tokio::time::Instant::now() + w);
        let answer = answer(&client, &path, until).await?;
        if args.watch {
            return watch(&client, args.robot.as_deref(), args.daemon.json, out).await;
        }
        let robots = robots(&answer).map_err(Failure::Runtime)?;
        let text: Vec<String> = robots.iter().map(line).collect();
        super::print(out, args.daemon.json, &answer, &text.join("\n"))?;
        match exit_code(&robots) {
            EXIT_OK => Ok(()),
            code => Err(Failure::Quiet(code)),
        }
    })
}

/// What `--watch` compares to decide a robot's line changed: its line with the heartbeat's age
/// (which changes at every read) left out.
fn watched(r: &RobotState) -> String {
    let mut steady = r.clone();
    steady.heartbeat_age_ms = steady.heartbeat_age_ms.map(|_| 0);
    line(&steady)
}

/// `status --watch`: a robot's line each time it changes, from the live stream, until the
/// stream ends (exit 4: the daemon went away) or Ctrl-C.
async fn watch(
    client: &Client,
    robot: Option<&str>,
    json: bool,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let mut feed = match client.live(robot).await.map_err(Failure::from_client)? {
        Ok(feed) => feed,
        Err(answer) => {
            return Err(Failure::from_status(
                answer.status,
                anyhow::anyhow!("{}", answer.error()),
            ));
        }
    };
    let mut said: std::collections::BTreeMap<String, String> = std::collections::BTreeMap::new();
    loop {
        let update = tokio::select! {
            next = feed.next() => next.map_err(Failure::Runtime)?,
            _ = tokio::signal::ctrl_c() => return Ok(()),
        };
        let Some(update) = update else {
            return Err(Failure::Unreachable(anyhow::anyhow!(
                "the daemon ended the live stream (it shut down, or this reader fell behind)"
            )));
        };
        let key = watched(&update.live.state);
        if said.get(&update.robot) == Some(&key) && !json {
            continue;
        }
        said.insert(update.robot.clone(), key);
        let text = line(&update.live.state);
        let written = if json {
            writeln!(out, "{}", update.line)
        } else {
            writeln!(out, "{text}")
        };
        written
            .and_then(|()| out.flush())
            .map_err(|e| Failure::Runtime(e.into()))?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn watch_sees_no_change_in_the_heartbeats_age_alone() {
        let a = idle();
        let mut b = idle();
        b.heartbeat_age_ms = Some(250);
        assert_eq!(watched(&a), watched(&b));
        b.pose = Some([1.0, 500.0, 0.0, 0.0]);
        assert_ne!(watched(&a), watched(&b));
    }

    fn state(json: Value) -> RobotState {
        Received::read(json, "a robot's state").unwrap().value
    }

    fn idle() -> RobotState {
        state(
            json!({"name": "press-loader", "link": {"connected": true, "error": null,
            "reconnects": 1}, "phase": "idle", "homed": true, "refuses": null,
            "plc_mode": "run", "heartbeat_age_ms": 12, "state": "idle", "fault": null,
            "counts": [0, 0, 0, 0], "pose": [-0.0, 500.0, 0.0, 0.0], "current_move": null,
            "queued": []}),
        )
    }

    #[test]
    fn an_idle_robot_is_said_in_words() {
        assert_eq!(
            line(&idle()),
            "press-loader: idle; link up; PLC in RUN, program idle, homed, heartbeat 12 ms ago; \
             pose (0.000, 500.000, 0.000 mm, 0.000 deg); no move running, nothing queued"
        );
        assert_eq!(exit_code(&[idle()]), EXIT_OK);
        let mut cycling = idle();
        cycling.inputs = Some([0x20, 0, 0x400, 0]);
        let mut cycle = crate::daemon::CycleStatus::starting("press-load", Some(10));
        cycle.done = 3;
        cycling.cycle = Some(cycle);
        assert!(
            line(&cycling).ends_with(
                "nothing queued; inputs 0020 0000 0400 0000\n  cycle press-load: running; 3 of \
                 10 done"
            ),
            "{}",
            line(&cycling)
        );
    }

    #[test]
    fn a_robot_never_read_has_no_null_in_its_line() {
        let r = state(json!({"name": "press-loader", "link": {"connected": false,
            "error": "connection refused", "reconnects": 0}, "phase": "link-down",
            "homed": false, "refuses": "the PLC link is down", "plc_mode": null,
            "heartbeat_age_ms": null, "state": null, "fault": null, "counts": null,
            "pose": null, "current_move": null, "queued": []}));
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
        r.link = state(json!({"name": "-", "link": {"connected": false,
            "error": "connection refused", "reconnects": 3}}))
        .link;
        r.phase = RobotPhase::LinkDown;
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
        r.state = Some(State::Fault);
        r.fault = Some(3);
        r.current_move = Some(7);
        r.queued = vec![8, 9];
        let text = line(&r);
        assert!(
            text.contains("program fault, homed, fault 3")
                && text.contains("move 7 running, queued 8, 9"),
            "{text}"
        );
        assert_eq!(exit_code(&[r]), EXIT_FAILURE);
    }

    #[test]
    fn a_robot_is_ready_once_linked_with_its_plc_read() {
        assert!(ready(&[idle()]));
        let mut never_read = idle();
        never_read.plc_mode = None;
        never_read.state = None;
        assert!(!ready(&[idle(), never_read]));
        let mut down = idle();
        down.link.connected = false;
        assert!(!ready(&[down]));
    }

    #[test]
    fn status_exits_1_for_a_faulted_cycle_on_a_healthy_robot() {
        let mut r = idle();
        let mut cycle = crate::daemon::CycleStatus::starting("press-load", Some(3));
        cycle.state = crate::daemon::CycleState::Faulted;
        r.cycle = Some(cycle.clone());
        assert_eq!(exit_code(&[r.clone()]), EXIT_FAILURE);
        cycle.state = crate::daemon::CycleState::Paused;
        r.cycle = Some(cycle);
        assert_eq!(exit_code(&[r]), EXIT_OK, "a paused cycle is no fault");
    }

    #[test]
    fn one_robot_or_a_list_reads_as_robots() {
        let one = json!({"name": "a", "phase": "idle"});
        assert_eq!(robots(&one).unwrap().len(), 1);
        assert_eq!(robots(&json!([one, {"name": "b"}])).unwrap().len(), 2);
        let e = format!("{:#}", robots(&json!({"phase": "idle"})).unwrap_err());
        assert!(
            e.starts_with("the daemon's answer is not a robot's state"),
            "{e}"
        );
    }

    #[test]
    fn the_cell_face_is_one_line_with_the_selection_enable_and_refusal() {
        let face = crate::daemon::FaceState {
            program: 3,
            program_name: Some("press-load".into()),
            enabled: false,
            commands: 0,
            refused: Some(crate::daemon::FaceRefusal {
                code: 2,
                meaning: "move-enable is off".into(),
            }),
        };
        assert_eq!(
            super::describe_face(&face),
            "cell face: program 3 (press-load) selected, move-enable off; last command refused: \
             2 (move-enable is off)"
        );
    }
}
