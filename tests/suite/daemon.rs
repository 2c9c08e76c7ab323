//! The daemon's move path end to end against the mock PLC: the same code a real PLC gets.

use crate::common;

use std::time::Duration;

use common::daemon::{
    duplex_connector, mewtocol_options, report_until, taking_moves as wait_connected,
};
use common::exchange::{P1, P2, mock_at_seed_start};
use linterpd::contract::Layout;
use linterpd::contract::machine::Blocker;
use linterpd::daemon::{Connector, Daemon, MoveOrder, MoveReport, RobotHandle, Stage, SubmitError};
use linterpd::mock::{
    MewtocolServer, MewtocolServerOptions, ModbusServer, ModbusServerOptions, SharedMock,
};
use linterpd::order::OrderMotion;
use linterpd::plc::exchange::ContractSettings;
use linterpd::plc::{
    AnyPlc, BoxedLink, MewtocolClient, ModbusClient, ModbusFraming, ModbusOptions, PlcMode,
};
use linterpd::wire::RobotState;
use tokio::net::{TcpListener, TcpStream};

const LIMIT: Duration = Duration::from_secs(15);

/// Every link the daemon reaches a PLC by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Link {
    MewtocolDuplex,
    MewtocolTcp,
    MewtocolPty,
    ModbusTcp,
    ModbusRtuPty,
}

const LINKS: [Link; 5] = [
    Link::MewtocolDuplex,
    Link::MewtocolTcp,
    Link::MewtocolPty,
    Link::ModbusTcp,
    Link::ModbusRtuPty,
];

fn link_error(operation: &str, e: std::io::Error) -> linterpd::plc::PlcError {
    linterpd::plc::PlcError::Link {
        operation: operation.into(),
        source: e,
    }
}

/// A connector to the mock over `link`: every (re)connection is a new connection (TCP), a new
/// pseudo-terminal pair (a real tty, through tokio-serial) or a new `duplex`.
fn connector(link: Link, shared: &SharedMock, baud: Option<u32>) -> Connector {
    if link == Link::MewtocolDuplex {
        return duplex_connector(shared, baud);
    }
    let std_listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    std_listener.set_nonblocking(true).unwrap();
    let address = std_listener.local_addr().unwrap();
    match link {
        Link::MewtocolTcp => {
            let server = MewtocolServer::new(
                shared.clone(),
                MewtocolServerOptions {
                    baud,
                    ..MewtocolServerOptions::default()
                },
            );
            tokio::spawn(server.serve_tcp(TcpListener::from_std(std_listener).unwrap()));
        }
        Link::ModbusTcp => {
            let server = ModbusServer::new(
                shared.clone(),
                ModbusServerOptions {
                    baud,
                    ..ModbusServerOptions::default()
                },
            );
            tokio::spawn(server.serve_tcp(TcpListener::from_std(std_listener).unwrap()));
        }
        _ => {}
    }
    let shared = shared.clone();
    Box::new(move || {
        let shared = shared.clone();
        Box::pin(async move {
            Ok(match link {
                Link::MewtocolTcp | Link::ModbusTcp => {
                    let stream: BoxedLink = Box::new(
                        TcpStream::connect(address)
                            .await
                            .map_err(|e| link_error("connect", e))?,
                    );
                    if link == Link::ModbusTcp {
                        AnyPlc::Modbus(ModbusClient::new(
                            stream,
                            ModbusOptions::new(ModbusFraming::Tcp, 1),
                        ))
                    } else {
                        AnyPlc::Mewtocol(MewtocolClient::new(stream, mewtocol_options()))
                    }
                }
                _ => {
                    let (ours, theirs) = tokio_serial::SerialStream::pair()
                        .map_err(|e| link_error("open a pty pair", e.into()))?;
                    let stream: BoxedLink = Box::new(ours);
                    if link == Link::ModbusRtuPty {
                        tokio::spawn(
                            ModbusServer::new(shared, ModbusServerOptions::default())
                                .serve_rtu(theirs),
                        );
                        AnyPlc::Modbus(ModbusClient::new(
                            stream,
                            ModbusOptions::new(ModbusFraming::Rtu, 1),
                        ))
                    } else {
                        let server = MewtocolServer::new(shared, MewtocolServerOptions::default());
                        tokio::spawn(async move { server.serve(theirs).await });
                        AnyPlc::Mewtocol(MewtocolClient::new(stream, mewtocol_options()))
                    }
                }
            })
        })
    })
}

fn daemon(connect: Connector, settings: ContractSettings) -> (Daemon, RobotHandle) {
    common::daemon::spawn(connect, settings)
}

fn order(p: [f64; 3]) -> MoveOrder {
    MoveOrder {
        to: Some(p.to_vec()),
        ..MoveOrder::default()
    }
}

/// `order`'s move at `speed_mm_s`: for a test that must act on it while it runs, slow enough
/// that a test thread woken late (24 tests at a time on 2 cores) still finds it running.
fn slow(speed_mm_s: f64, order: MoveOrder) -> MoveOrder {
    MoveOrder {
        motion: OrderMotion {
            speed_mm_s: Some(speed_mm_s),
            ..order.motion
        },
        ..order
    }
}

