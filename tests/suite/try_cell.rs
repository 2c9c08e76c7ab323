//! README.md's "Try the daemon on a simulated cell", as processes: `linterpd mock-plc --cell
//! config/examples/cells/press.toml` and `linterpd serve --config config/try.toml` (the shipped
//! file, only its PLC address changed to the mock's free port), then `linterpd cycle run
//! press-load --count 3 --follow`; and what a new integrator hits on the way: a cell that never
//! opens the press, Ctrl-C on an attached move, the shipped config's commented cell, a copied
//! program that keeps its number, `cycle run` of a program that is not there.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::process::{Finished, Spawned, TempDir};
use common::serve::READY;
use serde_json::Value;

const REPO: &str = env!("CARGO_MANIFEST_DIR");
/// The longest three press cycles may take (about 20 s).
const CYCLES: Duration = Duration::from_secs(180);

fn repo(path: &str) -> PathBuf {
    Path::new(REPO).join(path)
}

/// The try recipe's cell: the mock PLC with `cell`, its control socket in `dir`.
fn mock_with_cell(dir: &Path, cell: &Path) -> (Spawned, String) {
    let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    command
        .args(["mock-plc", "--listen", "127.0.0.1:0", "--cell"])
        .arg(cell)
        .arg("--control")
        .arg(dir.join("mock.sock"));
    let mut mock = Spawned::spawn("linterpd mock-plc --cell", command);
    let address = mock.first_line_after("listening on ", READY);
    (mock, address)
}

/// `config/try.toml` and the example program under `dir/config`, as in the repository, the PLC
/// address the mock's; `program` edits the program's text.
fn try_layout(dir: &Path, address: &str, program: impl Fn(String) -> String) {
    let text = std::fs::read_to_string(repo("config/try.toml")).unwrap();
    assert_eq!(
        text.matches("address = \"127.0.0.1:9094\"").count(),
        1,
        "the recipe's address"
    );
    let text = text.replace(
        "address = \"127.0.0.1:9094\"",
        &format!("address = \"{address}\""),
    );
    let cycles = dir.join("config/examples/cycles");
    std::fs::create_dir_all(&cycles).unwrap();
    std::fs::write(dir.join("config/try.toml"), text).unwrap();
    let press_load =
        std::fs::read_to_string(repo("config/examples/cycles/press-load.toml")).unwrap();
    std::fs::write(cycles.join("press-load.toml"), program(press_load)).unwrap();
}

/// `linterpd serve --config config/try.toml` in `dir`, connected to the mock.
fn serve_try(dir: &Path) -> Spawned {
    let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    command
        .current_dir(dir)
        .args(["serve", "--config", "config/try.toml"]);
    let mut serve = Spawned::spawn("linterpd serve --config config/try.toml", command);
    serve.wait_for_stderr("API listening", READY);
    serve.wait_for_stderr("press-loader: connected", READY);
    serve
}

/// A client command in `dir`, the socket from `LINTERPD_SOCKET` as the recipe exports it.
fn client(dir: &Path, args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    command
        .current_dir(dir)
        .env("LINTERPD_SOCKET", "target/try/api.sock")
        .args(args);
    command
}

fn run(dir: &Path, args: &[&str]) -> Finished {
    Spawned::spawn(&format!("linterpd {}", args.join(" ")), client(dir, args)).finish(READY)
}

