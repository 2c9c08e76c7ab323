//! The daemon's CLI when there is no daemon, and `check-config`, which needs none.

use std::process::Command;

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
    for args in [vec!["status"], vec!["stop"], vec!["move", "--to", "1,2,3"]] {
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
