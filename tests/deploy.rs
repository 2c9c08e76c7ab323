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
const EXEC_START: &str = "ExecStart=/usr/bin/linterpd serve --config /etc/linterpd/linterpd.toml";

/// `systemd-analyze verify` on `unit_text`, saved as `linterpd.service` in a temp dir. Its
/// warnings go to stderr with exit status 0, so any stderr line counts as a failure. The man
/// pages `Documentation=` names are the package's, not on this machine: `--man=no`
/// (`unit_documents_its_man_pages_and_the_installed_docs` checks them against the package).
fn systemd_analyze_verify(unit_text: &str) -> Result<(), String> {
    let dir = TempDir::new("unit");
    let path = dir.path().join("linterpd.service");
    std::fs::write(&path, unit_text).unwrap();
    let output = Command::new("systemd-analyze")
        .args(["verify", "--man=no"])
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
        "ExecStart=/usr/bin/linterpd ",
        &format!("ExecStart={} ", env!("CARGO_BIN_EXE_linterpd")),
    )
}

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs systemd's tools: cargo test --features third-party-peers (.ci/run)"
)]
fn unit_passes_systemd_analyze_verify_without_a_warning() {
    if let Err(report) = systemd_analyze_verify(&unit_for_verify()) {
        panic!("systemd-analyze verify {UNIT}:\n{report}");
    }
}

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs systemd's tools: cargo test --features third-party-peers (.ci/run)"
)]
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

/// The most `systemd-analyze security` may score the unit (issue 9: at most 1.5).
const MAX_EXPOSURE: f64 = 1.5;

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs systemd's tools: cargo test --features third-party-peers (.ci/run)"
)]
fn unit_exposure_is_at_most_one_and_a_half() {
    let output = Command::new("systemd-analyze")
        .args(["security", "--offline=yes", "--no-pager"])
        .arg(repo_file(UNIT))
        .output()
        .unwrap_or_else(|e| {
            panic!("systemd-analyze is required to score {UNIT} (.ci/run installs systemd): {e}")
        });
    let text = String::from_utf8_lossy(&output.stdout);
    // "→ Overall exposure level for linterpd.service: 1.5 OK 🙂"
    let exposure: f64 = text
        .lines()
        .find_map(|l| l.split_once("Overall exposure level for linterpd.service: "))
        .and_then(|(_, rest)| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no exposure level in\n{}", describe(&output)));
    assert!(
        exposure <= MAX_EXPOSURE,
        "{UNIT} scores {exposure}, more than {MAX_EXPOSURE}:\n{text}"
    );
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
        ("StateDirectory", "linterpd"),
        ("StateDirectoryMode", "0750"),
        ("UMask", "0027"),
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
        ("SystemCallFilter", "~@privileged @resources"),
        ("RestartPreventExitStatus", "2"),
        ("ProtectProc", "invisible"),
        ("ProcSubset", "pid"),
        ("RemoveIPC", "yes"),
        ("PrivateMounts", "yes"),
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
fn systemctl_reload_exists_and_sends_the_daemon_sighup() {
    // Issue 47: the unit had no ExecReload=, so `systemctl reload linterpd` was refused.
    let reloads: Vec<String> = directives(&read(UNIT))
        .into_iter()
        .filter(|(section, key, _)| section == "Service" && key == "ExecReload")
        .map(|(_, _, value)| value)
        .collect();
    assert_eq!(reloads, ["/bin/kill -HUP $MAINPID"], "{UNIT}");
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
}

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs systemd's tools: cargo test --features third-party-peers (.ci/run)"
)]
fn systemd_sysusers_accepts_the_sysusers_file() {
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
const PLC_README: &str = "deploy/plc/README.md";

// The listing's own names that these checks follow (its header lists every one).
/// The command word as the scan took it.
const COMMAND_OF_SCAN: &str = "DT1106";
/// The program's state, fault and latched seq.
const STATE: &str = "DT1100";
const FAULT: &str = "DT1101";
const SEQ: &str = "DT1102";
/// Start to act on in this scan; the e-stop input open; start to act on with the e-stop closed;
/// start goes ahead.
const START_TO_ACT: &str = "R44";
const ESTOP_OPEN: &str = "R46";
const START_CHECKED: &str = "R47";
const START_GOES: &str = "R42";
/// The program's homed bit (ready bit 0).
const HOMED: &str = "R22";
/// TABLE MODE: the constant's word and the relay that selects the fixed buffers.
const TABLE_MODE: &str = "DT1104";
const BUFFER_MODE: &str = "R20";

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

fn listing_code() -> Vec<String> {
    instructions(&read(LISTING))
}

/// One rung: its contact lines (`ST..`, `AN..`, `OR..`, `ANS`, `ORS`, `DF`), then what they
/// drive.
#[derive(Debug, Default)]
struct Rung {
    conditions: Vec<String>,
    outputs: Vec<String>,
}

impl Rung {
    fn has_condition(&self, line: &str) -> bool {
        self.conditions.iter().any(|c| c == line)
    }

    fn has_output(&self, line: &str) -> bool {
        self.outputs.iter().any(|o| o == line)
    }

    fn first_condition(&self) -> &str {
        self.conditions.first().map_or("", String::as_str)
    }
}

fn is_condition(line: &str) -> bool {
    let op = line.split(' ').next().unwrap_or("");
    op.starts_with("ST") || op.starts_with("AN") || op.starts_with("OR") || op == "DF"
}

/// The code cut into rungs: a contact line after an output starts the next rung.
fn rungs(code: &[String]) -> Vec<Rung> {
    let mut out = Vec::new();
    let mut rung = Rung::default();
    for line in code {
        if is_condition(line) {
            if !rung.outputs.is_empty() {
                out.push(std::mem::take(&mut rung));
            }
            rung.conditions.push(line.clone());
        } else {
            rung.outputs.push(line.clone());
        }
    }
    out.push(rung);
    out
}

/// The rung driving `output`; panics unless exactly one does.
fn rung_with<'a>(rungs: &'a [Rung], output: &str) -> &'a Rung {
    let found: Vec<&Rung> = rungs.iter().filter(|r| r.has_output(output)).collect();
    assert_eq!(
        found.len(),
        1,
        "{LISTING}: `{output}` in {} rungs",
        found.len()
    );
    found[0]
}

