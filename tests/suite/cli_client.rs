//! The daemon's CLI when there is no daemon, and what needs none: `check-config`, `--version`,
//! output into a closed pipe.

use crate::common;

use std::process::{Command, Stdio};

use common::cli::SEED;
use common::process::Spawned;

fn linterpd(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(args)
        .env_remove("LINTERPD_SOCKET")
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn every_client_command_says_clearly_that_the_daemon_is_not_running() {
    let dir = std::env::temp_dir().join(format!("linterpd-no-daemon-{}", std::process::id()));
    let socket = dir.join("api.sock");
    let socket = socket.to_str().unwrap();
    for args in [
        vec!["status"],
        vec!["stop"],
        vec!["home"],
        vec!["clear-fault"],
        vec!["io", "read", "DT0"],
        vec!["move", "--to", "1,2,3"],
    ] {
        let mut all = args.clone();
        all.extend(["--socket", socket]);
        let (code, out, err) = linterpd(&all);
        assert_eq!(code, Some(4), "{args:?}: {err}");
        assert!(out.is_empty());
        assert!(
            err.contains("daemon is not running") && err.contains(socket),
            "{err}"
        );
    }
}

#[test]
fn bad_move_arguments_are_refused_before_any_connection() {
    let (code, _, err) = linterpd(&["move", "--to", "1,2", "--socket", "/nonexistent/api.sock"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--to") && err.contains("a pose is X,Y,Z"),
        "{err}"
    );
    let no_daemon = ["--socket", "/nonexistent/api.sock"];
    for (args, named) in [
        (
            ["--tolerance", "0mm"],
            "--tolerance: '0mm' must be above 0 mm",
        ),
        (["--timeout", "5"], "--timeout: duration \"5\": no unit"),
        (["--accel-time", "x"], "--accel-time: duration \"x\""),
        (
            ["--profile", "s-curve:0"],
            "--profile: \"s-curve:0\": the jerk \"0\" must be a number of mm/s^3 above 0",
        ),
    ] {
        let line = [&["move", "--to", "1,2,3"][..], &args, &no_daemon].concat();
        let (code, out, err) = linterpd(&line);
        assert_eq!(code, Some(2), "{args:?}: {err}");
        assert!(out.is_empty() && err.contains(named), "{err}");
    }
    let (code, _, err) = linterpd(
        &[
            &["move", "--to", "1,2,3", "--method", "fast"][..],
            &no_daemon,
        ]
        .concat(),
    );
    assert_eq!(code, Some(2));
    assert!(err.contains("constant-period, bounded-error"), "{err}");
}

#[test]
fn run_and_plan_path_refuse_dev_zero_at_once_instead_of_reading_it_forever() {
    let config = concat!(env!("CARGO_MANIFEST_DIR"), "/config/linterpd.toml");
    for args in [
        vec!["run", "/dev/zero", "--socket", "/nonexistent/api.sock"],
        vec!["plan", "--config", config, "--path", "/dev/zero"],
    ] {
        let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
        command.args(&args).env_remove("LINTERPD_SOCKET");
        // Before the fix it read /dev/zero until memory ran out: killed (and failed) if it
        // does not end by itself.
        let done = Spawned::spawn("linterpd", command).finish(common::serve::READY);
        assert_eq!(done.status.code(), Some(2), "{args:?}: {}", done.describe());
        assert!(done.stdout.is_empty(), "{}", done.describe());
        assert!(
            done.stderr
                .contains("/dev/zero is not a regular file (a character device)")
                && done.stderr.contains("at most 1048576 bytes (1 MiB)"),
            "{args:?}: {}",
            done.describe()
        );
    }
}

#[test]
fn check_config_summarises_a_good_file_and_names_the_line_of_a_bad_one() {
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/config/linterpd.toml");
    let (code, out, err) = linterpd(&["check-config", "--config", shipped]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("press-loader (cylindrical)") && out.contains("MEWTOCOL-COM on serial"),
        "{out}"
    );
    assert!(!out.contains("not read back"), "{out}");
    let unverified =
        std::env::temp_dir().join(format!("linterpd-no-read-back-{}.toml", std::process::id()));
    let text = std::fs::read_to_string(shipped)
        .unwrap()
        .replace("read_back = true", "read_back = false");
    std::fs::write(&unverified, text).unwrap();
    let (code, out, err) = linterpd(&["check-config", "--config", unverified.to_str().unwrap()]);
    let _ = std::fs::remove_file(&unverified);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("uploads not read back (read_back = false)"),
        "{out}"
    );
    let (code, out, err) = linterpd(&["check-config", "--config", shipped, "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(doc["robots"][0]["name"], "press-loader");
    assert_eq!(doc["robots"][0]["joints"][2]["name"], "d3");
    let bad = std::env::temp_dir().join(format!("linterpd-bad-{}.toml", std::process::id()));
    let text = std::fs::read_to_string(shipped)
        .unwrap()
        .replace("max_freq_hz = 20000", "max_freq_hz = 200000");
    std::fs::write(&bad, text).unwrap();
    let (code, out, err) = linterpd(&["check-config", "--config", bad.to_str().unwrap()]);
    let _ = std::fs::remove_file(&bad);
    assert_eq!(code, Some(2));
    assert!(out.is_empty());
    assert!(
        err.contains("config line")
            && err.contains("max_freq_hz = 200000")
            && err.contains("20000 Hz"),
        "{err}"
    );
}

#[test]
fn check_config_refuses_a_socket_mode_that_lets_every_user_move_the_robot() {
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/config/linterpd.toml");
    let open = std::env::temp_dir().join(format!("linterpd-0777-{}.toml", std::process::id()));
    let text = std::fs::read_to_string(shipped).unwrap() + "\n[daemon]\nsocket_mode = \"0777\"\n";
    let line = text.lines().count();
    std::fs::write(&open, text).unwrap();
    let (code, out, err) = linterpd(&["check-config", "--config", open.to_str().unwrap()]);
    let _ = std::fs::remove_file(&open);
    assert_eq!(code, Some(2), "{out}{err}");
    assert!(out.is_empty(), "{out}");
    assert!(
        err.contains(&format!(
            "config line {line}: daemon.socket_mode = \"0777\": lets every user of the machine \
             move the robot"
        )) && err.contains("at most 0770"),
        "{err}"
    );
}

#[test]
fn version_names_the_commit_it_was_built_from() {
    let (code, out, err) = linterpd(&["--version"]);
    assert_eq!(code, Some(0), "{err}");
    let commit = out
        .trim()
        .strip_prefix(concat!("linterpd ", env!("CARGO_PKG_VERSION"), " (commit "))
        .and_then(|rest| rest.strip_suffix(')'))
        .unwrap_or_else(|| panic!("{out}"));
    assert!(
        commit == "unknown" || (commit.len() >= 7 && commit.chars().all(|c| c.is_ascii_hexdigit())),
        "{out}"
    );
}

/// Runs linterpd with its stdout a pipe whose reader has already gone, as in
/// `linterpd plan ... | head -1` once head has its line.
fn into_closed_pipe(args: &[&str]) -> (Option<i32>, String) {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(args)
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn output_into_a_closed_pipe_ends_quietly_with_0() {
    for format in ["text", "json", "csv"] {
        let args = [&["plan"][..], &SEED, &["--format", format]].concat();
        assert_eq!(
            into_closed_pipe(&args),
            (Some(0), String::new()),
            "{format}"
        );
    }
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/config/linterpd.toml");
    for args in [
        vec!["check-config", "--config", shipped],
        vec!["completions", "bash"],
        vec!["man"],
    ] {
        assert_eq!(
            into_closed_pipe(&args),
            (Some(0), String::new()),
            "{args:?}"
        );
    }
}

#[test]
fn pallet_show_lists_the_shipped_palletisers_96_slots_and_draws_its_four_layers() {
    let example = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/examples/palletiser.toml"
    );
    let svg = std::env::temp_dir().join(format!("linterpd-pallet-show-{}.svg", std::process::id()));
    let svg_arg = svg.to_str().unwrap();
    let (code, out, err) = linterpd(&[
        "pallet", "show", "out", "--config", example, "--svg", svg_arg,
    ]);
    assert_eq!(code, Some(0), "{err}");
    let mut lines = out.lines();
    assert_eq!(
        lines.next(),
        Some("pallet \"out\" of robot press-loader: 96 slots in 4 layers")
    );
    let rows: Vec<Vec<&str>> = lines
        .skip(1)
        .map(|l| l.split_whitespace().collect())
        .filter(|f: &Vec<&str>| f.len() == 8 && f[0].parse::<u32>().is_ok())
        .collect();
    assert_eq!(rows.len(), 96, "{out}");
    // Slot 0: the frame's origin (-270, 750, 0) plus origin_mm (0, 0, -40), by hand.
    assert_eq!(
        &rows[0][..],
        ["0", "1", "1", "1", "-270.0", "750.0", "-40.0", "0.0"]
    );
    // Every layer 90 mm above the one below; 24 slots each.
    for layer in 1..=4 {
        let on: Vec<&Vec<&str>> = rows.iter().filter(|r| r[1] == layer.to_string()).collect();
        assert_eq!(on.len(), 24, "layer {layer}");
        let z = f64::from(layer - 1) * 90.0 - 40.0;
        assert!(
            on.iter()
                .all(|r| (r[6].parse::<f64>().unwrap() - z).abs() < 1e-9),
            "layer {layer}"
        );
    }
    assert!(out.contains("between layers: slip-sheet"), "{out}");
    assert!(
        out.contains("when full: signal pallet_full, wait for pallet_empty, call change-pallet"),
        "{out}"
    );
    let drawn = std::fs::read_to_string(&svg).unwrap();
    let _ = std::fs::remove_file(&svg);
    assert!(drawn.starts_with("<svg"), "{drawn}");
    assert_eq!(drawn.matches("<g transform").count(), 4);

    let (code, out, err) = linterpd(&["pallet", "show", "in", "--config", example]);
    assert_eq!(code, Some(2), "{out}");
    assert!(
        err.contains("robot press-loader has no pallet \"in\"; it has out"),
        "{err}"
    );
}
