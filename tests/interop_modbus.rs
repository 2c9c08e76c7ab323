//! Modbus interoperability with third-party peers, as separate processes on loopback or a socat
//! pseudo-terminal pair:
//!
//! - linterpd's `ModbusClient` (TCP, RTU) against a pymodbus server,
//! - a pymodbus client (TCP, RTU) and mbpoll against `linterpd mock-plc --protocol modbus`.
//!
//! The peers are required, not optional: a missing one fails the test with the command that
//! installs it (`.ci/run` installs them all). Python is `$LINTERPD_INTEROP_PYTHON`, else
//! `.venv-interop/bin/python` in the crate; `socat` and `mbpoll` come from `PATH`.
//!
//! Every peer prints `listening on ADDR` as its first stdout line once it serves; that line is the
//! only readiness signal used. Every wait has a timeout and fails with what the peer printed.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::Duration;

use common::process::{Finished, Spawned, TempDir};
use linterpd::contract::{DT_LAST, MAGIC, VERSION};
use linterpd::plc::{
    ModbusClient, ModbusFraming, ModbusOptions, Parity, Plc, PlcError, Refusal, SerialSettings,
    TcpSettings, open_serial, open_tcp,
};

/// Longest wait for a peer to say it is listening (Python imports pymodbus first).
const READY: Duration = Duration::from_secs(10);
/// Longest run of one client script or mbpoll.
const RUN: Duration = Duration::from_secs(30);
/// Longest wait for a peer to exit after SIGTERM.
const STOP: Duration = Duration::from_secs(5);
/// Holding registers the pymodbus server holds: fewer than the FP-X's DT area, so a read past
/// them is an exception linterpd lets through.
const SERVER_REGISTERS: u16 = 10_000;
/// Registers written and read back in one round trip: more than one Modbus frame carries.
const ROUND_TRIP_WORDS: u16 = 300;
/// Where the round trips write: a table area of the register contract, inert on the mock.
const ROUND_TRIP_START: u16 = 2_000;

const INSTALL_VENV: &str = "python3 -m venv .venv-interop && \
    .venv-interop/bin/pip install -r tests/interop/requirements.txt";

// ---------------------------------------------------------------------------------------------
// Finding the peers
// ---------------------------------------------------------------------------------------------

fn manifest_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The Python with the pinned pymodbus; checked once per test binary.
fn python() -> &'static Path {
    static PYTHON: OnceLock<PathBuf> = OnceLock::new();
    PYTHON.get_or_init(|| {
        let (python, source) = match std::env::var_os("LINTERPD_INTEROP_PYTHON") {
            Some(path) => (PathBuf::from(path), "LINTERPD_INTEROP_PYTHON"),
            None => (
                manifest_dir().join(".venv-interop/bin/python"),
                "the default venv (LINTERPD_INTEROP_PYTHON is unset)",
            ),
        };
        assert!(
            python.is_file(),
            "interop peer missing: no Python with pymodbus at {} (from {source}). Install it from \
             the crate's root with `{INSTALL_VENV}` (as .ci/run does), or point \
             LINTERPD_INTEROP_PYTHON at a Python that has it",
            python.display()
        );
        let pinned = pinned_pymodbus();
        let mut check = Command::new(&python);
        check.args(["-c", "import pymodbus, serial; print(pymodbus.__version__)"]);
        let found = Spawned::spawn("python (pymodbus check)", check).finish(RUN);
        assert!(
            found.status.success(),
            "interop peer missing: {} cannot import pymodbus and pyserial. Install them with \
             `{INSTALL_VENV}`\n{}",
            python.display(),
            found.describe()
        );
        assert_eq!(
            found.stdout.trim(),
            pinned,
            "{} has pymodbus {} but tests/interop/requirements.txt pins {pinned}; reinstall with \
             `{INSTALL_VENV}`",
            python.display(),
            found.stdout.trim()
        );
        python
    })
}

/// The pymodbus version `tests/interop/requirements.txt` pins.
fn pinned_pymodbus() -> String {
    let path = manifest_dir().join("tests/interop/requirements.txt");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    text.lines()
        .find_map(|line| {
            let line = line.trim();
            let rest = line.strip_prefix("pymodbus")?;
            let (_, version) = rest.split_once("==")?;
            Some(version.trim().to_owned())
        })
        .unwrap_or_else(|| panic!("{} pins no pymodbus==VERSION", path.display()))
}

/// A program on `PATH`; the test fails naming the Debian package that provides it.
fn tool(name: &str) -> PathBuf {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .map(|dir| dir.join(name))
        .find(|candidate| is_executable(candidate))
        .unwrap_or_else(|| {
            panic!(
                "interop peer missing: `{name}` is not on PATH. Install it with \
                 `apt-get update && apt-get install -y {name}` (as .ci/run does)"
            )
        })
}

