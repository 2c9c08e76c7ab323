//! The mock PLC's servers from the outside: Modbus TCP and RTU through linterpd's own
//! `ModbusClient`, and `linterpd mock-plc` as a process. Servers bind port 0; the process's port is
//! read from its `listening on` line.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::Duration;

use linterpd::contract::{MAGIC, VERSION};
use linterpd::mewtocol::Station;
use linterpd::mock::{
    FaultScript, MockConfig, MockPlc, ModbusServer, ModbusServerOptions, SharedMock, StationFilter,
};
use linterpd::plc::{
    HeaderChoice, MewtocolClient, MewtocolOptions, ModbusClient, ModbusFraming, ModbusOptions, Plc,
    PlcError, PlcMode, Refusal,
};
use tokio::net::{TcpListener, TcpStream};

fn ramp(n: u16) -> Vec<u16> {
    (0..n).map(|i| i.wrapping_mul(977) ^ 0x3C3C).collect()
}

fn shared_mock(script: &str) -> SharedMock {
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    mock.set_faults(FaultScript::parse(script).unwrap());
    SharedMock::new(mock)
}

/// A Modbus TCP mock on port 0 and a client for `unit` on it.
async fn modbus_tcp(script: &str, unit: u8) -> (SharedMock, ModbusClient<TcpStream>) {
    let shared = shared_mock(script);
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let server = ModbusServer::new(shared.clone(), ModbusServerOptions::default());
    tokio::spawn(server.serve_tcp(listener));
    let stream = TcpStream::connect(address).await.unwrap();
    let mut options = ModbusOptions::new(ModbusFraming::Tcp, unit);
    options.timeout = Duration::from_millis(500);
    (shared, ModbusClient::new(stream, options))
}

#[tokio::test]
async fn modbus_tcp_round_trips_300_registers() {
    let (shared, mut plc) = modbus_tcp("", 1).await;
    plc.write_words(4_000, &ramp(300)).await.unwrap();
    assert_eq!(plc.read_words(4_000, 300).await.unwrap(), ramp(300));
    let stored = shared.with(|m| m.read_words(4_000, 300).unwrap());
    assert_eq!(stored, ramp(300));
    assert_eq!(
        shared.with(|m| m.commands()),
        6,
        "123 + 123 + 54 and 125 + 125 + 50"
    );
}

#[tokio::test]
async fn modbus_tcp_relays_and_the_run_flag() {
    let (shared, mut plc) = modbus_tcp("", 1).await;
    plc.write_relay(0x2A, true).await.unwrap();
    assert!(plc.read_relay(0x2A).await.unwrap());
    assert!(shared.with(|m| m.read_relay(0x2A).unwrap()));
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
    shared.with(|m| m.set_mode(PlcMode::Prog));
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Prog);
}

#[tokio::test]
async fn modbus_tcp_out_of_range_address_is_exception_02() {
    let (_, mut plc) = modbus_tcp("", 1).await;
    let e = plc.read_relay(300 * 16).await.unwrap_err(); // R300.0: past R255F
    let PlcError::Refused { refusal, .. } = e else {
        panic!("{e:?}")
    };
    assert_eq!(
        refusal,
        Refusal::Modbus {
            code: 2,
            meaning: "illegal data address"
        }
    );
}

#[tokio::test]
async fn modbus_tcp_scripted_exception_and_wrong_unit() {
    let (_, mut plc) = modbus_tcp("exception6@1", 1).await;
    let e = plc.read_words(0, 1).await.unwrap_err();
    assert!(
        matches!(
            e,
            PlcError::Refused {
                refusal: Refusal::Modbus { code: 6, .. },
                ..
            }
        ),
        "{e:?}"
    );
    let (shared, mut other) = modbus_tcp("", 2).await;
    let e = other.read_words(0, 1).await.unwrap_err();
    assert!(matches!(e, PlcError::Timeout { .. }), "{e:?}");
    assert_eq!(shared.with(|m| m.commands()), 0);
}

#[tokio::test]
async fn modbus_tcp_scripted_close_ends_the_connection() {
    let (_, mut plc) = modbus_tcp("close@1", 1).await;
    let e = plc.read_words(0, 1).await.unwrap_err();
    assert!(e.is_link_failure(), "{e:?}");
}

#[tokio::test]
async fn modbus_rtu_on_a_pseudo_terminal() {
    let (ours, theirs) = tokio_serial::SerialStream::pair().unwrap();
    let shared = shared_mock("");
    let server = ModbusServer::new(shared.clone(), ModbusServerOptions::default());
    tokio::spawn(server.serve_rtu(theirs));
    let mut options = ModbusOptions::new(ModbusFraming::Rtu, 1);
    options.timeout = Duration::from_secs(2);
    let mut plc = ModbusClient::new(ours, options);
    plc.write_words(6_000, &ramp(200)).await.unwrap();
    assert_eq!(plc.read_words(6_000, 200).await.unwrap(), ramp(200));
    let status = plc.read_words(1_000, 2).await.unwrap();
    assert_eq!(
        status,
        [MAGIC, VERSION],
        "magic and version of a live status block"
    );
}

/// Sends SIGTERM to a child process.
fn terminate(child: &std::process::Child) {
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

#[tokio::test]
async fn mock_plc_process_serves_mewtocol_and_exits_0_on_sigterm() {
    let trace = std::env::temp_dir().join(format!("linterpd-trace-{}.csv", std::process::id()));
    let mut child = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args([
            "mock-plc",
            "--listen",
            "127.0.0.1:0",
            "--protocol",
            "mewtocol",
        ])
        .arg("--trace")
        .arg(&trace)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let address = line
        .trim()
        .strip_prefix("listening on ")
        .unwrap()
        .to_owned();

    let stream = TcpStream::connect(&address).await.unwrap();
    let options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
    let mut plc = MewtocolClient::new(stream, options);
    assert_eq!(plc.read_words(1_000, 2).await.unwrap(), [MAGIC, VERSION]);

    terminate(&child);
    let status = tokio::task::spawn_blocking(move || child.wait().unwrap())
        .await
        .unwrap();
    assert_eq!(status.code(), Some(0));
    let csv = std::fs::read_to_string(&trace).unwrap();
    assert!(csv.starts_with("time_s,channel,count\n"), "{csv}");
    let _ = std::fs::remove_file(&trace);
}

#[test]
fn mock_plc_refuses_a_bad_station_with_exit_2() {
    let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(["mock-plc", "--listen", "127.0.0.1:0", "--station", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--station '0'"), "{stderr}");
    assert!(out.stdout.is_empty());
}

#[test]
fn station_filter_is_public() {
    assert_eq!(StationFilter::Only(1), ModbusServerOptions::default().unit);
}