async fn run(h: &RobotHandle, p: [f64; 3]) -> MoveReport {
    let id = h.submit(order(p)).await.unwrap();
    h.wait(id, LIMIT).await.unwrap()
}

fn assert_on_target(r: &MoveReport) {
    assert_eq!(r.stage, Stage::Done, "{r:?}");
    let e = r.final_error_pulses.expect("final counts compared");
    assert!(e.iter().all(|p| p.abs() <= 1), "{e:?}");
}

/// Nothing was written into the table areas or the command word.
fn assert_nothing_written(shared: &SharedMock) {
    let (tables, command) = shared.with(|m| {
        (
            m.read_words(2_000, 16_000).unwrap(),
            m.read_words(1_032, 8).unwrap(),
        )
    });
    assert!(tables.iter().all(|w| *w == 0), "table words were written");
    assert!(
        command.iter().all(|w| *w == 0),
        "command block was written: {command:?}"
    );
}

#[tokio::test]
async fn moves_end_on_their_targets_over_every_link() {
    for link in LINKS {
        let shared = mock_at_seed_start("");
        let (d, h) = daemon(connector(link, &shared, None), ContractSettings::default());
        wait_connected(&h).await;
        let there = run(&h, P2).await;
        assert_on_target(&there);
        assert!(there.predicted.unwrap().path_deviation_mm < 0.1, "{link:?}");
        assert_on_target(&run(&h, P1).await);
        d.shut_down().await;
    }
}

#[tokio::test]
async fn two_queued_moves_run_back_to_back_without_a_host_round_trip() {
    // The serial-line emulation makes an upload take about 0.3 s at 115200 baud: a start after a
    // host round trip would leave a gap that long between the moves. (Over a pty there is no
    // emulation; the gap is checked all the same.)
    for link in LINKS {
        let shared = mock_at_seed_start("");
        shared.with(|m| m.record_pulses(true));
        let (d, h) = daemon(
            connector(link, &shared, Some(115_200)),
            ContractSettings::default(),
        );
        wait_connected(&h).await;
        let a = h.submit(order(P2)).await.unwrap();
        let b = h.submit(order(P1)).await.unwrap();
        let rb = h.wait(b, LIMIT).await.unwrap();
        let ra = h.report(a).unwrap();
        assert_eq!(ra.stage, Stage::Done, "{link:?} {ra:?}");
        assert_on_target(&rb);
        // d3 (channel 2) goes out with A and back with B: the gap between its last pulse going
        // out and its first coming back.
        let pulses: Vec<_> = shared
            .with(linterpd::mock::MockPlc::take_pulses)
            .into_iter()
            .filter(|p| p.channel == 2)
            .collect();
        let turn = pulses
            .windows(2)
            .position(|w| w[1].count < w[0].count)
            .expect("d3 comes back");
        let gap = pulses[turn + 1].time_s - pulses[turn].time_s;
        assert!(gap < 0.03, "{link:?}: gap {gap} s between the moves");
        d.shut_down().await;
    }
}

#[tokio::test]
async fn stop_mid_move_stops_every_channel() {
    for link in LINKS {
        let shared = mock_at_seed_start("");
        let (d, h) = daemon(connector(link, &shared, None), ContractSettings::default());
        wait_connected(&h).await;
        // A slow move (about 5.5 s), stopped a tenth of the way: on a loaded machine the test
        // may be woken late, and the move must still be running when it is.
        let id = h.submit(slow(60.0, order(P2))).await.unwrap();
        let mut feed = h.subscribe(id).unwrap();
        report_until(&mut feed, "running, 10 % done", |r| {
            r.stage == Stage::Running && r.progress > 0.1
        })
        .await;
        h.stop().await.unwrap();
        let r = h.wait(id, LIMIT).await.unwrap();
        assert_eq!(r.stage, Stage::Stopped, "{link:?} {r:?}");
        // The PLC program acts on the stop command in its next scan (2 ms).
        tokio::time::sleep(Duration::from_millis(10)).await;
        let before = shared.with(|m| m.status());
        tokio::time::sleep(Duration::from_millis(100)).await;
        let after = shared.with(|m| m.status());
        assert_eq!(after.busy, 0, "{link:?}");
        assert_eq!(
            before.elapsed, after.elapsed,
            "{link:?}: a channel still moves"
        );
        assert_eq!(after.state, linterpd::contract::State::Stopped.word());
        d.shut_down().await;
    }
}

