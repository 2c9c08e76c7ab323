//! The register gateway end to end against the mock PLC: what the access list lets through
//! reaches the PLC's memory, what it does not never does, a link that is down is said so, and a
//! move runs to its target while a client keeps the gateway busy, its status reads waiting behind
//! one gateway exchange at most.

use crate::common;

use std::time::Duration;

use common::daemon::{duplex_connector, taking_moves as wait_connected};
use common::exchange::{P2, mock_at_seed_start};
use linterpd::contract::Layout;
use linterpd::daemon::{
    Connector, Daemon, DaemonOptions, GatewayError, MoveOrder, RobotHandle, RobotSetup, Stage,
    Values,
};
use linterpd::gateway::{AccessList, Address, Area, GatewaySettings, Range};
use linterpd::kinematics::JOINTS;
use linterpd::mock::SharedMock;
use linterpd::plc::exchange::ContractSettings;
use linterpd::robot::seed_robot;

fn ranges(texts: &[&str]) -> Vec<Range> {
    texts.iter().map(|t| t.parse().unwrap()).collect()
}

/// Reads DT0-DT999 (and the status block), X0-X1F, Y0-YF; writes DT100-DT199, Y0-Y7, R10-R1F.
fn access() -> AccessList {
    AccessList::new(
        ranges(&["DT0-DT999", "DT1000-DT1021", "X0-X1F", "Y0-YF"]),
        ranges(&["DT100-DT199", "Y0-Y7", "R10-R1F"]),
        &Layout::default(),
    )
    .unwrap()
}

fn spawn(connect: Connector) -> (Daemon, RobotHandle) {
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect,
        home_counts: [0; JOINTS],
        cell: linterpd::config::CellSettings::default(),
        gateway: GatewaySettings {
            access: access(),
            modbus: None,
        },
    };
    let d = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let h = d.robot("press-loader").unwrap().clone();
    (d, h)
}

fn at(text: &str) -> Address {
    text.parse().unwrap()
}

fn words(shared: &SharedMock, start: u32, count: usize) -> Vec<u16> {
    shared.with(|m| m.read_words(start, count).unwrap())
}

#[tokio::test]
async fn listed_registers_are_read_and_written_in_the_plcs_memory() {
    let shared = mock_at_seed_start("");
    shared.with(|m| {
        m.write_words(0, &(0..1_000).map(|i| i as u16 * 3).collect::<Vec<_>>())
            .unwrap();
        m.set_input(0x13, true).unwrap(); // X13: word 1, bit 3
    });
    let (d, h) = spawn(duplex_connector(&shared, None));
    wait_connected(&h).await;

    // 600 words: more than one MEWTOCOL exchange carries, cut into several and put together.
    let read = h.read_registers(at("DT0"), 600).await.unwrap();
    let expected: Vec<u16> = (0..600).map(|i| i as u16 * 3).collect();
    assert_eq!(read, Values::Words(expected));

    let written: Vec<u16> = (0..100).map(|i| 50_000 + i).collect();
    h.write_registers(at("DT100"), Values::Words(written.clone()))
        .await
        .unwrap();
    assert_eq!(words(&shared, 100, 100), written);
    assert_eq!(
        words(&shared, 99, 1),
        [99 * 3],
        "the word before is untouched"
    );
    assert_eq!(
        words(&shared, 200, 1),
        [200 * 3],
        "the word after is untouched"
    );

    // Bits: X inputs as the mock sets them, R and Y written bit by bit.
    let x = h.read_registers(at("X10"), 8).await.unwrap();
    assert_eq!(
        x,
        Values::Bits(vec![false, false, false, true, false, false, false, false])
    );
    h.write_registers(at("R1E"), Values::Bits(vec![true, true]))
        .await
        .unwrap();
    h.write_registers(at("Y3"), Values::Bits(vec![true]))
        .await
        .unwrap();
    shared.with(|m| {
        assert!(m.read_bit(Area::R, 0x1E).unwrap() && m.read_bit(Area::R, 0x1F).unwrap());
        assert!(!m.read_bit(Area::R, 0x1D).unwrap());
        assert!(m.read_bit(Area::Y, 3).unwrap());
    });
    assert_eq!(
        h.read_registers(at("Y0"), 4).await.unwrap(),
        Values::Bits(vec![false, false, false, true])
    );

    // The status block is readable where listed: its first word is the contract's magic.
    let Values::Words(status) = h.read_registers(at("DT1000"), 1).await.unwrap() else {
        panic!("words")
    };
    assert_eq!(status[0], linterpd::contract::MAGIC);

    let stats = h.state().gateway;
    assert_eq!((stats.requests, stats.failed), (7, 0), "{stats:?}");
    assert!(
        stats.exchanges > 7,
        "the 600-word read took several exchanges: {stats:?}"
    );
    // The lifetime counters of /metrics count the same requests; one more adds one.
    let metric = |name: &str| -> u64 {
        let text = h.metrics().encode();
        let line = format!("{name}{{robot=\"press-loader\"}} ");
        text.lines()
            .find_map(|l| l.strip_prefix(line.as_str()))
            .unwrap_or_else(|| panic!("no {line:?} in\n{text}"))
            .parse()
            .unwrap()
    };
    assert_eq!(metric("linterpd_gateway_requests_total"), 7);
    assert_eq!(metric("linterpd_gateway_errors_total"), 0);
    h.read_registers(at("DT5"), 1).await.unwrap();
    assert_eq!(metric("linterpd_gateway_requests_total"), 8);
    d.shut_down().await;
}

