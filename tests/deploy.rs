//! The deployment side: systemd notification as systemd sees it, the shipped unit and sysusers
//! file checked by systemd's own tools, and the PLC reference program against CONTRACT.md.
//!
//! Notification reads the process environment, and tests in one process share it, so the
//! notifying side runs in a child process: this test binary re-run on [`notify_child`] with its
//! own environment. No test here changes the environment of the test process.

mod common;

use std::collections::BTreeSet;
use std::io::ErrorKind;
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::process::TempDir;
use linterpd::daemon::notify::Notifier;

const MANIFEST_DIR: &str = env!("CARGO_MANIFEST_DIR");

fn repo_file(relative: &str) -> PathBuf {
    Path::new(MANIFEST_DIR).join(relative)
}

fn read(relative: &str) -> String {
    let path = repo_file(relative);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn describe(output: &Output) -> String {
    format!(
        "exit {}\n--- stdout\n{}--- stderr\n{}",
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

// ------------------------------------------------------------------------------------------------
// systemd notification

/// The notifying side of the notify tests; does nothing useful when run on its own.
#[test]
#[ignore = "run as a child process by the notify_* tests, with its own environment"]
fn notify_child() {
    let n = Notifier::from_env();
    let interval = n
        .watchdog_interval()
        .map_or_else(|| "none".to_owned(), |d| d.as_millis().to_string());
    println!("child: enabled={} watchdog_ms={interval}", n.enabled());
    n.ready().expect("READY=1");
    n.status("running move 7\nof 9").expect("STATUS=");
    n.watchdog().expect("WATCHDOG=1");
    n.stopping().expect("STOPPING=1");
}

/// Runs [`notify_child`] in a child process with `env` set (a `None` value removes the variable)
/// and returns its `child: ...` line.
fn run_notify_child(env: &[(&str, Option<&str>)]) -> String {
    let mut command = Command::new(std::env::current_exe().expect("test binary path"));
    command.args([
        "notify_child",
        "--exact",
        "--ignored",
        "--nocapture",
        "--test-threads=1",
    ]);
    for var in ["NOTIFY_SOCKET", "WATCHDOG_USEC", "WATCHDOG_PID"] {
        command.env_remove(var);
    }
    for (key, value) in env {
        match value {
            Some(value) => command.env(key, value),
            None => command.env_remove(key),
        };
    }
    let output = command.output().expect("could not re-run the test binary");
    assert!(output.status.success(), "{}", describe(&output));
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .find_map(|l| l.find("child: ").map(|at| l[at..].to_owned()))
        .unwrap_or_else(|| panic!("no child line\n{}", describe(&output)))
}

/// Every datagram waiting on `socket`, in order; the child has exited, so nothing more comes.
fn datagrams(socket: &UnixDatagram) -> Vec<String> {
    socket.set_nonblocking(true).unwrap();
    let mut out = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        match socket.recv(&mut buf) {
            Ok(n) => out.push(String::from_utf8_lossy(&buf[..n]).into_owned()),
            Err(e) if e.kind() == ErrorKind::WouldBlock => return out,
            Err(e) => panic!("recv: {e}"),
        }
    }
}

#[test]
fn notify_sends_ready_status_watchdog_stopping_as_single_datagrams() {
    let dir = TempDir::new("notify");
    let path = dir.path().join("notify.sock");
    let socket = UnixDatagram::bind(&path).unwrap();
    let line = run_notify_child(&[
        ("NOTIFY_SOCKET", Some(path.to_str().unwrap())),
        ("WATCHDOG_USEC", Some("10000000")),
    ]);
    // WatchdogSec=10s: ping every 5 s.
    assert_eq!(line, "child: enabled=true watchdog_ms=5000");
    assert_eq!(
        datagrams(&socket),
        [
            "READY=1\n",
            "STATUS=running move 7 of 9\n",
            "WATCHDOG=1\n",
            "STOPPING=1\n"
        ]
    );
}

#[test]
fn notify_ignores_a_watchdog_meant_for_another_process() {
    let dir = TempDir::new("notify-pid");
    let path = dir.path().join("notify.sock");
    let socket = UnixDatagram::bind(&path).unwrap();
    // PID 1 is never the test's child.
    let line = run_notify_child(&[
        ("NOTIFY_SOCKET", Some(path.to_str().unwrap())),
        ("WATCHDOG_USEC", Some("10000000")),
        ("WATCHDOG_PID", Some("1")),
    ]);
    assert_eq!(line, "child: enabled=true watchdog_ms=none");
    assert_eq!(datagrams(&socket).len(), 4);
}

#[test]
fn notify_is_a_no_op_without_notify_socket() {
    // A watchdog without a socket to ping is no watchdog.
    let line = run_notify_child(&[("WATCHDOG_USEC", Some("10000000"))]);
    assert_eq!(line, "child: enabled=false watchdog_ms=none");
}

// ------------------------------------------------------------------------------------------------
// The systemd unit

const UNIT: &str = "deploy/linterpd.service";
const EXEC_START: &str =
    "ExecStart=/usr/local/bin/linterpd serve --config /etc/linterpd/linterpd.toml";

/// `systemd-analyze verify` on `unit_text`, saved as `linterpd.service` in a temp dir. Its
/// warnings go to stderr with exit status 0, so any stderr line counts as a failure.
fn systemd_analyze_verify(unit_text: &str) -> Result<(), String> {
    let dir = TempDir::new("unit");
    let path = dir.path().join("linterpd.service");
    std::fs::write(&path, unit_text).unwrap();
    let output = Command::new("systemd-analyze")
        .arg("verify")
        .arg(&path)
        .output()
        .unwrap_or_else(|e| {
            panic!("systemd-analyze is required to check {UNIT} (.ci/run installs systemd): {e}")
        });
    if output.status.success() && output.stderr.is_empty() {
        Ok(())
    } else {
        Err(describe(&output))
    }
}

/// The shipped unit with `ExecStart=` pointing at the binary this build made: verify checks that
/// the command exists and is executable.
fn unit_for_verify() -> String {
    let unit = read(UNIT);
    assert_eq!(
        unit.lines().filter(|l| *l == EXEC_START).count(),
        1,
        "{UNIT} must have exactly one line `{EXEC_START}`"
    );
    unit.replace(
        "ExecStart=/usr/local/bin/linterpd ",
        &format!("ExecStart={} ", env!("CARGO_BIN_EXE_linterpd")),
    )
}

#[test]
fn unit_passes_systemd_analyze_verify_without_a_warning() {
    if let Err(report) = systemd_analyze_verify(&unit_for_verify()) {
        panic!("systemd-analyze verify {UNIT}:\n{report}");
    }
}

#[test]
fn verify_check_catches_a_bad_line() {
    // The check above is only worth something if a real mistake fails it.
    for bad in [
        "UMask=0999",
        "DeviceAllow=char-ttyS rwz",
        "Type=notfy",
        "ProtectSystem=very",
    ] {
        let unit = unit_for_verify().replace("[Service]\n", &format!("[Service]\n{bad}\n"));
        assert!(
            systemd_analyze_verify(&unit).is_err(),
            "`{bad}` passed verify"
        );
    }
}

/// `(section, key, value)` for every assignment in a unit file.
fn directives(unit: &str) -> Vec<(String, String, String)> {
    let mut section = String::new();
    let mut out = Vec::new();
    for line in unit.lines().map(str::trim) {
        if line.is_empty() || line.starts_with(['#', ';']) {
            continue;
        }
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            name.clone_into(&mut section);
        } else if let Some((key, value)) = line.split_once('=') {
            out.push((section.clone(), key.to_owned(), value.to_owned()));
        }
    }
    out
}

#[test]
fn unit_runs_as_linterpd_with_dialout_and_the_expected_hardening() {
    // Verify does not check users (and this machine has no linterpd user), so these are checked
    // here, with the rest of what the unit promises.
    let have: BTreeSet<(String, String, String)> = directives(&read(UNIT)).into_iter().collect();
    let service = [
        ("Type", "notify"),
        ("WatchdogSec", "10s"),
        ("Restart", "on-failure"),
        ("User", "linterpd"),
        ("Group", "linterpd"),
        ("SupplementaryGroups", "dialout"),
        ("RuntimeDirectory", "linterpd"),
        ("RuntimeDirectoryMode", "0750"),
        ("UMask", "0007"),
        ("ProtectSystem", "strict"),
        ("ProtectHome", "yes"),
        ("PrivateTmp", "yes"),
        ("NoNewPrivileges", "yes"),
        ("PrivateDevices", "no"),
        ("DevicePolicy", "closed"),
        ("DeviceAllow", "char-ttyS rw"),
        ("DeviceAllow", "char-ttyUSB rw"),
        ("DeviceAllow", "char-ttyACM rw"),
        ("ProtectKernelTunables", "yes"),
        ("ProtectKernelModules", "yes"),
        ("ProtectKernelLogs", "yes"),
        ("ProtectControlGroups", "yes"),
        ("ProtectClock", "yes"),
        ("ProtectHostname", "yes"),
        ("RestrictAddressFamilies", "AF_UNIX AF_INET AF_INET6"),
        ("RestrictNamespaces", "yes"),
        ("RestrictRealtime", "yes"),
        ("RestrictSUIDSGID", "yes"),
        ("LockPersonality", "yes"),
        ("MemoryDenyWriteExecute", "yes"),
        ("SystemCallArchitectures", "native"),
        ("SystemCallFilter", "@system-service"),
        ("CapabilityBoundingSet", ""),
        ("ReadOnlyPaths", "/etc/linterpd"),
    ];
    let missing: Vec<String> = service
        .iter()
        .filter(|(k, v)| !have.contains(&("Service".into(), (*k).into(), (*v).into())))
        .map(|(k, v)| format!("{k}={v}"))
        .collect();
    assert!(missing.is_empty(), "{UNIT} [Service] lacks {missing:?}");
    let device_allows = have.iter().filter(|(_, k, _)| k == "DeviceAllow").count();
    assert_eq!(device_allows, 3, "serial ports only");
}

#[test]
fn unit_comments_every_hardening_group() {
    // An admin reading the unit learns why each setting is there: no directive in [Service]
    // without a comment somewhere in the five lines above it.
    let unit = read(UNIT);
    let lines: Vec<&str> = unit.lines().collect();
    let mut uncommented = Vec::new();
    let mut in_service = false;
    for (i, line) in lines.iter().enumerate() {
        if line.starts_with('[') {
            in_service = *line == "[Service]";
        } else if in_service && line.contains('=') && !line.starts_with('#') {
            let above = &lines[i.saturating_sub(5)..i];
            if !above.iter().any(|l| l.starts_with('#')) {
                uncommented.push(*line);
            }
        }
    }
    assert!(uncommented.is_empty(), "uncommented: {uncommented:?}");
}

#[test]
fn sysusers_creates_linterpd_in_dialout() {
    let sysusers = read("deploy/linterpd.sysusers");
    let entries: Vec<Vec<&str>> = sysusers
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert!(entries.iter().any(|e| e[..2] == ["u", "linterpd"]));
    assert!(
        entries
            .iter()
            .any(|e| e[..] == ["m", "linterpd", "dialout"])
    );
    // systemd's own parser, on an empty root so nothing on this machine changes.
    let root = TempDir::new("sysusers-root");
    std::fs::create_dir(root.path().join("etc")).unwrap();
    let output = Command::new("systemd-sysusers")
        .arg(format!("--root={}", root.path().display()))
        .arg("--dry-run")
        .arg(repo_file("deploy/linterpd.sysusers"))
        .output()
        .unwrap_or_else(|e| panic!("systemd-sysusers is required (.ci/run installs systemd): {e}"));
    let text = describe(&output);
    assert!(output.status.success(), "{text}");
    assert!(!text.contains("Failed"), "{text}");
    assert!(text.contains("Creating user 'linterpd'"), "{text}");
}

// ------------------------------------------------------------------------------------------------
// The PLC side

const LISTING: &str = "deploy/plc/linterpd-contract.fpwin.txt";

/// The listing's instruction lines: what is left of each line after its `;` comment, with runs
/// of blanks made one space.
fn instructions(listing: &str) -> Vec<String> {
    listing
        .lines()
        .map(|l| {
            l.split(';')
                .next()
                .unwrap_or("")
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ")
        })
        .filter(|l| !l.is_empty())
        .collect()
}

#[test]
fn plc_listing_stops_every_channel_through_dt90052() {
    let code = instructions(&read(LISTING));
    for channel in 0..4 {
        let stop = format!("F0 MV H{channel}108, DT90052");
        assert!(
            code.contains(&stop),
            "{LISTING} never stops channel {channel} with `{stop}`"
        );
        let f174 = format!("F174 SP0H I0DT0, K{channel}");
        assert!(code.contains(&f174), "{LISTING} never runs `{f174}`");
    }
}

#[test]
fn plc_listing_ends_its_main_program_before_its_subroutine() {
    let code = instructions(&read(LISTING));
    let at = |needle: &str| code.iter().position(|l| l == needle);
    let ed = at("ED").expect("no ED");
    assert!(
        at("SUB 1").is_some_and(|sub| sub > ed),
        "SUB 1 must follow ED"
    );
    assert_eq!(code.last().map(String::as_str), Some("RET"));
    // The first scan clears the command word: no stale start after a power loss.
    assert!(code.contains(&"F0 MV K0, DT1032".to_owned()));
}

#[test]
fn plc_listing_uses_the_default_contract_addresses() {
    let code = instructions(&read(LISTING)).join("\n");
    // Magic and version into DT1000/DT1001, the command word DT1032, bank 0 channel 0's area.
    for needle in [
        "H4C49", "DT1000", "DT1001", "DT1002", "DT1032", "DT1033", "2000",
    ] {
        assert!(code.contains(needle), "{LISTING} lacks {needle}");
    }
}

#[test]
fn plc_listing_comments_every_block() {
    // A block starts after a blank line; its first line is a comment.
    let listing = read(LISTING);
    let mut previous_blank = true;
    for (i, line) in listing.lines().enumerate() {
        let trimmed = line.trim();
        if previous_blank && !trimmed.is_empty() {
            assert!(
                trimmed.starts_with(';'),
                "{LISTING}:{}: a block must open with a comment: {line}",
                i + 1
            );
        }
        previous_blank = trimmed.is_empty();
    }
}

#[test]
fn plc_readme_lists_every_unverified_address_of_the_listing() {
    let listing = read(LISTING);
    let readme = read("deploy/plc/README.md");
    let unverified: BTreeSet<String> = listing
        .lines()
        .filter(|l| l.contains("UNVERIFIED"))
        .flat_map(|l| {
            l.split(|c: char| !c.is_ascii_alphanumeric())
                .filter(|w| is_special_address(w))
                .map(str::to_owned)
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        !unverified.is_empty(),
        "{LISTING} marks no special address UNVERIFIED"
    );
    for address in &unverified {
        assert!(
            readme.contains(address.as_str()),
            "deploy/plc/README.md does not list {address}, which {LISTING} marks UNVERIFIED"
        );
    }
}

/// A special relay (`R9xxx`) or special data register (`DT9xxxx`).
fn is_special_address(word: &str) -> bool {
    let digits = |s: &str, n: usize| s.len() == n && s.bytes().all(|b| b.is_ascii_hexdigit());
    word.strip_prefix("DT9").is_some_and(|d| digits(d, 4))
        || word.strip_prefix("R9").is_some_and(|d| digits(d, 3))
}

#[test]
fn readme_has_install_and_plc_sections() {
    let readme = read("README.md");
    for needle in [
        "## Installing on a line PC",
        "## The PLC side",
        "deploy/plc/README.md",
        "systemctl enable --now linterpd",
        "journalctl -u linterpd -f",
    ] {
        assert!(readme.contains(needle), "README.md lacks {needle:?}");
    }
}