/// An order is refused at once, naming why, once the daemon has seen the PLC (`seen`: its
/// state shows what it saw; a heartbeat standing still is known after its timeout); nothing
/// is written.
async fn refused(
    link: Link,
    shared: &SharedMock,
    settings: ContractSettings,
    (want, seen): (&str, fn(&RobotState) -> bool),
) {
    let (d, h) = daemon(connector(link, shared, None), settings);
    for _ in 0..1_000 {
        if seen(&h.state()) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let e = h.submit(order(P2)).await.unwrap_err();
    assert!(matches!(e, SubmitError::NotNow { .. }), "{link:?}: {e:?}");
    assert!(e.to_string().contains(want), "{link:?}: {e}");
    assert!(h.reports().is_empty(), "nothing queued");
    assert_nothing_written(shared);
    d.shut_down().await;
}

#[tokio::test]
async fn prog_mode_frozen_heartbeat_and_wrong_magic_are_refused_and_nothing_is_written() {
    let prog = |s: &RobotState| s.plc_mode == Some(PlcMode::Prog) && s.refuses.is_some();
    let stalled = |s: &RobotState| s.refuses == Some(Blocker::Stalled.to_string());
    let magic = |s: &RobotState| s.link.error.as_ref().is_some_and(|e| e.contains("magic"));
    for link in LINKS {
        let shared = mock_at_seed_start("");
        shared.with(|m| m.set_mode(PlcMode::Prog));
        // Over Modbus the mode comes from the RUN relay R9020, which the mock keeps.
        let settings = ContractSettings::default();
        refused(link, &shared, settings, ("it reports PROG mode", prog)).await;
        let shared = mock_at_seed_start("");
        shared.with(|m| m.freeze_heartbeat(true));
        refused(link, &shared, settings, ("the PLC is stalled", stalled)).await;
        let shared = mock_at_seed_start("");
        let elsewhere = Layout {
            status_base: 30_000,
            ..Layout::default()
        };
        let settings = ContractSettings {
            layout: elsewhere,
            ..ContractSettings::default()
        };
        refused(link, &shared, settings, ("magic is 0x0000", magic)).await;
    }
}

#[tokio::test]
async fn link_cut_during_upload_starts_nothing_and_the_next_move_works_after_reconnection() {
    for link in LINKS {
        let shared = mock_at_seed_start("");
        let (d, h) = daemon(connector(link, &shared, None), ContractSettings::default());
        wait_connected(&h).await;
        let before = shared.with(|m| m.status());
        // Past check_alive's status reads (and an idle poll that may come first): inside the
        // bank writes and read-backs. A cut serial line is replies that stop coming (three in a
        // row, more than the client retries); a cut connection is a close.
        shared.with(|m| {
            let k = m.commands() + 8;
            let script = if link == Link::ModbusRtuPty {
                format!("drop@{k},drop@{},drop@{}", k + 1, k + 2)
            } else {
                format!("close@{k}")
            };
            m.set_faults(script.parse().unwrap());
        });
        let r = run(&h, P2).await;
        assert_eq!(r.stage, Stage::Failed, "{link:?} {r:?}");
        let after = shared.with(|m| (m.status(), m.read_words(1_032, 1).unwrap()[0]));
        assert_eq!(after.1, 0, "{link:?}: a start command was written");
        assert_eq!(after.0.elapsed, before.elapsed);
        assert_eq!(after.0.busy, 0);
        wait_connected(&h).await;
        assert_on_target(&run(&h, P2).await);
        assert!(h.state().link.reconnects >= 1, "{link:?}: {:?}", h.state());
        d.shut_down().await;
    }
}

#[tokio::test]
async fn a_daemon_restarted_mid_move_reports_the_moves_true_state() {
    for link in LINKS {
        let shared = mock_at_seed_start("");
        let (first, h) = daemon(connector(link, &shared, None), ContractSettings::default());
        wait_connected(&h).await;
        let id = h.submit(slow(120.0, order(P2))).await.unwrap();
        report_until(&mut h.subscribe(id).unwrap(), "running", |r| {
            r.stage == Stage::Running
        })
        .await;
        while shared.with(|m| m.status().state) != linterpd::contract::State::Running.word() {
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
        first.shut_down().await;
        let (second, h2) = daemon(connector(link, &shared, None), ContractSettings::default());
        wait_connected(&h2).await;
        // Connected (with counts) can come a status block before the running move is taken
        // over (the phase still "link-down" while the host word is confirmed): wait for it.
        for _ in 0..500 {
            let s = h2.state();
            if s.current_move.is_some() || s.phase != linterpd::daemon::RobotPhase::LinkDown {
                break;
            }
            tokio::time::sleep(Duration::from_millis(2)).await;
        }
        let state = h2.state();
        let found = state
            .current_move
            .unwrap_or_else(|| panic!("{link:?}: the running move is not found: {state:?}"));
        let r = h2.report(found).unwrap();
        assert!(r.recovered && r.stage == Stage::Running, "{link:?} {r:?}");
        let seq = shared.with(|m| m.status().seq);
        assert_eq!(r.seq, Some(seq));
        let r = h2.wait(found, LIMIT).await.unwrap();
        assert_eq!(r.stage, Stage::Done, "{link:?}");
        second.shut_down().await;
    }
}

#[tokio::test]
async fn bad_orders_are_refused_and_nothing_is_queued() {
    let shared = mock_at_seed_start("");
    let (d, h) = daemon(duplex_connector(&shared, None), ContractSettings::default());
    wait_connected(&h).await;
    let e = h
        .submit(MoveOrder {
            to: Some(vec![1.0, 2.0]),
            ..MoveOrder::default()
        })
        .await
        .unwrap_err();
    assert!(e.to_string().starts_with("to = [1.0, 2.0]"), "{e}");
    let e = h
        .submit(order([-1144.43, 659.60, 500.0]))
        .await
        .unwrap_err();
    assert!(e.to_string().contains("joint d2 would reach"), "{e}");
    assert!(h.state().queued.is_empty());
    assert!(h.reports().is_empty());
    d.shut_down().await;
}

#[tokio::test]
async fn while_the_link_is_down_orders_are_refused_and_a_stop_answers_at_once() {
    let shared = mock_at_seed_start("");
    // A PLC that never answers the connection: every connect fails.
    let connect: Connector = Box::new(|| {
        Box::pin(async {
            Err(linterpd::plc::PlcError::Link {
                operation: "connect".into(),
                source: std::io::Error::new(std::io::ErrorKind::ConnectionRefused, "refused"),
            })
        })
    });
    let (d, h) = daemon(connect, ContractSettings::default());
    tokio::time::sleep(Duration::from_millis(50)).await;
    let e = h.submit(order(P2)).await.unwrap_err();
    assert!(
        e.to_string()
            .starts_with("the PLC link is down: link failed during connect: refused"),
        "{e}"
    );
    let answer = tokio::time::timeout(Duration::from_secs(7), h.stop())
        .await
        .expect("the stop answers");
    let e = answer.unwrap_err().to_string();
    assert!(e.contains("link is down"), "{e}");
    assert!(h.reports().is_empty());
    assert_nothing_written(&shared);
    d.shut_down().await;
}

/// The shipped config as it is (19200 baud, `header = "auto"`, `timeout = "300ms"`), its serial
/// path pointed at a pseudo-terminal whose other end the mock serves at an emulated 19200 baud:
/// the seed's move runs to its target. The exchange timeouts follow the line's speed, so a long
/// `<` read is not cut off and no late reply is taken for the next request.
#[tokio::test]
async fn the_shipped_config_moves_over_a_19200_baud_line() {
    let shipped = include_str!("../../config/linterpd.toml");
    let (mut master, slave) = tokio_serial::SerialStream::pair().unwrap();
    let path = tokio_serial::SerialPort::name(&slave).expect("the pty's path");
    // The daemon opens the path itself (exclusively), so this end is closed first.
    drop(slave);
    let config = shipped.replace("/dev/ttyUSB0", &path);
    assert_ne!(config, shipped, "the shipped config names /dev/ttyUSB0");
    let config = linterpd::config::Config::from_toml(&config).unwrap();
    let shared = mock_at_seed_start("");
    let server = MewtocolServer::new(
        shared.clone(),
        MewtocolServerOptions {
            baud: Some(19_200),
            ..MewtocolServerOptions::default()
        },
    );
    // Until the daemon opens its end, reading the master fails: serve again.
    tokio::spawn(async move {
        loop {
            let _ = server.serve(&mut master).await;
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    });
    let robots = linterpd::daemon::service::robots_from_config(&config).unwrap();
    let d = Daemon::spawn(robots, &linterpd::daemon::DaemonOptions::default());
    let h = d.robot("press-loader").unwrap().clone();
    wait_connected(&h).await;
    let r = run(&h, P2).await;
    assert_on_target(&r);
    println!(
        "seed's move at 19200 baud over a pty: upload and verify {:.2} s, motion {:.2} s",
        r.upload_s.unwrap(),
        r.motion_s.unwrap()
    );
    d.shut_down().await;
}

/// A connector that never returns: the worker hangs in it.
fn hanging_connector() -> Connector {
    Box::new(|| Box::pin(std::future::pending()))
}

#[tokio::test(start_paused = true)]
async fn a_worker_that_hangs_makes_the_daemon_unhealthy_and_one_that_panics_is_reported() {
    use linterpd::daemon::service::healthy;
    let shared = mock_at_seed_start("");
    let (good, _) = daemon(duplex_connector(&shared, None), ContractSettings::default());
    let (stuck, _) = daemon(hanging_connector(), ContractSettings::default());
    tokio::time::sleep(Duration::from_secs(20)).await;
    let limit = Duration::from_secs(15);
    assert!(healthy(good.robots(), limit), "a working worker beats");
    assert!(!healthy(stuck.robots(), limit), "a hung worker does not");
    good.shut_down().await;
    stuck.kill().await;

    let panicking: Connector = Box::new(|| panic!("a bug in a connector"));
    let (mut d, _) = daemon(panicking, ContractSettings::default());
    let why = tokio::time::timeout(Duration::from_secs(5), d.worker_failed())
        .await
        .expect("the failure is reported");
    assert!(why.contains("panicked"), "{why}");
}

/// A move queued behind a running one is uploaded while that one runs, for seconds on a slow
/// line (752 words: about 4.7 s at 19200 baud): the running move stays watched through it. Its
/// heartbeat freezing early in that upload stops it where it is, long before its end (2.6 s
/// of motion), where a daemon blind until the upload ended would have let it run out; the
/// queued move's upload is given up there, and it never starts.
#[tokio::test]
async fn a_running_move_stays_watched_while_the_next_one_uploads() {
    let shared = mock_at_seed_start("");
    let (d, h) = daemon(
        duplex_connector(&shared, Some(19_200)),
        ContractSettings::default(),
    );
    wait_connected(&h).await;
    let a = h
        .submit(MoveOrder {
            motion: OrderMotion {
                speed_mm_s: Some(120.0),
                tolerance_mm: Some(0.05),
                ..OrderMotion::default()
            },
            ..order(P2)
        })
        .await
        .unwrap();
    let b = h
        .submit(MoveOrder {
            motion: OrderMotion {
                period: Some("20ms".into()),
                ..OrderMotion::default()
            },
            ..order(P1)
        })
        .await
        .unwrap();
    // Seen running, `a` has `b`'s upload begin behind it.
    for _ in 0..1_000 {
        if h.report(a).is_some_and(|r| r.stage == Stage::Running) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert_eq!(h.report(a).unwrap().stage, Stage::Running);
    tokio::time::sleep(Duration::from_millis(200)).await;
    shared.with(|m| m.freeze_heartbeat(true));
    let ra = h.wait(a, LIMIT).await.unwrap();
    assert_ne!(ra.stage, Stage::Done, "{ra:?}");
    // The stop follows the report within an exchange or two.
    let stopped = linterpd::contract::State::Stopped.word();
    for _ in 0..100 {
        if shared.with(|m| m.status().state) == stopped {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let status = shared.with(|m| m.status());
    assert_eq!(status.state, stopped, "{status:?}");
    assert_eq!(status.busy, 0);
    let targets = ra.target_counts.expect("planned");
    let robot = h.robot();
    let short = (0..4).any(|j| {
        let c = usize::from(robot.joints[j].channel);
        (shared.with(|m| m.count(c)) - targets[j]).abs() > 100
    });
    assert!(
        short,
        "stopped only at its end: {status:?}, targets {targets:?}"
    );
    let rb = h.wait(b, LIMIT).await.unwrap();
    assert_ne!(rb.stage, Stage::Done, "{rb:?}");
    // Given up at the watch read that saw the PLC stalled, not written to its end first.
    let why = rb.error.as_deref().unwrap_or_default();
    assert!(why.contains("heartbeat stands still"), "{rb:?}");
    assert_eq!(rb.upload_s, None, "{rb:?}");
    assert_ne!(shared.with(|m| m.read_words(1_032, 1).unwrap()[0]), 1);
    d.shut_down().await;
}

/// Counts per channel the mock's engines hold now.
fn engine_counts(shared: &SharedMock) -> [i64; 4] {
    shared.with(|m| std::array::from_fn(|c| m.count(c)))
}

/// Issue 25: a move to the pose the running move will end on, queued behind it (zero length
/// from the planned end), ended `done` at once while the move ahead was at 1 %, and still said
/// `done` at the target after the move ahead was stopped far from it.
#[tokio::test]
async fn a_move_with_no_motion_behind_a_running_move_is_not_done_before_it() {
    // The move ahead ends done: the one behind it ends done with it, at its counts.
    let shared = mock_at_seed_start("");
    let (d, h) = daemon(duplex_connector(&shared, None), ContractSettings::default());
    wait_connected(&h).await;
    let ahead = h.submit(order(P2)).await.unwrap();
    let same = h.submit(order(P2)).await.unwrap();
    let mut feed = h.subscribe(ahead).unwrap();
    report_until(&mut feed, "running", |r| r.stage == Stage::Running).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    let behind = h.report(same).unwrap();
    assert!(
        !behind.stage.is_final(),
        "ended while the move ahead runs: {behind:?}"
    );
    let ahead = h.wait(ahead, LIMIT).await.unwrap();
    assert_on_target(&ahead);
    let behind = h.wait(same, LIMIT).await.unwrap();
    assert_eq!(behind.stage, Stage::Done, "{behind:?}");
    assert_eq!(behind.target_counts, ahead.target_counts);
    assert_eq!(behind.target_counts, Some(engine_counts(&shared)));
    assert_eq!(behind.final_error_pulses, Some([0; 4]));
    assert_eq!(shared.with(|m| m.starts().len()), 1, "no start of its own");
    d.shut_down().await;

    // The move ahead is stopped: the one behind it is not done.
    let shared = mock_at_seed_start("");
    let (d, h) = daemon(duplex_connector(&shared, None), ContractSettings::default());
    wait_connected(&h).await;
    let ahead = h.submit(slow(120.0, order(P2))).await.unwrap();
    let same = h.submit(order(P2)).await.unwrap();
    let mut feed = h.subscribe(ahead).unwrap();
    report_until(&mut feed, "running", |r| r.stage == Stage::Running).await;
    h.stop().await.unwrap();
    let ahead = h.wait(ahead, LIMIT).await.unwrap();
    assert_eq!(ahead.stage, Stage::Stopped, "{ahead:?}");
    let behind = h.wait(same, LIMIT).await.unwrap();
    assert_eq!(behind.stage, Stage::Cancelled, "{behind:?}");
    assert_ne!(behind.target_counts, Some(engine_counts(&shared)));
    d.shut_down().await;
}

/// Issue 25: a move to exactly the current pose was refused 422 "length 0" while one 0.001 mm
/// away ended done: both end done, without a start.
#[tokio::test]
async fn a_move_to_exactly_the_current_pose_ends_done_without_a_start() {
    let shared = mock_at_seed_start("");
    let (d, h) = daemon(duplex_connector(&shared, None), ContractSettings::default());
    wait_connected(&h).await;
    while h.state().counts != Some(engine_counts(&shared)) {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let here = h.state().pose.unwrap();
    for to in [
        here.to_vec(),
        vec![here[0] + 0.001, here[1], here[2], here[3]],
    ] {
        let id = h
            .submit(MoveOrder {
                to: Some(to),
                ..MoveOrder::default()
            })
            .await
            .unwrap();
        let report = h.wait(id, LIMIT).await.unwrap();
        assert_eq!(report.stage, Stage::Done, "{report:?}");
        assert_eq!(report.final_error_pulses, Some([0; 4]), "{report:?}");
    }
    // A joint move to the joints' values where they stand.
    let counts = engine_counts(&shared);
    let joints = linterpd::robot::seed_robot().values_of(&counts);
    let robot = linterpd::robot::seed_robot();
    let user: Vec<f64> = (0..4)
        .map(|j| robot.joints[j].kind.to_user(joints[j]))
        .collect();
    let id = h
        .submit(MoveOrder {
            joints: Some(user),
            ..MoveOrder::default()
        })
        .await
        .unwrap();
    assert_eq!(h.wait(id, LIMIT).await.unwrap().stage, Stage::Done);
    assert!(shared.with(|m| m.starts().is_empty()), "nothing started");
    assert_nothing_written(&shared);
    d.shut_down().await;
}

/// Issue 25: a move whose link died reported `deadline_s` 7.75 s but ended failed after
/// 11.3 s (the worker looked only at its reconnection backoff), and the CLI, waiting the
/// deadline and 2 s, gave up first. The link closes while the move runs and never opens
/// again (each attempt hangs): the move ends failed within the deadline its running report
/// gave, counted from that report.
#[tokio::test(start_paused = true)]
async fn a_move_whose_link_dies_ends_by_the_deadline_its_report_gave() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let shared = mock_at_seed_start("");
    let opened = std::sync::Arc::new(AtomicUsize::new(0));
    let first = duplex_connector(&shared, None);
    let first = std::sync::Arc::new(tokio::sync::Mutex::new(first));
    let connect: Connector = {
        let opened = std::sync::Arc::clone(&opened);
        Box::new(move || {
            let (opened, first) = (
                std::sync::Arc::clone(&opened),
                std::sync::Arc::clone(&first),
            );
            Box::pin(async move {
                if opened.fetch_add(1, Ordering::SeqCst) == 0 {
                    let mut connect = first.lock().await;
                    (*connect)().await
                } else {
                    std::future::pending().await
                }
            })
        })
    };
    let (d, h) = daemon(connect, ContractSettings::default());
    wait_connected(&h).await;
    let id = h.submit(slow(120.0, order(P2))).await.unwrap();
    let mut feed = h.subscribe(id).unwrap();
    let running = report_until(&mut feed, "running", |r| r.stage == Stage::Running).await;
    let seen = tokio::time::Instant::now();
    let deadline = Duration::from_secs_f64(running.deadline_s.unwrap());
    let next = shared.with(|m| m.commands()) + 1;
    shared.with(|m| m.set_faults(format!("close@{next}").parse().unwrap()));
    let ended = h.wait(id, Duration::from_secs(60)).await.unwrap();
    let took = seen.elapsed();
    assert_eq!(ended.stage, Stage::Failed, "{ended:?}");
    assert!(
        took <= deadline,
        "ended after {took:?}, its report gave {deadline:?}"
    );
    assert!(opened.load(Ordering::SeqCst) >= 2, "it tried to reconnect");
    d.kill().await;
}

/// When the mock played each pulse of `channel` since the last take, s on its clock.
fn pulse_times(shared: &SharedMock, channel: u8) -> Vec<f64> {
    shared
        .with(linterpd::mock::MockPlc::take_pulses)
        .into_iter()
        .filter(|p| p.channel == channel)
        .map(|p| p.time_s)
        .collect()
}

/// A daemon on the seed's robot whose d3 drive follows `max_accel_mm_s2` and starts at 1 kHz,
/// against a mock at the seed's start recording its pulses.
async fn d3_limited(max_accel_mm_s2: f64) -> (SharedMock, Daemon, RobotHandle) {
    let mut robot = linterpd::robot::seed_robot();
    robot.joints[2].dynamics = linterpd::robot::Dynamics {
        max_accel: Some(max_accel_mm_s2),
        start_hz: Some(1_000.0),
        max_jerk: None,
    };
    daemon_for(robot).await
}

/// A daemon on `robot` against a mock at the seed's start recording its pulses.
async fn daemon_for(robot: linterpd::robot::Robot) -> (SharedMock, Daemon, RobotHandle) {
    let shared = mock_at_seed_start("");
    shared.with(|m| m.record_pulses(true));
    let (d, h) = common::daemon::spawn_robot(
        duplex_connector(&shared, None),
        ContractSettings::default(),
        &linterpd::daemon::DaemonOptions::default(),
        [0; linterpd::kinematics::JOINTS],
        robot,
    );
    wait_connected(&h).await;
    (shared, d, h)
}

/// d3's pulses on the PLC keep its drive's limits: it leaves standstill and comes to it at no
/// more than 1 kHz over its first and last 50 ms (a pulse of rounding aside), and its speed
/// changes by no more than `max_accel_mm_s2` allows between two 50 ms windows (two pulses of
/// rounding). A time-optimal motion's last row lasts up to a period and a half (PLANNING.md),
/// and a row step is judged over the two rows' mean length: into the last row, up to 1.25
/// periods' worth. Returns the time from its first pulse to its last, s.
fn assert_d3_within(shared: &SharedMock, max_accel_mm_s2: f64) -> f64 {
    let times = pulse_times(shared, 2);
    let (first, last) = (times[0], times[times.len() - 1]);
    let within = |from: f64, to: f64| times.iter().filter(|&&t| t >= from && t < to).count();
    assert!(
        within(first, first + 0.05) <= 51,
        "{} pulses",
        within(first, first + 0.05)
    );
    assert!(within(last - 0.05, last + 1e-9) <= 51);
    let windows = ((last - first) / 0.05).ceil() as u32;
    let per_window: Vec<usize> = (0..windows)
        .map(|k| first + 0.05 * f64::from(k))
        .map(|t| within(t, t + 0.05))
        .collect();
    // At 0.013 mm a pulse, over 50 ms: 1000 mm/s^2 is 3846 Hz, 192 pulses a window.
    let allowed = (max_accel_mm_s2 / 0.013 * 0.05 * 0.05).round() as usize + 4;
    let into_last_row = |k: usize| first + 0.05 * k as f64 >= last - 0.075;
    for (k, w) in per_window.windows(2).enumerate() {
        let allowed = if into_last_row(k + 1) {
            allowed + allowed / 4
        } else {
            allowed
        };
        assert!(w[0].abs_diff(w[1]) <= allowed, "{per_window:?}");
    }
    last - first
}

#[tokio::test]
async fn a_robot_with_drive_limits_runs_its_moves_within_them_on_the_plc() {
    // d3's drive follows 1000 mm/s^2 and starts at 1 kHz: without the limits its first 50 ms
    // row runs at about 2 kHz from rest.
    let (shared, d, h) = d3_limited(1_000.0).await;
    let there = run(&h, P2).await;
    assert_on_target(&there);
    assert_d3_within(&shared, 1_000.0);
    d.shut_down().await;
}

#[tokio::test]
async fn an_s_curve_order_on_a_robot_with_drive_limits_runs_within_them_on_the_plc() {
    // d3's drive follows 300 mm/s^2 and starts at 1 kHz; the seed's move asked with S-curve
    // ramps of 20000 mm/s^3 is its time-optimal motion averaged to that jerk: 1.923 s, where
    // slowing the S-curve as a whole took 2.600 s (PLANNING.md, "S-curve ramps").
    let (shared, d, h) = d3_limited(300.0).await;
    let start = shared.with(|m| std::array::from_fn(|c| m.count(c)));
    while h.state().counts != Some(start) {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let mut asked = order(P2);
    asked.motion.profile = Some("s-curve".to_owned());
    asked.motion.jerk_mm_s3 = Some(20_000.0);
    let id = h.submit(asked).await.unwrap();
    let there = h.wait(id, LIMIT).await.unwrap();
    assert_on_target(&there);
    let span_s = assert_d3_within(&shared, 300.0);
    assert!((span_s - 1.92).abs() < 0.06, "{span_s}");
    d.shut_down().await;
}

#[tokio::test]
async fn a_robot_with_a_joint_s_max_jerk_runs_its_s_curve_within_it_and_refuses_a_trapezoid() {
    // d3 takes 5000 mm/s^3; the robot's own ramps are S-curves of 20000 mm/s^3 along the path,
    // which ask d3 for 14523: the seed's move runs as its time-optimal motion averaged over a
    // window lengthened until d3 keeps its jerk, d3's pulses over 1.60 s, where slowing the
    // S-curve as a whole (to 66.3 %) took 2.200 s (PLANNING.md, "A joint's jerk").
    let mut robot = linterpd::robot::seed_robot();
    robot.motion.ramp = linterpd::robot::Ramp::SCurve {
        jerk_mm_s3: 20_000.0,
    };
    robot.joints[2].dynamics.max_jerk = Some(5_000.0);
    let (shared, d, h) = daemon_for(robot).await;
    let start = shared.with(|m| std::array::from_fn(|c| m.count(c)));
    while h.state().counts != Some(start) {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    // A trapezoid asked for: refused naming d3, and nothing moves.
    let mut trapezoid = order(P2);
    trapezoid.motion.profile = Some("trapezoid".to_owned());
    let refused = h.submit(trapezoid).await.unwrap_err();
    assert!(
        refused
            .to_string()
            .starts_with("joint d3 has max_jerk = 5000 mm/s^3"),
        "{refused}"
    );
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(pulse_times(&shared, 2).is_empty());
    assert_eq!(shared.with(|m| std::array::from_fn(|c| m.count(c))), start);
    // The robot's own S-curve runs within d3's jerk, as `plan` shows.
    let id = h.submit(order(P2)).await.unwrap();
    let there = h.wait(id, LIMIT).await.unwrap();
    assert_on_target(&there);
    let times = pulse_times(&shared, 2);
    let span_s = times[times.len() - 1] - times[0];
    assert!((span_s - 1.60).abs() < 0.06, "{span_s}");
    d.shut_down().await;
}

#[tokio::test]
async fn an_order_asking_for_an_s_curve_runs_jerk_limited_ramps_on_the_plc() {
    // The seed's move asked with S-curve ramps of 5000 mm/s^3 (the robot's own are the
    // trapezoid): PLANNING.md gives 1.650 s against 1.400 s, d3 leaving rest at 141 Hz
    // against 2024 Hz.
    let mut firsts = Vec::new();
    for profile in [None, Some("s-curve")] {
        let shared = mock_at_seed_start("");
        shared.with(|m| m.record_pulses(true));
        let (d, h) = daemon(duplex_connector(&shared, None), ContractSettings::default());
        wait_connected(&h).await;
        // Until the daemon has read the counts the mock's engines hold (a status block read
        // before the mock's first scan holds zeros): the line may be planned in parts, from
        // the counts at the order.
        let start = shared.with(|m| std::array::from_fn(|c| m.count(c)));
        while h.state().counts != Some(start) {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
        let mut asked = order(P2);
        asked.motion.profile = profile.map(str::to_owned);
        asked.motion.jerk_mm_s3 = profile.map(|_| 5000.0);
        let id = h.submit(asked).await.unwrap();
        let there = h.wait(id, LIMIT).await.unwrap();
        assert_on_target(&there);
        let times = pulse_times(&shared, 2);
        let (first, last) = (times[0], times[times.len() - 1]);
        let first_50ms = times.iter().filter(|&&t| t < first + 0.05).count();
        firsts.push((last - first, first_50ms));
        d.shut_down().await;
    }
    let ((trapezoid_s, trapezoid_pulses), (s_curve_s, s_curve_pulses)) = (firsts[0], firsts[1]);
    // d3's pulses span the move, less a row's rise at either end.
    assert!((trapezoid_s - 1.40).abs() < 0.06, "{trapezoid_s}");
    assert!((s_curve_s - 1.65).abs() < 0.06, "{s_curve_s}");
    // 2024 Hz over the first 50 ms against 141 Hz (the 50 ms from the first pulse reach into
    // the faster second row).
    assert!(trapezoid_pulses >= 95, "{trapezoid_pulses}");
    assert!(s_curve_pulses <= 20, "{s_curve_pulses}");
}

/// Issue 44: a 0.001 mm move, which never started, reported `seq 1, bank 0`; a move with no
/// motion of its own behind a running move showed stage `uploading` while it waited.
#[tokio::test]
async fn a_move_with_no_motion_of_its_own_has_no_seq_bank_or_upload() {
    let shared = mock_at_seed_start("");
    let (_d, h) = daemon(duplex_connector(&shared, None), ContractSettings::default());
    wait_connected(&h).await;
    let tiny = MoveOrder {
        by: Some(vec![0.001, 0.0, 0.0]),
        ..MoveOrder::default()
    };
    let r = h.wait(h.submit(tiny).await.unwrap(), LIMIT).await.unwrap();
    assert_eq!(r.stage, Stage::Done, "{r:?}");
    assert_eq!((r.seq, r.bank, r.upload_s), (None, None, None), "{r:?}");
    assert!(shared.with(|m| m.starts().is_empty()));
    // Behind a running move, one to where that one ends waits queued, and ends with it.
    let out = MoveOrder {
        motion: OrderMotion {
            speed_mm_s: Some(100.0),
            ..OrderMotion::default()
        },
        ..order(P2)
    };
    let lead = h.submit(out).await.unwrap();
    let follower = h.submit(order(P2)).await.unwrap();
    let mut seen = Vec::new();
    loop {
        let r = h.report(follower).unwrap();
        if seen.last() != Some(&r.stage) {
            seen.push(r.stage);
        }
        if r.stage.is_final() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert_eq!(seen, [Stage::Queued, Stage::Done], "{seen:?}");
    let r = h.report(follower).unwrap();
    assert_eq!((r.seq, r.bank, r.upload_s), (None, None, None), "{r:?}");
    assert_eq!(h.report(lead).unwrap().stage, Stage::Done);
}