#[test]
fn try_config_runs_three_press_cycles_with_the_press_models_waits_and_permits_met() {
    let dir = TempDir::new("try");
    let (_mock, address) = mock_with_cell(dir.path(), &repo("config/examples/cells/press.toml"));
    try_layout(dir.path(), &address, |p| p);
    assert!(
        !dir.path().join("target").exists(),
        "the socket's directory is the daemon's to make"
    );
    let _serve = serve_try(dir.path());

    let ready = run(dir.path(), &["status", "--wait", "10s"]);
    assert_eq!(ready.status.code(), Some(0), "{}", ready.describe());
    assert!(
        ready.stdout.contains("link up; PLC in RUN"),
        "{}",
        ready.stdout
    );
    let args = ["cycle", "run", "press-load", "--count", "3", "--follow"];
    let follow = Spawned::spawn("cycle run --follow", client(dir.path(), &args)).finish(CYCLES);
    assert_eq!(follow.status.code(), Some(0), "{}", follow.describe());
    let lines: Vec<&str> = follow.stdout.lines().collect();
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("press-load: cycle 1 of 3, step 1 (pick)")),
        "{}",
        follow.stdout
    );
    for cycle in 1..=3 {
        let permitted = format!(
            "press-load: cycle {cycle} of 3, step 7: move to [-1144.43, 659.6, 186.6] (permit \
             press_open & !press_moving)"
        );
        assert!(lines.contains(&permitted.as_str()), "{}", follow.stdout);
    }
    let last = lines.last().unwrap();
    assert!(
        last.starts_with("press-load: done") && last.contains("3 of 3 done"),
        "{last}"
    );
    assert!(follow.stderr.is_empty(), "{}", follow.stderr);

    // The press model saw press_go rise once a cycle, after the permitted moves, and the gripper
    // took a blank off the stack each cycle.
    let cell = run(dir.path(), &["io", "cell", "--mock", "mock.sock"]);
    assert_eq!(cell.status.code(), Some(0), "{}", cell.describe());
    // (The last stroke may still run: the cycle ends as the press starts.)
    assert!(
        cell.stdout.starts_with("press[0] ")
            && cell
                .stdout
                .trim()
                .ends_with(", 3 strokes; stack[0] 997 of 1000 parts"),
        "{}",
        cell.stdout
    );
    let status = run(dir.path(), &["cycle", "status"]);
    assert_eq!(status.status.code(), Some(0), "{}", status.describe());
}

#[test]
fn readme_try_section_runs_what_the_test_runs() {
    let readme = std::fs::read_to_string(repo("README.md")).unwrap();
    let section = readme
        .split("## Try the daemon on a simulated cell")
        .nth(1)
        .and_then(|s| s.split("\n## ").next())
        .expect("README.md has the try section");
    let block = section
        .split("```sh\n")
        .nth(1)
        .and_then(|b| b.split("```").next())
        .unwrap();
    let commands: Vec<&str> = block.lines().collect();
    assert!(commands.len() <= 5, "at most five commands: {commands:?}");
    assert_eq!(
        commands,
        [
            "RUST_LOG=warn target/release/linterpd mock-plc --listen 127.0.0.1:9094 --cell \
             config/examples/cells/press.toml --control target/try/mock.sock &",
            "RUST_LOG=warn target/release/linterpd serve --config config/try.toml &",
            "export LINTERPD_SOCKET=target/try/api.sock",
            "target/release/linterpd status --wait 10s",
            "target/release/linterpd cycle run press-load --count 3 --follow",
        ],
        "the commands the tests here run (but for the mock's port, 0 in a test)"
    );
    let try_toml = std::fs::read_to_string(repo("config/try.toml")).unwrap();
    assert!(try_toml.contains("tcp = { address = \"127.0.0.1:9094\" }"));
    assert!(try_toml.contains("socket = \"../target/try/api.sock\""));
}