/// An F instruction's number and operands: `F0 MV K0, DT1032` gives `F0` and `[K0, DT1032]`.
fn f_instruction(line: &str) -> Option<(&str, Vec<&str>)> {
    let mut words = line.splitn(3, ' ');
    let op = words.next()?;
    if !op.starts_with('F') || !op[1..].bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let _name = words.next()?;
    Some((op, words.next().unwrap_or("").split(", ").collect()))
}

fn dt(operand: &str) -> Option<u32> {
    operand.strip_prefix("DT")?.parse().ok()
}

/// Every DT word the code writes through a plain (not index-modified) operand.
fn written_words(code: &[String]) -> BTreeSet<u32> {
    let mut out = BTreeSet::new();
    for (op, args) in code.iter().filter_map(|l| f_instruction(l)) {
        let dest = |i: usize| args.get(i).and_then(|a| dt(a));
        let (start, words) = match op {
            "F0" => (dest(1), 1),
            // F65 WAN S1, S2, D (16-bit AND).
            "F65" => (dest(2).or_else(|| dest(1)), 1),
            "F1" => (dest(1), 2),
            "F22" | "F27" => (dest(2), 1),
            "F35" => (dest(0), 1),
            "F10" => match (dest(0), dest(1)) {
                (Some(s1), Some(s2)) => (dest(2), s2 - s1 + 1),
                _ => (dest(2), 1),
            },
            "F11" => match (dest(1), dest(2)) {
                (Some(d1), Some(d2)) => (Some(d1), d2 - d1 + 1),
                _ => (None, 0),
            },
            _ => (None, 0),
        };
        if let Some(start) = start {
            out.extend(start..start + words);
        }
    }
    out
}

/// Every DT word the code names, 32-bit operands and block ranges counted whole.
fn mentioned_words(code: &[String]) -> BTreeSet<u32> {
    let mut out = BTreeSet::new();
    for line in code {
        let op = line.split(' ').next().unwrap_or("");
        let dint = op == "F1" || ["STD", "AND", "ORD"].iter().any(|p| op.starts_with(p));
        let operands: Vec<u32> = line.split([' ', ',']).filter_map(dt).collect();
        for &w in &operands {
            out.insert(w);
            if dint {
                out.insert(w + 1);
            }
        }
        if op == "F10" && operands.len() == 3 {
            out.extend(operands[0]..=operands[1]);
        }
    }
    out
}

/// What the code copies into the DINT at `DT{dest}` (the first such `F1 DMV`).
fn dmv_source(code: &[String], dest: u32) -> &str {
    code.iter()
        .find_map(|l| {
            l.strip_prefix("F1 DMV ")?
                .strip_suffix(&format!(", DT{dest}"))
        })
        .unwrap_or_else(|| panic!("{LISTING}: nothing copied into DT{dest}"))
}

/// A special relay (`R9xxx`) or special data register (`DT9xxxx`).
fn is_special_address(word: &str) -> bool {
    let digits = |s: &str, n: usize| s.len() == n && s.bytes().all(|b| b.is_ascii_hexdigit());
    word.strip_prefix("DT9").is_some_and(|d| digits(d, 4))
        || word.strip_prefix("R9").is_some_and(|d| digits(d, 3))
}