fn is_executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    path.metadata()
        .is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

fn script(name: &str) -> PathBuf {
    manifest_dir().join("tests/interop").join(name)
}

// ---------------------------------------------------------------------------------------------
// Starting the peers
// ---------------------------------------------------------------------------------------------

/// A pseudo-terminal pair joined by socat; `a` and `b` are the two ends' links.
struct PtyPair {
    // Declared first so socat is killed before its directory is removed.
    _socat: Spawned,
    a: PathBuf,
    b: PathBuf,
    _dir: TempDir,
}

impl PtyPair {
    fn new() -> Self {
        let socat = tool("socat");
        let dir = TempDir::new("pty");
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        let mut command = Command::new(socat);
        command.args(["-d", "-d"]);
        for end in [&a, &b] {
            command.arg(format!("pty,raw,echo=0,link={}", end.display()));
        }
        let mut socat = Spawned::spawn("socat", command);
        // socat makes both links, then logs this notice and starts copying.
        socat.wait_for_stderr("starting data transfer loop", READY);
        for end in [&a, &b] {
            assert!(
                end.exists(),
                "socat says it is copying but {} is missing\n{}",
                end.display(),
                socat.output()
            );
        }
        Self {
            _socat: socat,
            a,
            b,
            _dir: dir,
        }
    }
}

/// `pymodbus_server.py` serving Modbus TCP on loopback; returns it and its `host:port`.
fn pymodbus_tcp_server() -> (Spawned, String) {
    let mut command = Command::new(python());
    command.arg(script("pymodbus_server.py")).args([
        "--tcp",
        "127.0.0.1:0",
        "--registers",
        &SERVER_REGISTERS.to_string(),
    ]);
    let mut server = Spawned::spawn("pymodbus TCP server", command);
    let address = server.first_line_after("listening on ", READY);
    (server, address)
}

/// `pymodbus_server.py` serving Modbus RTU on `path`.
fn pymodbus_rtu_server(path: &Path) -> Spawned {
    let mut command = Command::new(python());
    command
        .arg(script("pymodbus_server.py"))
        .arg("--serial")
        .arg(path)
        .args(["--registers", &SERVER_REGISTERS.to_string()]);
    let mut server = Spawned::spawn("pymodbus RTU server", command);
    let said = server.first_line_after("listening on ", READY);
    assert_eq!(Path::new(&said), path, "{}", server.output());
    server
}

/// `linterpd mock-plc --protocol modbus` with `args` (where to listen, station...).
fn mock_plc(args: &[&str]) -> (Spawned, String) {
    let mut command = Command::new(env!("CARGO_BIN_EXE_linterpd"));
    command
        .args(["mock-plc", "--protocol", "modbus"])
        .args(args);
    let mut mock = Spawned::spawn("linterpd mock-plc", command);
    let address = mock.first_line_after("listening on ", READY);
    (mock, address)
}

/// Runs `pymodbus_client.py` with `args` to its end.
fn pymodbus_client(args: &[String]) -> Finished {
    let mut command = Command::new(python());
    command.arg(script("pymodbus_client.py")).args(args);
    Spawned::spawn("pymodbus client", command).finish(RUN)
}

fn port_of(address: &str) -> &str {
    match address.rsplit_once(':') {
        Some((_, port)) => port,
        None => panic!("`{address}` is not host:port"),
    }
}

fn stop_cleanly(peer: &mut Spawned, name: &str) {
    let status = peer.terminate(STOP);
    assert!(
        status.success(),
        "{name} should exit 0 on SIGTERM, got {status}\n{}",
        peer.output()
    );
}

// ---------------------------------------------------------------------------------------------
// linterpd's client against pymodbus servers
// ---------------------------------------------------------------------------------------------

fn options(framing: ModbusFraming) -> ModbusOptions {
    ModbusOptions {
        timeout: Duration::from_secs(2),
        ..ModbusOptions::new(framing, 1)
    }
}

/// Distinct words, none zero, different in both bytes from one address to the next.
fn pattern(start: u16, count: u16) -> Vec<u16> {
    (0..count)
        .map(|i| start.wrapping_add(i).wrapping_mul(0x0101) ^ 0x5AA5)
        .collect()
}