#[test]
fn follow_exits_non_zero_naming_the_wait_when_the_press_never_opens() {
    let dir = TempDir::new("try-closed");
    let cell = dir.path().join("closed.toml");
    std::fs::write(
        &cell,
        "[signals]\npress_open = \"X5\"\npress_moving = \"X6\"\npart_present = \"X2\"\n\
         gripper = \"Y1\"\n[[stack]]\npresent = \"part_present\"\ntake = \"gripper\"\n\
         parts = 10\n[constants]\npress_open = false\npress_moving = false\n",
    )
    .unwrap();
    let (_mock, address) = mock_with_cell(dir.path(), &cell);
    // The program as shipped, its wait for the press 2 s long instead of 60.
    try_layout(dir.path(), &address, |p| {
        let shorter = p.replace("timeout = \"60s\"", "timeout = \"2s\"");
        assert_ne!(shorter, p);
        shorter
    });
    let _serve = serve_try(dir.path());

    let args = ["cycle", "run", "press-load", "--count", "3", "--follow"];
    let follow = Spawned::spawn("cycle run --follow", client(dir.path(), &args)).finish(CYCLES);
    assert_eq!(follow.status.code(), Some(3), "{}", follow.describe());
    assert!(
        follow.stdout.contains(
            "press-load: cycle 1 of 3, step 6 (before-press): wait for press_open (X5) & \
             !press_moving (X6): waiting for press_open (X5) & !press_moving (X6)"
        ),
        "{}",
        follow.describe()
    );
    let error = follow.stderr.trim();
    assert!(
        error.starts_with("error: press-load faulted at step 6 (before-press) of press-load: wait for press_open (X5) & !press_moving (X6)")
            && error.contains("0 of 3 cycles done"),
        "{error}"
    );
    // A script tells the faulted cycle apart.
    let status = run(dir.path(), &["cycle", "status"]);
    assert_eq!(status.status.code(), Some(1), "{}", status.describe());
    assert!(status.stdout.contains("FAULTED"), "{}", status.stdout);
    let status = run(dir.path(), &["status"]);
    assert_eq!(status.status.code(), Some(1), "{}", status.describe());
}

/// `status --json` of the robot until `done` holds.
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
        let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
            .args(["status", "--json", "--socket"])
            .arg(socket)
            .output()
            .unwrap();
        let robots: Value = serde_json::from_slice(&out.stdout).unwrap_or(Value::Null);
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

/// A long slow move, attached; once the daemon runs it, Ctrl-C.
fn interrupted_move(socket: &Path, extra: &[&str]) -> Finished {
    let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    command
        .args(["move", "--to", "0,600,100", "--speed", "20", "--socket"])
        .arg(socket)
        .args(extra);
    let mut attached = Spawned::spawn("linterpd move", command);
    status_until_or(
        socket,
        "the move running",
        |r| r["current_move"].is_u64() && r["state"] == "running",
        || attached.output(),
    );
    attached.interrupt();
    attached.finish(READY)
}

#[test]
fn ctrl_c_on_an_attached_move_stops_the_robot() {
    let running = common::serve::start();
    let socket = running.socket.as_path();
    let stopped = interrupted_move(socket, &[]);
    assert_eq!(stopped.status.code(), Some(130), "{}", stopped.describe());
    assert!(
        stopped
            .stderr
            .contains("error: interrupted (Ctrl-C): press-loader stopped, move 1 with it"),
        "{}",
        stopped.describe()
    );
    status_until(socket, "the robot stopped", |r| {
        r["state"] == "stopped" && r["current_move"].is_null()
    });

    let detached = interrupted_move(socket, &["--detach"]);
    assert_eq!(detached.status.code(), Some(0), "{}", detached.describe());
    assert!(
        detached.stderr.contains("detached: move 2 goes on"),
        "{}",
        detached.describe()
    );
    let still = status_until(socket, "the move still running", |r| {
        r["state"] == "running"
    });
    assert_eq!(still["current_move"], 2, "{still}");
}

/// The shipped config's robot with its commented `[robots.press-loader.cell]` and
/// `[robots.press-loader.gateway]` blocks uncommented as they stand, the programs directory
/// pointed at the examples.
fn shipped_with_cell_uncommented() -> String {
    let shipped = std::fs::read_to_string(repo("config/linterpd.toml")).unwrap();
    let mut out = String::new();
    let mut block = false;
    for line in shipped.lines() {
        if line == "# [robots.press-loader.cell]" || line == "# [robots.press-loader.gateway]" {
            block = true;
        }
        // A block's lines are TOML (`key = value`) up to its first line of prose.
        let code = line
            .strip_prefix("# ")
            .filter(|code| block && (code.starts_with('[') || code.contains(" = ")));
        if let Some(code) = code {
            out.push_str(code);
        } else {
            block = false;
            out.push_str(line);
        }
        out.push('\n');
    }
    let cycles = repo("config/examples/cycles");
    out.replace(
        "programs = \"cycles\"",
        &format!("programs = \"{}\"", cycles.display()),
    )
}