#[tokio::test]
async fn what_the_list_does_not_allow_never_reaches_the_plc() {
    let shared = mock_at_seed_start("");
    let (d, h) = spawn(duplex_connector(&shared, None));
    wait_connected(&h).await;
    let before_tables = words(&shared, 1_032, 17);

    let refused = [
        // A write to the command block: not writable, whatever the list.
        (at("DT1032"), Values::Words(vec![1])),
        // Half inside the writable range, half out.
        (at("DT190"), Values::Words(vec![7; 20])),
        // X is read-only.
        (at("X0"), Values::Bits(vec![true])),
        // Y8 is readable, not writable.
        (at("Y8"), Values::Bits(vec![true])),
    ];
    for (start, values) in refused {
        let e = h.write_registers(start, values).await.unwrap_err();
        assert!(matches!(e, GatewayError::Denied(_)), "{start}: {e}");
    }
    assert_eq!(words(&shared, 1_032, 17), before_tables);
    assert_eq!(words(&shared, 190, 20), vec![0; 20]);
    shared.with(|m| {
        assert!(!m.read_bit(Area::Y, 8).unwrap());
    });

    // Reads outside the list, counts out of bounds, values of the wrong kind.
    let e = h.read_registers(at("DT2000"), 1).await.unwrap_err();
    assert!(e.to_string().contains("DT2000"), "names the address: {e}");
    assert!(matches!(e, GatewayError::Denied(_)), "{e}");
    for count in [0, 1_001] {
        let e = h.read_registers(at("DT0"), count).await.unwrap_err();
        assert!(matches!(e, GatewayError::BadRequest(_)), "{count}: {e}");
    }
    let e = h
        .write_registers(at("R10"), Values::Words(vec![1]))
        .await
        .unwrap_err();
    assert!(e.to_string().contains("R holds bits"), "{e}");

    assert_eq!(h.state().gateway.exchanges, 0, "nothing refused was sent");
    d.shut_down().await;
}

#[tokio::test]
async fn a_link_that_is_down_is_said_so_at_once() {
    let connect: Connector = Box::new(|| {
        Box::pin(async {
            Err(linterpd::plc::PlcError::Link {
                operation: "connect".into(),
                source: std::io::Error::new(std::io::ErrorKind::ConnectionRefused, "refused"),
            })
        })
    });
    let (d, h) = spawn(connect);
    let began = tokio::time::Instant::now();
    let e = h.read_registers(at("DT0"), 1).await.unwrap_err();
    assert!(matches!(e, GatewayError::LinkDown { .. }), "{e}");
    assert!(
        e.to_string().contains("refused"),
        "names the link's error: {e}"
    );
    assert!(
        began.elapsed() < Duration::from_secs(6),
        "within one reconnection backoff"
    );
    d.shut_down().await;
}

#[tokio::test(start_paused = true)]
async fn a_move_runs_to_its_target_while_a_client_keeps_the_gateway_busy() {
    let shared = mock_at_seed_start("");
    // 19200 baud: a gateway exchange takes as long as it would on the shipped serial link.
    let (d, h) = spawn(duplex_connector(&shared, Some(19_200)));
    wait_connected(&h).await;

    let client = {
        let h = h.clone();
        tokio::spawn(async move {
            let mut rounds = 0_u16;
            loop {
                let values: Vec<u16> = (0..24).map(|i| rounds.wrapping_add(i)).collect();
                if h.write_registers(at("DT100"), Values::Words(values.clone()))
                    .await
                    .is_err()
                {
                    return rounds;
                }
                match h.read_registers(at("DT100"), 24).await {
                    Ok(read) => assert_eq!(read, Values::Words(values), "reads what it wrote"),
                    Err(_) => return rounds,
                }
                rounds = rounds.wrapping_add(1);
            }
        })
    };

    let id = h
        .submit(MoveOrder {
            to: Some(P2.to_vec()),
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    let mut feed = h.subscribe(id).unwrap();
    let limit = Duration::from_secs(60);
    tokio::time::timeout(limit, feed.wait_for(|r| r.stage == Stage::Running))
        .await
        .unwrap()
        .unwrap();
    let at_start = h.state().gateway;
    let report = h.wait(id, limit).await.unwrap();
    let at_end = h.state().gateway;
    assert_eq!(report.stage, Stage::Done, "{report:?}");
    let e = report.final_error_pulses.expect("final counts compared");
    assert!(e.iter().all(|p| p.abs() <= 1), "{e:?}");

    d.shut_down().await;
    let rounds = client.await.unwrap();
    println!(
        "gateway while moving: {at_end:?}; {} requests while the move ran {:.2} s; {rounds} client rounds",
        at_end.requests - at_start.requests,
        report.motion_s.unwrap_or_default()
    );
    assert!(
        at_end.requests - at_start.requests >= 4,
        "the client was served while the move ran: {at_start:?} -> {at_end:?}"
    );
    assert_eq!(at_end.failed, 0, "{at_end:?}");
    // A due status read waits for the gateway exchange under way, never for a second one.
    assert!(
        at_end.longest_poll_delay_ms <= at_end.longest_exchange_ms,
        "{at_end:?}"
    );
}