/// Writes and reads back 300 registers, switches a relay on and off and reads it each time, then
/// reads past the server's registers and expects exception 02, and reads once more.
async fn round_trip<P: Plc>(plc: &mut P, peer: &Spawned) {
    let words = pattern(ROUND_TRIP_START, ROUND_TRIP_WORDS);
    plc.write_words(ROUND_TRIP_START, &words)
        .await
        .unwrap_or_else(|e| panic!("write 300 registers: {e:?}\n{}", peer.output()));
    let read = plc
        .read_words(ROUND_TRIP_START, ROUND_TRIP_WORDS)
        .await
        .unwrap_or_else(|e| panic!("read 300 registers: {e:?}\n{}", peer.output()));
    if let Some(i) = (0..words.len()).find(|&i| read[i] != words[i]) {
        panic!(
            "DT{} read back {:#06x}, wrote {:#06x}",
            usize::from(ROUND_TRIP_START) + i,
            read[i],
            words[i]
        );
    }
    assert_eq!(read.len(), words.len());

    // R3A = relay 3 * 16 + 10 = coil 2048 + 58.
    let relay = 3 * 16 + 10;
    for on in [true, false, true] {
        plc.write_relay(relay, on)
            .await
            .unwrap_or_else(|e| panic!("write R3A = {on}: {e:?}\n{}", peer.output()));
        let state = plc
            .read_relay(relay)
            .await
            .unwrap_or_else(|e| panic!("read R3A: {e:?}\n{}", peer.output()));
        assert_eq!(state, on, "R3A read back");
    }
    assert!(
        !plc.read_relay(relay + 1).await.expect("read R3B"),
        "R3B was never written"
    );

    // The server holds DT0..DT9999: a read across its end is refused with exception 02.
    match plc.read_words(SERVER_REGISTERS - 5, 10).await {
        Err(PlcError::Refused {
            refusal: Refusal::Modbus { code: 2, .. },
            ..
        }) => {}
        other => panic!(
            "a read past the server's registers should be exception 02, got {other:?}\n{}",
            peer.output()
        ),
    }
    // An exception breaks nothing: the next call is answered.
    let again = plc
        .read_words(ROUND_TRIP_START, 2)
        .await
        .unwrap_or_else(|e| panic!("read after the exception: {e:?}\n{}", peer.output()));
    assert_eq!(again, words[..2]);
}

#[tokio::test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs socat, mbpoll and pymodbus: cargo test --features third-party-peers (.ci/run)"
)]
async fn linterpd_client_round_trips_with_a_pymodbus_tcp_server() {
    let (mut server, address) = pymodbus_tcp_server();
    let link = open_tcp(&TcpSettings {
        address: address.clone(),
        connect_timeout: Duration::from_secs(3),
    })
    .await
    .unwrap_or_else(|e| panic!("connect to {address}: {e:?}\n{}", server.output()));
    let mut plc = ModbusClient::new(link, options(ModbusFraming::Tcp));
    round_trip(&mut plc, &server).await;
    assert_eq!(plc.reattach_count(), 0, "no call should have failed");
    drop(plc);
    stop_cleanly(&mut server, "the pymodbus TCP server");
}

#[tokio::test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs socat, mbpoll and pymodbus: cargo test --features third-party-peers (.ci/run)"
)]
async fn linterpd_client_round_trips_with_a_pymodbus_rtu_server_over_a_pty_pair() {
    let pty = PtyPair::new();
    let mut server = pymodbus_rtu_server(&pty.a);
    let link = open_serial(&SerialSettings {
        path: pty.b.display().to_string(),
        baud: 19_200,
        data_bits: 8,
        parity: Parity::None,
        stop_bits: 1,
    })
    .unwrap_or_else(|e| panic!("open {}: {e:?}", pty.b.display()));
    let mut plc = ModbusClient::new(link, options(ModbusFraming::Rtu));
    round_trip(&mut plc, &server).await;
    assert_eq!(plc.reattach_count(), 0, "no call should have failed");
    drop(plc);
    stop_cleanly(&mut server, "the pymodbus RTU server");
}

/// Parses mbpoll's `[REF]: VALUE` lines.
fn mbpoll_values(stdout: &str) -> Vec<(u32, i64)> {
    stdout
        .lines()
        .filter_map(|line| {
            let rest = line.trim().strip_prefix('[')?;
            let (reference, value) = rest.split_once("]:")?;
            Some((reference.parse().ok()?, value.trim().parse().ok()?))
        })
        .collect()
}

/// mbpoll reading two holding registers from PDU address `start` over TCP (its `-r` is 1-based
/// unless `-0` is given: `-r 1001` is PDU address 1000, printed as `[1001]`).
fn mbpoll_read_two(port: &str, start: u16) -> (Finished, Vec<(u32, i64)>) {
    let mut command = Command::new(tool("mbpoll"));
    command.args(["-m", "tcp", "-a", "1", "-r"]);
    command.arg((u32::from(start) + 1).to_string());
    command.args([
        "-c",
        "2",
        "-t",
        "4",
        "-1",
        "-o",
        "2",
        "-p",
        port,
        "127.0.0.1",
    ]);
    let finished = Spawned::spawn("mbpoll", command).finish(RUN);
    let values = mbpoll_values(&finished.stdout);
    (finished, values)
}

