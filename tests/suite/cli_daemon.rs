//! The CLI against a running daemon: `linterpd serve` on `linterpd mock-plc`, both real
//! processes, and `linterpd move / status / stop / home / clear-fault` as an operator types them.

use crate::common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use common::process::Spawned;
use common::serve::READY;
use serde_json::{Value, json};

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

    // A bounded-error line past the point nearest the robot's axis: the radial joint d3
    // reverses halfway while theta1 turns, so the line runs as two starts cut there, each
    // followed to its end.
    let (code, out, err) = linterpd(socket, &["move", "--to=-150,560,40"]);
    assert_eq!(code, Some(0), "{out}{err}");
    let (code, out, err) = linterpd(
        socket,
        &["move", "--to", "150,560,40", "--tolerance", "0.05"],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 2, "{out}");
    assert!(
        lines[0].starts_with("start 1/2: move ") && lines[0].contains(" done: upload "),
        "{out}"
    );
    assert!(
        lines[1].starts_with("start 2/2: move ") && lines[1].contains(" done: upload "),
        "{out}"
    );
    assert!(lines[1].contains("final error ["), "{out}");

    let (code, out, err) = linterpd(socket, &["status", "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let robots: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(robots[0]["name"], "press-loader");
    assert_eq!(robots[0]["link"]["connected"], true);
    let (code, out, _) = linterpd(socket, &["status"]);
    assert_eq!(code, Some(0));
    assert!(
        out.starts_with("press-loader: idle; link up; PLC in RUN, program done, homed"),
        "{out}"
    );
    assert!(!out.contains("null"), "{out}");

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

/// `status --json` until `done` holds for the robot (at most `READY`); returns its state.
fn status_until(socket: &Path, what: &str, done: impl Fn(&Value) -> bool) -> Value {
    status_until_or(socket, what, done, String::new)
}

/// As [`status_until`], with `more` told when it fails.
fn status_until_or(
    socket: &Path,
    what: &str,
    done: impl Fn(&Value) -> bool,
    more: impl Fn() -> String,
) -> Value {
    let deadline = Instant::now() + READY;
    loop {
        let (_, out, err) = linterpd(socket, &["status", "--json"]);
        let robots: Value = serde_json::from_str(out.trim())
            .unwrap_or_else(|e| panic!("status --json: {e}: {out}{err}"));
        if done(&robots[0]) {
            return robots[0].clone();
        }
        assert!(
            Instant::now() < deadline,
            "waited for {what}: {robots}\n{}",
            more()
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// One `error: ...` line on stderr, nothing on stdout.
fn assert_one_error_line(out: &str, err: &str) {
    assert!(out.is_empty(), "printed as if it had worked: {out}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.starts_with("error: "), "{err}");
}

#[test]
fn an_unhomed_robot_refuses_moves_until_linterpd_home() {
    let running = common::serve::start_with(&["--unhomed"]);
    let socket = running.socket.as_path();
    status_until(socket, "the unhomed phase", |r| r["phase"] == "unhomed");

    // Connected, no fault: status exits 0, and says in words why moves are refused.
    let (code, out, err) = linterpd(socket, &["status"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.contains("link up; PLC in RUN, program idle, not homed")
            && out.contains("new moves refused: the robot is not homed")
            && !out.contains("null"),
        "{out}"
    );

    let (code, out, err) = linterpd(socket, &["move", "--to", "50,520,20"]);
    assert_eq!(code, Some(3), "{out}{err}");
    assert_one_error_line(&out, &err);
    assert!(
        err.contains("the robot is not homed") && err.contains("(reason: not-homed)"),
        "{err}"
    );

    let (code, out, err) = linterpd(socket, &["clear-fault"]);
    assert_eq!(code, Some(3), "{out}{err}");
    assert_one_error_line(&out, &err);
    assert!(err.contains("the PLC reports no fault"), "{err}");

    let (code, out, err) = linterpd(socket, &["home"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out.trim(), "press-loader: homed");
    let (code, out, err) = linterpd(socket, &["home", "--json"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out.trim(), r#"{"homed":true}"#);

    let (code, out, err) = linterpd(socket, &["move", "--to", "50,520,20"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(out.starts_with("move 1 done: upload "), "{out}");

    // A long move and a timeout far shorter: exit 3 saying what it waits for; it goes on.
    let long = ["move", "--to", "0,700,100", "--speed", "20mm/s"];
    let (code, out, err) = linterpd(socket, &[&long[..], &["--timeout", "300ms"]].concat());
    assert_eq!(code, Some(3), "{out}{err}");
    assert_one_error_line(&out, &err);
    assert!(
        err.contains("move 2 did not end within 0.3 s (--timeout)")
            && err.contains("waiting for")
            && err.contains("it was not stopped"),
        "{err}"
    );
    let (code, _, err) = linterpd(socket, &["stop"]);
    assert_eq!(code, Some(0), "{err}");
}

#[test]
fn a_link_that_goes_down_is_said_by_move_and_status() {
    let mut running = common::serve::start();
    let socket = running.socket.clone();
    let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    // About 11 s at 20 mm/s.
    command.args([
        "move",
        "--to",
        "0,700,100",
        "--speed",
        "20",
        "--timeout",
        "3s",
    ]);
    command.arg("--socket").arg(&socket);
    let mut follower = Spawned::spawn("linterpd move", command);
    status_until_or(
        &socket,
        "the move running",
        |r| r["current_move"] == 1,
        || follower.output(),
    );
    assert!(running.mock.terminate(READY).success());

    follower.wait_for_stderr("move 1: waiting for the PLC link of press-loader", READY);
    let ended = follower.finish(READY);
    assert_eq!(ended.status.code(), Some(3), "{}", ended.describe());
    let notices = ended
        .stderr
        .lines()
        .filter(|l| l.starts_with("move 1: waiting for"))
        .count();
    assert_eq!(notices, 1, "said once: {}", ended.describe());
    assert!(
        ended
            .stderr
            .contains("move 1 did not end within 3.0 s (--timeout)")
            && ended
                .stderr
                .contains("waiting for the PLC link of press-loader to come back"),
        "{}",
        ended.describe()
    );

    // status: exit 3 like `systemctl status` for a unit that is not running, in words.
    status_until(&socket, "the link down", |r| {
        r["link"]["connected"] == false
    });
    let (code, out, err) = linterpd(&socket, &["status"]);
    assert_eq!(code, Some(3), "{out}{err}");
    assert!(
        out.starts_with("press-loader: link down; link error: ")
            && out.contains("PLC as last read: in RUN")
            && !out.contains("null"),
        "{out}"
    );
    let (code, out, _) = linterpd(&socket, &["status", "--json"]);
    assert_eq!(code, Some(3), "{out}");

    // A new order is refused at once: exit 4 with the reason.
    let (code, out, err) = linterpd(&socket, &["move", "--to", "50,520,20"]);
    assert_eq!(code, Some(4), "{out}{err}");
    assert_one_error_line(&out, &err);
    assert!(err.contains("(reason: link-down)"), "{err}");
}

#[test]
fn a_second_daemon_on_the_same_socket_refuses_and_sighup_keeps_the_first_running() {
    let mut running = common::serve::start();
    let mut second = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    second.arg("serve").arg("--config").arg(&running.config);
    let second = common::process::Spawned::spawn("a second linterpd serve", second)
        .finish(common::serve::READY);
    assert_eq!(second.status.code(), Some(1), "{}", second.describe());
    assert!(
        second
            .stderr
            .contains("another linterpd daemon already serves"),
        "{}",
        second.describe()
    );
    // The first daemon's socket was left alone.
    let (code, _, err) = linterpd(&running.socket, &["status", "--json"]);
    assert_eq!(code, Some(0), "{err}");

    // SIGHUP reads the config again; the daemon goes on.
    let pid = running.serve.id().to_string();
    let sent = Command::new("sh")
        .args(["-c", "kill -HUP \"$1\"", "sh", &pid])
        .status()
        .unwrap();
    assert!(sent.success());
    running
        .serve
        .wait_for_stderr("SIGHUP: the config is unchanged", common::serve::READY);
    let (code, _, err) = linterpd(&running.socket, &["status", "--json"]);
    assert_eq!(code, Some(0), "{err}");
}

/// `status --json`'s counts of the only robot.
fn counts(socket: &Path) -> Value {
    let (_, out, _) = linterpd(socket, &["status", "--json"]);
    let robots: Value = serde_json::from_str(out.trim()).unwrap();
    robots[0]["counts"].clone()
}

#[test]
fn operator_jogs_moves_joints_and_teaches_positions_through_the_cli() {
    let running = common::serve::start();
    let socket = running.socket.as_path();
    let state_dir = socket.parent().unwrap();

    // The mock starts at counts 0: the tool at (0, 500, 0) mm. A jog out and up.
    let (code, out, err) = linterpd(socket, &["move", "--by", "0,20,10"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(
        out.starts_with("move 1 done: ") && out.contains("final error [0,0,0,0] pulses"),
        "{out}"
    );
    // d2 10 mm at 0.025 mm a pulse, d3 20 mm at 0.013 mm.
    let taught = json!([0, 400, 1538, 0]);
    assert_eq!(counts(socket), taught);

    let (code, out, err) = linterpd(socket, &["pos", "save", "pick"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert_eq!(
        out.trim(),
        "press-loader: saved pick: x 0.000, y 519.994, z 10.000 mm, a 0.000 deg; joint counts [0,400,1538,0]"
    );
    assert!(state_dir.join("positions.json").exists());
    let (code, out, _) = linterpd(socket, &["pos", "list"]);
    assert_eq!(code, Some(0));
    assert_eq!(out.lines().count(), 1, "{out}");
    assert!(out.starts_with("pick: x 0.000, y 519.994"), "{out}");
    let (code, out, _) = linterpd(socket, &["pos", "show", "pick", "--json"]);
    assert_eq!(code, Some(0));
    let shown: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(shown["joint_counts"], taught);

    // Away by a jog and a joint move, then back to the taught position.
    let (code, out, err) = linterpd(socket, &["move", "--by", "15,0,-5", "--json"]);
    assert_eq!(code, Some(0), "{out}{err}");
    let last: Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(last["order"]["by"], json!([15.0, 0.0, -5.0]));
    assert_eq!(last["final_error_pulses"], json!([0, 0, 0, 0]));
    let (code, out, err) = linterpd(socket, &["move", "--joints", "5,20,30,-10"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert_eq!(counts(socket), json!([2000, 800, 2308, -4000]));
    let (code, out, err) = linterpd(socket, &["move", "--to", "@pick"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(out.contains("final error [0,0,0,0] pulses"), "{out}");
    assert_eq!(counts(socket), taught);

    // Refusals: exit 2 naming what is wrong, nothing on stdout.
    let (code, out, err) = linterpd(socket, &["pos", "show", "place"]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert_one_error_line(&out, &err);
    assert!(
        err.contains("no position \"place\" for robot press-loader; positions: pick"),
        "{err}"
    );
    let (code, out, err) = linterpd(socket, &["pos", "save", "a/b"]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(err.contains("1 to 32 letters, digits"), "{err}");
    let (code, out, err) = linterpd(socket, &["move", "--to", "@place"]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(
        err.contains("no such position; taught positions: pick"),
        "{err}"
    );
    let (code, out, err) = linterpd(socket, &["move", "--joints", "5,20,1200,0"]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(
        err.contains("joint d3 target 1200.0000 mm is beyond its limits 0 to 1000 mm"),
        "{err}"
    );
    let (code, _, err) = linterpd(socket, &["move", "--by", "1,2,3", "--to", "1,2,3"]);
    assert_eq!(code, Some(2), "{err}");

    let (code, out, err) = linterpd(socket, &["pos", "delete", "pick"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out.trim(), "press-loader: deleted pick");
    let (code, out, _) = linterpd(socket, &["pos", "list"]);
    assert_eq!(code, Some(0));
    assert_eq!(out.trim(), "press-loader: no taught positions");
}

#[test]
fn serve_started_by_hand_creates_its_missing_state_dir_so_pos_save_works() {
    use std::os::unix::fs::PermissionsExt;
    let running = common::serve::start_with_state_dir("var/lib/linterpd");
    let socket = running.socket.as_path();
    let state_dir = socket.parent().unwrap().join("var/lib/linterpd");
    let mode = std::fs::metadata(&state_dir).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode & !0o750, 0, "{mode:o}");
    let (code, out, err) = linterpd(socket, &["pos", "save", "pick"]);
    assert_eq!(code, Some(0), "{out}{err}");
    assert!(state_dir.join("positions.json").exists());
}

#[test]
fn operator_runs_a_path_file_through_the_cli_section_by_section() {
    let running = common::serve::start();
    let socket = running.socket.as_path();
    let dir = socket.parent().unwrap();
    // The mock starts at counts 0: the tool at (0, 500, 0) mm. Out and up with a blended
    // corner, a stop, then up again: two sections.
    let file = dir.join("cycle.toml");
    std::fs::write(
        &file,
        "[[element]]\nline = [0, 520, 10]\nblend = \"5mm\"\n\
         [[element]]\nline = [20, 520, 10]\nstop = true\n\
         [[element]]\nline = [20, 520, 30]\n",
    )
    .unwrap();
    let (code, out, err) = linterpd(socket, &["run", file.to_str().unwrap(), "--speed", "100"]);
    assert_eq!(code, Some(0), "{out}{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 2, "{out}");
    // Each names the elements it ran: 1 and 2 through the blend, then 3.
    assert!(
        lines[0].starts_with("section 1/2 (element 1-2): move 1 done: "),
        "{out}"
    );
    assert!(
        lines[1].starts_with("section 2/2 (element 3): move 2 done: "),
        "{out}"
    );
    assert!(lines[1].contains("final error [0,0,0,0] pulses"), "{out}");

    // A file with a mistake is refused before the daemon sees it, naming the element and key.
    std::fs::write(&file, "[[element]]\narc = [0, 520, 10]\n").unwrap();
    let (code, out, err) = linterpd(socket, &["run", file.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(err.contains("element 1: an arc needs `via"), "{err}");
    // A path the robot cannot follow is refused by the daemon whole (exit 2, 422).
    std::fs::write(&file, "[[element]]\nline = [0, 520, 5000]\n").unwrap();
    let (code, out, err) = linterpd(socket, &["run", file.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(err.contains("path section 1 (element 1): joint"), "{err}");
    assert_eq!(counts(socket), json!(counts_after_cycle()));
}

#[test]
fn run_numbers_the_sections_the_reports_give_not_the_starts_of_a_section_cut_into_parts() {
    let running = common::serve::start();
    let socket = running.socket.as_path();
    let file = socket.parent().unwrap().join("lift.toml");
    // The mock starts at counts 0: the tool at (0, 500, 0) mm. A straight lift blended into a
    // traverse (the base and radial joints stand still until the blend, so a bounded-error
    // plan cuts that section into parts), a stop, then down: two sections.
    std::fs::write(
        &file,
        "path_accel = \"5000mm/s2\"\n\
         [[element]]\nline = [0, 500, 100]\nblend = \"20mm\"\n\
         [[element]]\nline = [60, 560, 100]\nstop = true\n\
         [[element]]\nline = [60, 560, 80]\n",
    )
    .unwrap();
    let (code, out, err) = linterpd(
        socket,
        &["run", file.to_str().unwrap(), "--tolerance", "0.05mm"],
    );
    assert_eq!(code, Some(0), "{out}{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert!(
        lines.len() > 2,
        "the first section is cut into parts: {out}"
    );
    let parts = lines.len() - 1;
    for (k, line) in lines[..parts].iter().enumerate() {
        let label = format!("section 1/2, part {}/{parts} ", k + 1);
        assert!(line.starts_with(&label), "{label:?} in\n{out}");
    }
    assert!(
        lines[parts].starts_with("section 2/2 (element 3): "),
        "{out}"
    );
    assert!(!out.contains("section 3"), "{out}");
}

/// Where the cycle above leaves the mock: (20, 520, 30) with the tool angle kept at 0.
fn counts_after_cycle() -> [i64; 4] {
    let robot = linterpd::robot::seed_robot();
    let pose = linterpd::geometry::Pose::from_mm_deg(20.0, 520.0, 30.0, 0.0);
    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &pose, None).unwrap();
    robot.counts_of(&q)
}

/// systemd may stop (SIGTERM), reload (SIGHUP) or a terminal interrupt (SIGINT) the daemon the
/// moment it says it listens: each is listened for before anything is bound, so none of them
/// kills it (a SIGHUP's and a SIGTERM's default action ends a process). Found by the Modbus
/// face's test, which once saw the daemon killed by its SIGTERM under load.
#[test]
fn a_signal_as_soon_as_the_daemon_listens_is_handled_never_fatal() {
    let dir = common::process::TempDir::new("signals");
    let socket = dir.path().join("api.sock");
    let config = dir.path().join("linterpd.toml");
    // No PLC there: the daemon serves its API and keeps trying the link.
    std::fs::write(&config, common::serve::config_for("127.0.0.1:1", &socket)).unwrap();
    let serve = || {
        let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
        command.arg("serve").arg("--config").arg(&config);
        let mut serve = Spawned::spawn("linterpd serve", command);
        serve.wait_for_stderr("API listening", READY);
        serve
    };
    for round in 0..3 {
        let mut term = serve();
        let status = term.terminate(READY);
        assert!(status.success(), "round {round}, SIGTERM: {status:?}");

        let mut hup = serve();
        hup.hangup();
        hup.wait_for_stderr("SIGHUP", READY);
        let status = hup.terminate(READY);
        assert!(
            status.success(),
            "round {round}, SIGHUP then SIGTERM: {status:?}"
        );

        let mut int = serve();
        int.interrupt();
        let done = int.finish(READY);
        assert!(
            done.status.success(),
            "round {round}, SIGINT: {}",
            done.describe()
        );
    }
}