#[test]
fn shipped_config_commented_cell_and_gateway_blocks_check_the_example_program() {
    let dir = TempDir::new("shipped-cell");
    let config = dir.path().join("linterpd.toml");
    let text = shipped_with_cell_uncommented();
    assert!(
        text.contains("\n[robots.press-loader.cell]\n")
            && text.contains("\n[robots.press-loader.gateway]\n"),
        "{text}"
    );
    std::fs::write(&config, text).unwrap();
    let check = run(
        dir.path(),
        &["check-config", "--config", config.to_str().unwrap()],
    );
    assert_eq!(check.status.code(), Some(0), "{}", check.describe());
    assert!(
        check.stdout.contains("press-load (number 1), each checked"),
        "{}",
        check.stdout
    );
}

/// A programs directory holding the example program and `more` (name, text).
fn programs(dir: &Path, more: &[(&str, &str)]) -> PathBuf {
    let cycles = dir.join("cycles");
    std::fs::create_dir_all(&cycles).unwrap();
    std::fs::copy(
        repo("config/examples/cycles/press-load.toml"),
        cycles.join("press-load.toml"),
    )
    .unwrap();
    for (name, text) in more {
        std::fs::write(cycles.join(format!("{name}.toml")), text).unwrap();
    }
    cycles
}

const CELL: &str = "signals = { press_open = \"X5\", press_moving = \"X6\", \
                    part_present = \"X2\", gripper = \"Y1\", press_go = \"Y0\" }\n";
const GATEWAY: &str = "[robots.press-loader.gateway]\nwrite = [\"Y0-Y7\"]\n";

#[test]
fn check_config_checks_every_program_and_names_both_files_of_a_copied_number() {
    let dir = TempDir::new("check-programs");
    let copy = std::fs::read_to_string(repo("config/examples/cycles/press-load.toml")).unwrap();
    let cycles = programs(dir.path(), &[("press-load-copy", &copy)]);
    let config = dir.path().join("linterpd.toml");
    let shipped = std::fs::read_to_string(repo("config/linterpd.toml")).unwrap();
    std::fs::write(
        &config,
        format!("{shipped}\n[robots.press-loader.cell]\n{CELL}programs = \"cycles\"\n{GATEWAY}"),
    )
    .unwrap();
    let check = run(
        dir.path(),
        &["check-config", "--config", config.to_str().unwrap()],
    );
    assert_eq!(check.status.code(), Some(2), "{}", check.describe());
    assert!(
        check.stderr.contains(&format!(
            "programs {} and {} have the same number = 1",
            cycles.join("press-load.toml").display(),
            cycles.join("press-load-copy.toml").display()
        )),
        "{}",
        check.stderr
    );

    // A program that does not check is named with its step; the good one is not refused for it.
    std::fs::write(
        cycles.join("press-load-copy.toml"),
        copy.replace("number = 1", "number = 2")
            .replace("wait = \"part_present\"", "wait = \"part_presnt\""),
    )
    .unwrap();
    let check = run(
        dir.path(),
        &["check-config", "--config", config.to_str().unwrap()],
    );
    assert_eq!(check.status.code(), Some(2), "{}", check.describe());
    assert!(
        check.stderr.contains("one fault in its cycle programs")
            && check
                .stderr
                .contains("program \"press-load-copy\" step 2: wait: condition \"part_presnt\""),
        "{}",
        check.stderr
    );
}

#[test]
fn cycle_run_of_a_missing_program_says_so_whatever_else_is_wrong() {
    let dir = TempDir::new("missing-program");
    let copy = std::fs::read_to_string(repo("config/examples/cycles/press-load.toml")).unwrap();
    let cycles = programs(dir.path(), &[("copy", &copy)]);
    let extra = format!(
        "[robots.press-loader.cell]\n{CELL}programs = \"{}\"\n{GATEWAY}",
        cycles.display()
    );
    let running = common::serve::start_with_config(&[], &extra);
    let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(["cycle", "run", "nosuch", "--socket"])
        .arg(&running.socket)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!(
            "program \"nosuch\": no such program; there are: copy, press-load (in {}, which has \
             no nosuch.toml)",
            cycles.display()
        )),
        "{err}"
    );
}