fn special_addresses<'a>(lines: impl Iterator<Item = &'a str>) -> BTreeSet<String> {
    lines
        .flat_map(|l| {
            l.split(|c: char| !c.is_ascii_alphanumeric())
                .filter(|w| is_special_address(w))
                .map(str::to_owned)
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn plc_listing_speaks_contract_version_3_at_the_default_addresses() {
    let code = listing_code();
    for line in ["F0 MV H4C49, DT1000", "F0 MV K3, DT1001"] {
        assert!(code.contains(&line.to_owned()), "{LISTING} lacks `{line}`");
    }
    let written = written_words(&code);
    let missing: Vec<u32> = (1000..=1025).filter(|w| !written.contains(w)).collect();
    assert!(
        missing.is_empty(),
        "status words never written: {missing:?}"
    );
    // The command block is linterpd's: the program reads all of it and writes back only the
    // command word (0 once acted on) and the host word (0 in the first scan).
    let mentioned = mentioned_words(&code);
    let unread: Vec<u32> = (1032..=1056).filter(|w| !mentioned.contains(w)).collect();
    assert!(
        unread.is_empty(),
        "command block words never used: {unread:?}"
    );
    let overwritten: Vec<u32> = (1032..=1056).filter(|w| written.contains(w)).collect();
    assert_eq!(
        overwritten,
        [1032, 1048],
        "the program writes linterpd's words"
    );
    // Nothing writes the table areas (DT2000 + bank * 8000 + channel * 2000, 2000 words each).
    let into_tables: Vec<u32> = (2000..18_000).filter(|w| written.contains(w)).collect();
    assert!(
        into_tables.is_empty(),
        "writes into the table areas: {into_tables:?}"
    );
    let joined = code.join("\n");
    for base in ["K2000, DT1116", "K10000, DT1116", "DT1116, K2000, DT1117"] {
        assert!(
            joined.contains(base),
            "{LISTING} lacks the area arithmetic `{base}`"
        );
    }
    // The host word is echoed and the waiting start shown.
    for line in ["F0 MV DT1048, DT1020", "F0 MV DT1033, DT1021"] {
        assert!(code.contains(&line.to_owned()), "{LISTING} lacks `{line}`");
    }
}

#[test]
fn plc_listing_first_scan_clears_state_seq_command_both_hosts_and_the_homed_bit() {
    let code = listing_code();
    let rungs = rungs(&code);
    let first = &rungs[0];
    assert_eq!(
        first.conditions,
        ["ST R9013"],
        "the first rung must be the first scan's"
    );
    let cleared = written_words(&first.outputs);
    for (word, what) in [
        (1032, "command"),
        (1048, "command block host"),
        (1100, "state"),
        (1101, "fault"),
        (1102, "seq"),
    ] {
        assert!(
            cleared.contains(&word),
            "the first scan leaves {what} DT{word}"
        );
    }
    assert!(first.has_output(&format!("RST {HOMED}")));
    // The homed bit is the ready word's bit 0, and the status host is the command host's copy.
    assert!(
        rungs
            .iter()
            .any(|r| r.conditions == [format!("ST {HOMED}")] && r.has_output("OT R200"))
    );
    assert!(code.contains(&"F0 MV WR20, DT1007".to_owned()));
    // The scan takes the command word after the first-scan rung has cleared it.
    assert!(rungs[1].has_output(&format!("F0 MV DT1032, {COMMAND_OF_SCAN}")));
}

#[test]
fn plc_listing_ignores_a_repeated_seq_and_checks_starts_in_contract_order() {
    let code = listing_code();
    let rungs = rungs(&code);
    let start = format!("ST= {COMMAND_OF_SCAN}, K1");
    assert!(
        rungs.iter().any(
            |r| r.conditions == [start.clone(), format!("AN= DT1033, {SEQ}")]
                && r.outputs == ["F0 MV K0, DT1032"]
        ),
        "no rung drops a start whose seq is the latched one"
    );
    let act = rung_with(&rungs, &format!("OT {START_TO_ACT}"));
    assert!(act.has_condition(&format!("AN<> DT1033, {SEQ}")));
    // Refusals: the first failing check wins, in the order 1, 6, 2, 5, 4; none touches seq.
    let refusals: Vec<&Rung> = rungs
        .iter()
        .filter(|r| {
            r.first_condition() == format!("ST {START_CHECKED}")
                && r.outputs.iter().any(|o| o.ends_with(&format!(", {FAULT}")))
        })
        .collect();
    let mut faults = Vec::new();
    let mut earlier: Vec<String> = Vec::new();
    for r in &refusals {
        let fault = r
            .outputs
            .iter()
            .find_map(|o| {
                o.strip_prefix("F0 MV K")?
                    .strip_suffix(&format!(", {FAULT}"))
            })
            .expect("a fault value");
        faults.push(fault.to_owned());
        let positive: Vec<&String> = r.conditions[1..]
            .iter()
            .filter(|c| c.starts_with("AN "))
            .collect();
        assert_eq!(positive.len(), 1, "fault {fault}: {:?}", r.conditions);
        for e in &earlier {
            assert!(
                r.has_condition(&format!("AN/ {e}")),
                "fault {fault} is not behind the earlier check {e}"
            );
        }
        assert!(r.has_output(&format!("F0 MV K4, {STATE}")));
        assert!(r.has_output("F0 MV K0, DT1032"));
        assert!(
            !r.outputs.iter().any(|o| o.contains(SEQ)),
            "fault {fault} sets seq"
        );
        earlier.push(positive[0]["AN ".len()..].to_owned());
    }
    assert_eq!(faults, ["1", "6", "2", "5", "8", "4"]);
    let go = rung_with(&rungs, &format!("OT {START_GOES}"));
    assert_eq!(go.first_condition(), format!("ST {START_CHECKED}"));
    for e in &earlier {
        assert!(
            go.has_condition(&format!("AN/ {e}")),
            "a start goes ahead past {e}"
        );
    }
    // Fault 5 compares every channel's count with from[c], 32 bits, masked or not.
    let from = rung_with(&rungs, &format!("OT {}", earlier[3]));
    for c in 0..4 {
        let cmp = format!("DT{}, DT{}", 1140 + 2 * c, 1040 + 2 * c);
        assert!(
            from.conditions
                .iter()
                .any(|l| l.ends_with(&cmp) && l.contains("D<>")),
            "fault 5 does not compare channel {c}: {:?}",
            from.conditions
        );
    }
    // seq is latched only when the start went ahead.
    let latch = rung_with(&rungs, &format!("F0 MV DT1033, {SEQ}"));
    assert_eq!(latch.first_condition(), format!("ST {START_GOES}"));
}

#[test]
fn plc_listing_refuses_a_start_while_the_estop_input_is_open() {
    let code = listing_code();
    let rungs = rungs(&code);
    let estop = rung_with(&rungs, &format!("OT {ESTOP_OPEN}"));
    assert_eq!(estop.conditions, ["ST/ X10"]);
    let refused = rungs
        .iter()
        .find(|r| r.conditions == [format!("ST {START_TO_ACT}"), format!("AN {ESTOP_OPEN}")])
        .expect("no rung refuses a start while the e-stop is open");
    assert_eq!(
        refused.outputs,
        [
            format!("F0 MV K3, {STATE}"),
            format!("F0 MV K3, {FAULT}"),
            "F0 MV K0, DT1032".to_owned()
        ]
    );
    let checked = rung_with(&rungs, &format!("OT {START_CHECKED}"));
    assert_eq!(
        checked.conditions,
        [format!("ST {START_TO_ACT}"), format!("AN/ {ESTOP_OPEN}")]
    );
    // Launch relays R70..R73 come only from a start that went ahead or a chain decided with
    // the e-stop closed, and every F174 hangs on its channel's launch relay.
    for c in 0..4 {
        let chain = rung_with(&rungs, &format!("OT R6{c}"));
        assert!(
            chain.has_condition(&format!("AN/ {ESTOP_OPEN}")),
            "channel {c} chains blind"
        );
        for r in rungs.iter().filter(|r| r.has_output(&format!("SET R7{c}"))) {
            assert_eq!(r.first_condition(), format!("ST R6{c}"));
        }
    }
    for r in &rungs {
        for o in &r.outputs {
            if o.ends_with(", WR7") && o != "F0 MV K0, WR7" {
                assert_eq!(r.first_condition(), format!("ST {START_GOES}"), "`{o}`");
            }
            if let Some(("F174", args)) = f_instruction(o) {
                let channel = args[1].trim_start_matches('K');
                assert_eq!(r.first_condition(), format!("ST R7{channel}"), "`{o}`");
            }
            if let Some(("F171", _)) = f_instruction(o) {
                assert!(
                    r.has_condition(&format!("AN/ {ESTOP_OPEN}")),
                    "`{o}` ignores the e-stop"
                );
            }
        }
    }
}

#[test]
fn plc_listing_chains_only_after_busy_was_seen_or_the_last_target_is_reached() {
    let code = listing_code();
    let rungs = rungs(&code);
    assert!(
        code.contains(&"F0 MV WR7, WR8".to_owned()),
        "no memory of last scan's launches"
    );
    for c in 0..4 {
        let busy = format!("R21{c}");
        let seen = format!("R9{c}");
        // The busy image comes straight from a special relay; the seen relay follows it while
        // the channel takes part, and a launch forgets it.
        let image = rung_with(&rungs, &format!("OT {busy}"));
        let flag = image.first_condition().trim_start_matches("ST ");
        assert!(
            is_special_address(flag),
            "channel {c}'s busy image reads {flag}"
        );
        let set_seen = rung_with(&rungs, &format!("SET {seen}"));
        assert_eq!(
            set_seen.conditions,
            [format!("ST {busy}"), format!("AN R16{c}")]
        );
        let forget = rung_with(&rungs, &format!("RST {seen}"));
        assert_eq!(forget.first_condition(), format!("ST R7{c}"));
        // A segment has finished: busy OFF, and seen ON or the count at the last target;
        // never in the scan of a launch or the one after.
        let finished = rung_with(&rungs, &format!("OT R17{c}"));
        for needed in [
            format!("AN/ {busy}"),
            format!("ST {seen}"),
            format!("AN/ R7{c}"),
            format!("AN/ R8{c}"),
        ] {
            assert!(
                finished.has_condition(&needed),
                "channel {c}: no `{needed}`"
            );
        }
        let target = format!("ORD= DT{}, I3DT{}", 1140 + 2 * c, 1200 + 16 * c);
        assert!(
            finished.has_condition(&target),
            "channel {c}: no `{target}`"
        );
        let chain = rung_with(&rungs, &format!("OT R6{c}"));
        assert_eq!(chain.first_condition(), format!("ST R17{c}"));
        // The count compared is the same channel's elapsed value the status block reports.
        assert_eq!(
            dmv_source(&code, 1140 + 2 * c),
            dmv_source(&code, 1008 + 2 * c),
            "channel {c}"
        );
    }
}

#[test]
fn plc_listing_runs_f174_on_fixed_buffers_when_table_mode_selects_them() {
    let code = listing_code();
    let rungs = rungs(&code);
    assert!(
        code.contains(&format!("F0 MV K1, {TABLE_MODE}")),
        "TABLE MODE must default to K1, the fixed buffers"
    );
    let mode = rung_with(&rungs, &format!("OT {BUFFER_MODE}"));
    assert_eq!(mode.conditions, [format!("ST= {TABLE_MODE}, K1")]);
    let mut buffers = Vec::new();
    for r in &rungs {
        for o in &r.outputs {
            let Some(("F174", args)) = f_instruction(o) else {
                continue;
            };
            assert!(r.has_condition("DF"), "`{o}` does not run on an edge");
            let launch = r.first_condition().to_owned();
            if args[0].starts_with('I') {
                assert!(
                    r.has_condition(&format!("AN/ {BUFFER_MODE}")),
                    "index-modified `{o}` runs while TABLE MODE selects the buffers"
                );
                continue;
            }
            assert!(
                r.has_condition(&format!("AN {BUFFER_MODE}")),
                "`{o}` outside TABLE MODE 1"
            );
            let buffer = dt(args[0]).expect("F174 on a DT word");
            let filled = rungs.iter().any(|b| {
                b.first_condition() == launch
                    && b.has_condition(&format!("AN {BUFFER_MODE}"))
                    && b.outputs.iter().any(|l| {
                        l.starts_with("F10 BKMV ") && l.ends_with(&format!(", {}", args[0]))
                    })
            });
            assert!(
                filled,
                "nothing copies the segment into {} before `{o}`",
                args[0]
            );
            buffers.push((args[1].to_owned(), buffer));
        }
    }
    buffers.sort();
    let channels: Vec<&str> = buffers.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(channels, ["K0", "K1", "K2", "K3"], "one buffer per channel");
    // A buffer holds a whole segment (up to 1992 words), clear of the tables and of each other.
    for pair in buffers.windows(2) {
        assert!(
            pair[1].1 >= pair[0].1 + 2000,
            "buffers overlap: {buffers:?}"
        );
    }
    for (_, start) in &buffers {
        assert!(
            *start >= 18_000 && start + 2000 <= 32_765,
            "buffer DT{start}"
        );
    }
}

#[test]
fn plc_listing_homes_with_command_4() {
    let listing = read(LISTING);
    let code = instructions(&listing);
    let rungs = rungs(&code);
    let home = format!("ST= {COMMAND_OF_SCAN}, K4");
    assert!(
        rungs.iter().any(|r| r.first_condition() == home),
        "no home command"
    );
    let accept = rung_with(&rungs, &format!("F0 MV K5, {STATE}"));
    for line in [
        format!("RST {HOMED}"),
        "F10 BKMV DT1040, DT1047, DT1150".to_owned(),
        "F0 MV K0, DT1032".to_owned(),
    ] {
        assert!(
            accept.has_output(&line),
            "accepting a home command lacks `{line}`"
        );
    }
    let homed = rung_with(&rungs, &format!("SET {HOMED}"));
    assert_eq!(homed.first_condition(), format!("ST= {STATE}, K5"));
    assert!(homed.has_output(&format!("F0 MV K2, {STATE}")));
    // Fault 7: timeout or failure input, the e-stop while homing, a home command while open.
    let fault7 = code
        .iter()
        .filter(|l| **l == format!("F0 MV K7, {FAULT}"))
        .count();
    assert!(fault7 >= 3, "fault 7 written {fault7} times");
    for c in 0..4 {
        // Each homed channel's count is preset to from[c], into the register the status block
        // reports as its elapsed count.
        let elapsed = dmv_source(&code, 1008 + 2 * c);
        let preset = format!("F1 DMV DT{}, {elapsed}", 1150 + 2 * c);
        assert!(
            code.contains(&preset),
            "channel {c} is never preset (`{preset}`)"
        );
        let f171 = format!("F171 SPDH DT{}, K{c}", 1300 + 10 * c);
        assert!(code.contains(&f171), "no `{f171}` in the integrator block");
        for marker in ["begin", "end"] {
            let line = format!("INTEGRATOR BLOCK: channel {c}'s home routine, {marker}");
            assert!(listing.contains(&line), "{LISTING} lacks `{line}`");
        }
    }
}

#[test]
fn plc_listing_stops_every_channel_through_dt90052() {
    let code = listing_code();
    let rungs = rungs(&code);
    let stop = rung_with(&rungs, "OT R45");
    assert_eq!(
        stop.conditions,
        [
            format!("ST {ESTOP_OPEN}"),
            format!("OR= {COMMAND_OF_SCAN}, K2"),
            // Version 3: the running move's latched permit stopped holding.
            "OR R182".to_owned(),
        ]
    );
    let acts = rungs
        .iter()
        .find(|r| r.conditions == ["ST R45"])
        .expect("no stop rung");
    for channel in 0..4 {
        let line = format!("F0 MV H{channel}108, DT90052");
        assert!(acts.has_output(&line), "the stop never runs `{line}`");
    }
    for line in ["F0 MV K0, DT1032", "F0 MV K0, WR16"] {
        assert!(acts.has_output(line), "the stop lacks `{line}`");
    }
}

#[test]
fn plc_listing_ends_its_main_program_before_its_subroutine() {
    let code = listing_code();
    let at = |needle: &str| code.iter().position(|l| l == needle);
    let ed = at("ED").expect("no ED");
    assert!(
        at("SUB 1").is_some_and(|sub| sub > ed),
        "SUB 1 must follow ED"
    );
    assert_eq!(code.last().map(String::as_str), Some("RET"));
    // Every label the subroutine jumps or loops to is in it, once.
    let sub = &code[ed..];
    for line in sub
        .iter()
        .filter(|l| l.starts_with("JP ") || l.starts_with("LOOP "))
    {
        let label = line.split([' ', ',']).nth(1).unwrap_or("");
        let lbl = format!("LBL {label}");
        assert_eq!(sub.iter().filter(|l| **l == lbl).count(), 1, "`{line}`");
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
fn plc_readme_and_header_list_every_special_address_with_its_status() {
    let listing = read(LISTING);
    let readme = read(PLC_README);
    let used = special_addresses(instructions(&listing).iter().map(String::as_str));
    let unverified = special_addresses(listing.lines().filter(|l| l.contains("UNVERIFIED")));
    assert!(
        !unverified.is_empty(),
        "{LISTING} marks no special address UNVERIFIED"
    );
    // The header: every comment line before the first instruction.
    let header: Vec<&str> = listing.lines().take_while(|l| l.starts_with(';')).collect();
    let in_header = special_addresses(header.iter().copied());
    for address in used.union(&unverified) {
        assert!(
            in_header.contains(address),
            "{LISTING}'s header lacks {address}"
        );
        let rows: Vec<&str> = readme
            .lines()
            .filter(|l| l.starts_with('|') && l.contains(address.as_str()))
            .collect();
        assert!(
            rows.iter().any(|r| ["confirmed", "probable", "unknown"]
                .iter()
                .any(|s| r.contains(s))),
            "{PLC_README} has no row giving {address}'s status"
        );
    }
    // The probable FP-X addresses come with the alternative written beside every use.
    for line in listing.lines().filter(|l| {
        let code = l.split(';').next().unwrap_or("");
        ["R911", "DT9034", "DT9035", "DT9036"]
            .iter()
            .any(|a| code.contains(a))
    }) {
        assert!(
            line.contains("UNVERIFIED") && line.contains("alternative"),
            "{LISTING}: `{line}` has no alternative beside it"
        );
    }
}

/// The commission's steps and checks, named as the commission command names them.
const COMMISSION: [(&str, &[&str]); 4] = [
    (
        "link",
        &[
            "headers %, <",
            "largest frame/read/write",
            "multi-frame read",
            "round trip",
            "scan time from heartbeat rate",
            "RUN/PROG read",
        ],
    ),
    (
        "contract",
        &["magic", "version", "heartbeat", "host echo", "ready bits"],
    ),
    ("inputs", &["copied every scan"]),
    (
        "pulses",
        &[
            "busy on then off",
            "elapsed moves by exactly the table's pulses",
            "time taken vs frequency",
            "two-segment table chains",
            "stop mid-table then a following start works",
            "`from` interlock refuses fault 5",
            "repeated seq ignored",
            "permit refuses fault 8",
            "permit drop holds within one scan",
        ],
    ),
];

#[test]
fn plc_readme_names_commission_steps_exactly() {
    let readme = read(PLC_README);
    let mut cells = 0;
    let mut header_has_column = false;
    for line in readme.lines() {
        if !line.starts_with('|') {
            header_has_column = false;
            continue;
        }
        let row: Vec<&str> = line.trim_matches('|').split(" | ").map(str::trim).collect();
        if row.last() == Some(&"measured by") {
            header_has_column = true;
            continue;
        }
        if !header_has_column || line.chars().all(|ch| ch == '|' || ch == '-') {
            continue;
        }
        let cell = row.last().unwrap();
        for item in cell.split("; ") {
            cells += 1;
            if ["load", "by hand", "not measured"]
                .iter()
                .any(|p| item.starts_with(p))
            {
                continue;
            }
            let known = COMMISSION.iter().any(|(step, checks)| {
                item.strip_prefix(step)
                    .and_then(|rest| rest.strip_prefix(": "))
                    .is_some_and(|check| checks.contains(&check))
            });
            assert!(known, "{PLC_README}: `{item}` names no commission check");
        }
    }
    assert!(
        cells > 40,
        "{PLC_README}: only {cells} `measured by` entries"
    );
    for (step, checks) in COMMISSION {
        for check in checks {
            assert!(
                readme.contains(&format!("{step}: {check}")),
                "{PLC_README} never names `{step}: {check}`"
            );
        }
    }
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

// ------------------------------------------------------------------------------------------------
// The Debian package (cargo deb)

const PACKAGE_SCRIPT: &str = "deploy/package.sh";

/// `[package.metadata.deb]`'s assets as (source, destination).
fn deb_assets() -> Vec<(String, String)> {
    let manifest: toml::Table = toml::from_str(&read("Cargo.toml")).unwrap();
    let deb = &manifest["package"]["metadata"]["deb"];
    deb["assets"]
        .as_array()
        .expect("assets")
        .iter()
        .map(|a| {
            let a = a.as_array().expect("[source, destination, mode]");
            (
                a[0].as_str().unwrap().to_owned(),
                a[1].as_str().unwrap().to_owned(),
            )
        })
        .collect()
}

#[test]
fn deb_installs_the_unit_sysusers_conffile_completions_and_man_pages() {
    let assets = deb_assets();
    let dest = |source: &str| {
        assets
            .iter()
            .find(|(s, _)| s == source)
            .map_or_else(|| panic!("no asset {source}"), |(_, d)| d.as_str())
    };
    assert_eq!(dest("target/release/linterpd"), "usr/bin/");
    assert_eq!(
        dest(UNIT),
        "usr/lib/systemd/system/linterpd.service",
        "the unit's ExecStart is /usr/bin/linterpd"
    );
    assert!(read(UNIT).contains(EXEC_START));
    assert_eq!(
        dest("deploy/linterpd.sysusers"),
        "usr/lib/sysusers.d/linterpd.conf"
    );
    assert_eq!(dest("config/linterpd.toml"), "etc/linterpd/linterpd.toml");
    let manifest: toml::Table = toml::from_str(&read("Cargo.toml")).unwrap();
    let conf_files = manifest["package"]["metadata"]["deb"]["conf-files"]
        .as_array()
        .expect("conf-files");
    assert!(
        conf_files
            .iter()
            .any(|c| c.as_str() == Some("/etc/linterpd/linterpd.toml"))
    );
    for wanted in [
        "usr/share/bash-completion/completions/linterpd",
        "usr/share/zsh/vendor-completions/_linterpd",
        "usr/share/fish/vendor_completions.d/linterpd.fish",
        "usr/share/man/man1/",
    ] {
        assert!(
            assets.iter().any(|(_, d)| d == wanted),
            "nothing installed to {wanted}"
        );
    }
}

/// The repository's files a glob of one `*` in its last part matches (`docs/*`).
fn glob(pattern: &str) -> Vec<PathBuf> {
    let (dir, name) = pattern.rsplit_once('/').unwrap_or((".", pattern));
    let (prefix, suffix) = name.split_once('*').expect("a glob");
    std::fs::read_dir(repo_file(dir))
        .unwrap_or_else(|e| panic!("{dir}: {e}"))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .filter(|p| {
            let n = p.file_name().unwrap().to_str().unwrap();
            n.starts_with(prefix) && n.ends_with(suffix)
        })
        .collect()
}

#[test]
fn deb_assets_exist_in_the_repository_or_are_made_by_the_package_script() {
    let script = read(PACKAGE_SCRIPT);
    for (source, _) in deb_assets() {
        if source == "target/release/linterpd" {
            continue; // built by cargo
        }
        if let Some(generated) = source.strip_prefix("target/release/package/") {
            // The script writes `$out/<generated>` ($out = target/release/package); a man page
            // glob matches the pages `linterpd man --dir "$out/man"` writes, gzipped.
            let made = if generated == "man/*.1.gz" {
                script.contains("man --dir \"$out/man\"")
                    && script.contains("gzip -9n \"$out\"/man/*.1")
            } else {
                script.contains(&format!("> \"$out/{generated}\""))
            };
            assert!(made, "{PACKAGE_SCRIPT} does not make {source}");
            continue;
        }
        if source.contains('*') {
            assert!(!glob(&source).is_empty(), "asset {source} matches nothing");
            continue;
        }
        assert!(
            repo_file(&source).is_file(),
            "asset {source} is not in the repository"
        );
    }
    for script in ["deploy/debian/postinst", "deploy/debian/postrm"] {
        assert!(read(script).contains("#DEBHELPER#"), "{script}");
    }
}

#[test]
fn deb_stops_the_service_on_remove_and_never_restarts_it_on_upgrade() {
    // `apt remove` left the daemon running from a deleted binary; an upgrade must not restart a
    // robot under way: cargo-deb's systemd-units, as README.md's "Upgrading" says.
    let manifest: toml::Table = toml::from_str(&read("Cargo.toml")).unwrap();
    let deb = &manifest["package"]["metadata"]["deb"];
    let units = deb["systemd-units"].as_table().expect("systemd-units");
    let option = |key: &str| units.get(key).and_then(toml::Value::as_bool);
    assert_eq!(units["unit-name"].as_str(), Some("linterpd"));
    assert_eq!(
        option("enable"),
        Some(false),
        "enabled by the operator, once configured"
    );
    assert_eq!(
        option("start"),
        Some(false),
        "started by the operator, once configured"
    );
    assert_eq!(option("restart-after-upgrade"), Some(false));
    assert_eq!(
        option("stop-on-upgrade"),
        Some(false),
        "stopped on removal only, not on upgrade"
    );
    let assets = deb_assets();
    assert!(assets.contains(&(
        "deploy/needrestart.conf".to_owned(),
        "etc/needrestart/conf.d/linterpd.conf".to_owned()
    )));
    assert!(read("deploy/needrestart.conf").contains("{qr(^linterpd\\.service$)} = 0;"));
    let readme = read("README.md");
    assert!(
        readme.contains("### Upgrading"),
        "README.md says how to upgrade"
    );
}

#[test]
fn deb_installs_the_docs_and_examples_the_readme_links_to() {
    let assets = deb_assets();
    let installed = |source: &str, dest: &str| assets.iter().any(|(s, d)| s == source && d == dest);
    assert!(installed("docs/*", "usr/share/doc/linterpd/docs/"));
    for dir in [
        "config/examples",
        "config/examples/cycles",
        "config/examples/cells",
    ] {
        assert!(
            installed(
                &format!("{dir}/*.toml"),
                &format!("usr/share/doc/linterpd/{dir}/")
            ),
            "{dir}"
        );
    }
    // Every link of the README to a document or example lands on an installed file.
    let readme = read("README.md");
    for link in readme.split("](").skip(1) {
        let target = link.split([')', '#']).next().unwrap();
        if target.is_empty() || target.starts_with("http") {
            continue;
        }
        let shipped = assets.iter().any(|(s, d)| {
            let installed_as = d.strip_prefix("usr/share/doc/linterpd/");
            installed_as == Some(target)
                || (s.ends_with('*') || s.ends_with("*.toml"))
                    && installed_as.is_some_and(|dir| {
                        target.starts_with(dir)
                            && !target[dir.len()..].contains('/')
                            && glob(s).iter().any(|p| p.ends_with(target))
                    })
        });
        assert!(
            shipped,
            "README.md links to {target}, which the package does not install"
        );
    }
}

#[test]
fn unit_documents_its_man_pages_and_the_installed_docs() {
    let unit = read(UNIT);
    let docs: Vec<&str> = unit
        .lines()
        .filter_map(|l| l.strip_prefix("Documentation="))
        .flat_map(str::split_whitespace)
        .collect();
    assert!(docs.contains(&"man:linterpd(1)"), "{docs:?}");
    for doc in docs {
        if let Some(file) = doc.strip_prefix("file:/usr/share/doc/linterpd/") {
            assert!(repo_file(file).is_file(), "{doc}");
            let shipped = deb_assets().iter().any(|(s, d)| {
                d.trim_start_matches("usr/share/doc/linterpd/") == file
                    || (s.ends_with('*')
                        && file.starts_with(d.trim_start_matches("usr/share/doc/linterpd/")))
            });
            assert!(shipped, "{doc} is not installed by the package");
        } else if let Some(page) = doc.strip_prefix("man:") {
            // linterpd man --dir writes linterpd.1, linterpd-serve.1, ...
            let name = page.trim_end_matches("(1)");
            let dir = TempDir::new("unit-man");
            let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
                .arg("man")
                .arg("--dir")
                .arg(dir.path())
                .output()
                .unwrap();
            assert!(out.status.success(), "{}", describe(&out));
            assert!(dir.path().join(format!("{name}.1")).is_file(), "{doc}");
        } else {
            panic!("{doc}: a man: or file: document");
        }
    }
}

#[test]
fn package_script_writes_every_completion_and_man_page_the_cli_generates() {
    // What the script asks the binary for, the binary gives: run it as the script does.
    let dir = TempDir::new("package");
    let bin = env!("CARGO_BIN_EXE_linterpd");
    for shell in ["bash", "zsh", "fish"] {
        let out = Command::new(bin)
            .args(["completions", shell])
            .output()
            .unwrap();
        assert!(
            out.status.success() && !out.stdout.is_empty(),
            "{shell}: {}",
            describe(&out)
        );
        assert!(read(PACKAGE_SCRIPT).contains(&format!("completions {shell} >")));
    }
    let man = dir.path().join("man");
    std::fs::create_dir_all(&man).unwrap();
    let out = Command::new(bin)
        .arg("man")
        .arg("--dir")
        .arg(&man)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", describe(&out));
    assert!(man.join("linterpd.1").is_file());
}
