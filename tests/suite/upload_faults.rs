//! Every fault the mock can inject, injected during a bank upload, ends in a clear error and no
//! start; once the fault clears, the next exchange works. MEWTOCOL over `duplex` with the
//! client's usual timeout and retries; a single glitch is retried through, a persistent one is
//! not. Then the Modbus faults over Modbus TCP.

use crate::common;

use std::time::Duration;

use common::exchange::{
    exchange, home_where_it_stands, machine, mock_at_seed_start, settings, start_and_follow, upload,
};
use linterpd::contract::MAGIC;
use linterpd::mewtocol::Station;
use linterpd::mock::{
    MewtocolServer, MewtocolServerOptions, ModbusServer, ModbusServerOptions, SharedMock,
};
use linterpd::plc::MewtocolOptions;
use linterpd::plc::exchange::{Contract, ContractError};
use linterpd::plc::{
    HeaderChoice, MewtocolClient, ModbusClient, ModbusFraming, ModbusOptions, PlcError, PlcMode,
};
use tokio::io::DuplexStream;
use tokio::net::{TcpListener, TcpStream};

/// Bank writes begin after the host is made ready (status, host word, status: commands 1-3):
/// command 5 is inside the second channel's table.
const IN_UPLOAD: u64 = 5;

fn mewtocol(shared: &SharedMock) -> Contract<MewtocolClient<DuplexStream>> {
    let (ours, theirs) = tokio::io::duplex(4_096);
    let server = MewtocolServer::new(shared.clone(), MewtocolServerOptions::default());
    tokio::spawn(async move { server.serve(theirs).await });
    let options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
    Contract::new(MewtocolClient::new(ours, options), settings())
}