#[tokio::test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs socat, mbpoll and pymodbus: cargo test --features third-party-peers (.ci/run)"
)]
async fn mbpoll_reads_what_linterpd_wrote_to_a_pymodbus_server() {
    tool("mbpoll");
    let (mut server, address) = pymodbus_tcp_server();
    let link = open_tcp(&TcpSettings {
        address: address.clone(),
        connect_timeout: Duration::from_secs(3),
    })
    .await
    .unwrap_or_else(|e| panic!("connect to {address}: {e:?}\n{}", server.output()));
    let mut plc = ModbusClient::new(link, options(ModbusFraming::Tcp));
    plc.write_words(1000, &[MAGIC, VERSION])
        .await
        .unwrap_or_else(|e| panic!("write DT1000..=DT1001: {e:?}\n{}", server.output()));
    drop(plc);

    let (finished, values) = mbpoll_read_two(port_of(&address), 1000);
    assert!(finished.status.success(), "{}", finished.describe());
    assert_eq!(
        values,
        [(1001, i64::from(MAGIC)), (1002, i64::from(VERSION))],
        "{}",
        finished.describe()
    );
    stop_cleanly(&mut server, "the pymodbus TCP server");
}

// ---------------------------------------------------------------------------------------------
// Third-party clients against linterpd's mock PLC
// ---------------------------------------------------------------------------------------------

/// The pymodbus client's arguments for the mock: a 300-register round trip in a table area,
/// the status block's magic and version, the DT area's last word and the exception past it.
fn mock_checks(unit: u8) -> Vec<String> {
    let past_end = u32::from(DT_LAST) + 1;
    vec![
        "--unit".into(),
        unit.to_string(),
        "--roundtrip".into(),
        format!("{ROUND_TRIP_START}:{ROUND_TRIP_WORDS}"),
        "--roundtrip".into(),
        format!("{}:{}", DT_LAST - 64, 65),
        "--expect".into(),
        format!("1000:{MAGIC:#06x},{VERSION}"),
        "--expect-exception".into(),
        format!("{past_end}:1"),
        "--expect-exception".into(),
        format!("{}:2", DT_LAST),
    ]
}

fn assert_client_matched(finished: &Finished, what: &str) {
    assert!(
        finished.status.success() && finished.stdout.contains("all matched"),
        "the pymodbus client against {what} failed\n{}",
        finished.describe()
    );
}

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs socat, mbpoll and pymodbus: cargo test --features third-party-peers (.ci/run)"
)]
fn pymodbus_client_round_trips_with_the_mock_over_tcp() {
    python();
    let (mut mock, address) = mock_plc(&["--listen", "127.0.0.1:0"]);
    assert!(
        address.starts_with("127.0.0.1:") && port_of(&address) != "0",
        "the mock should report its bound address, said `{address}`"
    );
    let mut args = vec!["--tcp".to_owned(), address];
    args.extend(mock_checks(1));
    let finished = pymodbus_client(&args);
    assert_client_matched(&finished, "the mock over TCP");
    stop_cleanly(&mut mock, "linterpd mock-plc");
}

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs socat, mbpoll and pymodbus: cargo test --features third-party-peers (.ci/run)"
)]
fn pymodbus_client_round_trips_with_the_mock_over_rtu_on_a_pty_pair() {
    python();
    let pty = PtyPair::new();
    let end = pty.a.display().to_string();
    let (mut mock, said) = mock_plc(&["--serial", &end, "--baud", "19200", "--station", "7"]);
    assert_eq!(said, end, "the mock should report its serial path");
    let mut args = vec!["--serial".to_owned(), pty.b.display().to_string()];
    args.extend(["--baud".to_owned(), "19200".to_owned()]);
    args.extend(mock_checks(7));
    let finished = pymodbus_client(&args);
    assert_client_matched(&finished, "the mock over RTU");
    stop_cleanly(&mut mock, "linterpd mock-plc");
}

#[test]
#[cfg_attr(
    not(feature = "third-party-peers"),
    ignore = "needs socat, mbpoll and pymodbus: cargo test --features third-party-peers (.ci/run)"
)]
fn mbpoll_reads_the_mock_status_block() {
    tool("mbpoll");
    let (mut mock, address) = mock_plc(&["--listen", "127.0.0.1:0"]);
    let (finished, values) = mbpoll_read_two(port_of(&address), 1000);
    assert!(
        finished.status.success(),
        "mbpoll against the mock failed\n{}\n--- mock ---\n{}",
        finished.describe(),
        mock.output()
    );
    assert_eq!(
        values,
        [(1001, i64::from(MAGIC)), (1002, i64::from(VERSION))],
        "mbpoll should show the magic 0x4C49 = 19529 and the contract version {VERSION}\n{}",
        finished.describe()
    );
    stop_cleanly(&mut mock, "linterpd mock-plc");
}