/// `item@k` for three commands in a row from the first write: more than the client's retries.
fn persistent(item: &str) -> String {
    (IN_UPLOAD..IN_UPLOAD + 3)
        .map(|k| format!("{item}@{k}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Nothing was started: no start command waits, the program is idle, every count unchanged.
fn assert_no_start(shared: &SharedMock, counts_before: [i32; 4]) {
    let (command, status) = shared.with(|m| (m.read_words(1_032, 1).unwrap()[0], m.status()));
    assert_eq!(command, 0, "a start command was written");
    assert_eq!(status.magic, MAGIC);
    assert_eq!(status.state, 0, "state {}", status.state);
    assert_eq!(status.busy, 0);
    assert_eq!(status.elapsed, counts_before);
}

/// The channels' counts (the engines', not the status block's copy of its last scan).
fn counts(shared: &SharedMock) -> [i32; 4] {
    shared.with(|m| std::array::from_fn(|c| m.count(c) as i32))
}

async fn refused_then_recovers(script: &str, expect: impl Fn(&ContractError) -> bool) -> String {
    let shared = mock_at_seed_start(script);
    let before = counts(&shared);
    let mut c = mewtocol(&shared);
    let mut m = machine();
    let err = match upload(&mut c, &mut m, 1).await {
        Err(e) => e,
        Ok((_, bank, planned)) => start_and_follow(&mut c, &mut m, &bank, planned)
            .await
            .expect_err("the start must be refused"),
    };
    assert!(expect(&err), "{err:?}");
    assert_no_start(&shared, before);
    // The fault has passed (or is lifted): the next exchange works, on a new connection.
    shared.with(|m| {
        m.freeze_heartbeat(false);
        m.set_mode(PlcMode::Run);
    });
    let mut again = mewtocol(&shared);
    if !shared.with(|m| m.homed()) {
        // PROG -> RUN is a restart: the program's first scan cleared the homed bit.
        home_where_it_stands(&mut again).await.unwrap();
    }
    exchange(&mut again, 2).await.unwrap();
    err.to_string()
}

#[tokio::test]
async fn dropped_replies_time_out_and_start_nothing() {
    let msg = refused_then_recovers(&persistent("drop"), |e| {
        matches!(e, ContractError::Plc(PlcError::Timeout { .. }))
    })
    .await;
    assert!(
        msg.starts_with("no reply to write DT") && msg.ends_with("within 320 ms"),
        "{msg}"
    );
}

#[tokio::test]
async fn corrupted_replies_are_bad_replies_and_start_nothing() {
    let msg = refused_then_recovers(&persistent("corrupt"), |e| {
        matches!(e, ContractError::Plc(PlcError::BadReply { .. }))
    })
    .await;
    assert!(msg.starts_with("bad reply to write DT"), "{msg}");
}

#[tokio::test]
async fn delayed_replies_time_out_and_late_ones_do_not_confuse_the_next_exchange() {
    refused_then_recovers(&persistent("delay1000"), |e| {
        matches!(e, ContractError::Plc(PlcError::Timeout { .. }))
    })
    .await;
}

#[tokio::test]
async fn closed_connection_is_a_link_failure_and_starts_nothing() {
    let msg = refused_then_recovers(&format!("close@{IN_UPLOAD}"), |e| {
        matches!(
            e,
            ContractError::Plc(PlcError::Link { .. } | PlcError::Timeout { .. })
        )
    })
    .await;
    assert!(msg.contains("write DT"), "{msg}");
}

#[tokio::test]
async fn plc_error_code_is_passed_up_unchanged_and_starts_nothing() {
    let msg = refused_then_recovers(&format!("error61@{IN_UPLOAD}"), |e| {
        matches!(e, ContractError::Plc(PlcError::Refused { .. }))
    })
    .await;
    assert!(msg.contains("MEWTOCOL error 61: data error"), "{msg}");
}

#[tokio::test]
async fn heartbeat_frozen_during_the_upload_refuses_the_start() {
    let msg = refused_then_recovers(&format!("freeze@{IN_UPLOAD}"), |e| {
        matches!(e, ContractError::Stalled { .. })
    })
    .await;
    assert!(msg.contains("the PLC is stalled"), "{msg}");
}

#[tokio::test]
async fn prog_mode_during_the_upload_refuses_the_start() {
    let msg = refused_then_recovers(&format!("prog@{IN_UPLOAD}"), |e| {
        matches!(e, ContractError::Stalled { .. })
    })
    .await;
    assert!(msg.ends_with("stalled, and in PROG mode"), "{msg}");
}

#[tokio::test]
async fn a_single_dropped_reply_is_retried_and_the_move_runs() {
    let shared = mock_at_seed_start(&format!("drop@{IN_UPLOAD},corrupt@{}", IN_UPLOAD + 4));
    exchange(&mut mewtocol(&shared), 1).await.unwrap();
}

async fn modbus(shared: &SharedMock) -> Contract<ModbusClient<TcpStream>> {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    tokio::spawn(
        ModbusServer::new(shared.clone(), ModbusServerOptions::default()).serve_tcp(listener),
    );
    let mut options = ModbusOptions::new(ModbusFraming::Tcp, 1);
    options.timeout = Duration::from_millis(300);
    Contract::new(
        ModbusClient::new(TcpStream::connect(address).await.unwrap(), options),
        settings(),
    )
}

#[tokio::test]
async fn modbus_exception_and_lost_replies_during_upload_start_nothing() {
    for (script, want) in [
        (format!("exception4@{IN_UPLOAD}"), "Modbus exception 0x04"),
        (persistent("drop"), "no reply to"),
    ] {
        let shared = mock_at_seed_start(&script);
        let before = counts(&shared);
        let mut c = modbus(&shared).await;
        let err = upload(&mut c, &mut machine(), 1)
            .await
            .map(|_| ())
            .unwrap_err();
        assert!(err.to_string().contains(want), "{script}: {err}");
        assert_no_start(&shared, before);
        exchange(&mut modbus(&shared).await, 2).await.unwrap();
    }
}
