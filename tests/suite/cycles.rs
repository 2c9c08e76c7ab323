//! Cycle programs run by the daemon against the mock PLC: waits decided on the status block's
//! inputs, interlocked moves the PLC holds, outputs written, faults that need `clear-fault` and
//! `resume`, stops that always work, and one controller at a time.

use crate::common;

use std::path::PathBuf;
use std::time::Duration;

use common::daemon::{duplex_connector, signals, spawn_in_cell, taking_moves};
use common::exchange::{P1, P2, mock_at_seed_start};
use linterpd::config::CellSettings;
use linterpd::contract::{Layout, State};
use linterpd::daemon::{CycleError, CycleState, CycleStatus, Daemon, RobotHandle};
use linterpd::gateway::{AccessList, GatewaySettings};
use linterpd::mock::SharedMock;

const LIMIT: Duration = Duration::from_secs(20);

/// A programs directory of its own for each test.
fn programs(test: &str, files: &[(&str, String)]) -> PathBuf {
    common::daemon::programs_dir("cycles", test, files)
}

fn spawn(shared: &SharedMock, dir: PathBuf) -> (Daemon, RobotHandle) {
    spawn_on(duplex_connector(shared, None), dir)
}

/// The daemon in the press cell, on `connect`.
fn spawn_on(connect: linterpd::daemon::Connector, dir: PathBuf) -> (Daemon, RobotHandle) {
    let signals = signals(&[
        ("press_open", "X5"),
        ("press_moving", "X6"),
        ("part_present", "X2"),
        ("press_go", "Y0"),
        // In the status block's third input word (WR10): a start's record shows it.
        ("gripper", "R100"),
    ]);
    let ranges = |l: &[&str]| l.iter().map(|r| r.parse().unwrap()).collect();
    let access = AccessList::new(
        ranges(&["DT0-DT199"]),
        ranges(&["Y0-Y7", "DT100-DT199", "R100-R10F"]),
        &Layout::default(),
    )
    .unwrap();
    let cell = CellSettings {
        signals,
        programs: Some(dir),
        require_wait_timeout: false,
        face: None,
    };
    let gateway = GatewaySettings {
        access,
        modbus: None,
    };
    spawn_in_cell(connect, cell, gateway)
}

/// A connector to the mock over Modbus TCP (its Modbus server on a local port).
async fn modbus_connector(shared: &SharedMock) -> linterpd::daemon::Connector {
    use linterpd::mock::{ModbusServer, ModbusServerOptions};
    use linterpd::plc::{AnyPlc, BoxedLink, ModbusClient, ModbusFraming, ModbusOptions};
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let server = ModbusServer::new(shared.clone(), ModbusServerOptions::default());
    tokio::spawn(server.serve_tcp(listener));
    Box::new(move || {
        Box::pin(async move {
            let stream = tokio::net::TcpStream::connect(address)
                .await
                .map_err(|source| linterpd::plc::PlcError::Link {
                    operation: "connect".into(),
                    source,
                })?;
            Ok(AnyPlc::Modbus(ModbusClient::new(
                Box::new(stream) as BoxedLink,
                ModbusOptions::new(ModbusFraming::Tcp, 1),
            )))
        })
    })
}

/// Waits until the cycle's status satisfies `done`.
async fn until(h: &RobotHandle, what: &str, done: impl Fn(&CycleStatus) -> bool) -> CycleStatus {
    let began = std::time::Instant::now();
    loop {
        if let Some(s) = h.cycle()
            && done(&s)
        {
            return s;
        }
        assert!(began.elapsed() < LIMIT, "never {what}: {:?}", h.cycle());
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

fn at(p: [f64; 3]) -> String {
    format!("{{ to = [{}, {}, {}] }}", p[0], p[1], p[2])
}

/// Out to P2 once the press is open, interlocked, tell the press to go, back to P1.
fn press_cycle() -> String {
    format!(
        r#"
[[step]]
label = "wait"
wait = "press_open & !press_moving"
timeout = "10s"
[[step]]
move = {p2}
permit = "press_open & !press_moving"
[[step]]
set = {{ press_go = true, DT100 = 7 }}
[[step]]
move = {p1}
[[step]]
set = {{ press_go = false }}
"#,
        p1 = at(P1),
        p2 = at(P2)
    )
}

#[tokio::test]
async fn a_press_cycle_waits_for_the_press_runs_interlocked_and_counts_its_cycles() {
    let shared = mock_at_seed_start("");
    let (_d, h) = spawn(&shared, programs("press", &[("press-load", press_cycle())]));
    taking_moves(&h).await;
    let s = h.run_cycle("press-load", Some(2)).await.unwrap();
    assert_eq!((s.state, s.count), (CycleState::Running, Some(2)));
    // The press is closed: the cycle waits, and nothing moves.
    let s = until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    assert_eq!(
        s.waiting_for.as_deref(),
        Some("press_open (X5) & !press_moving (X6)")
    );
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert!(shared.with(|m| m.starts().is_empty()));
    shared.with(|m| m.set_input(5, true).unwrap());
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 2);
    assert!(s.last_cycle_s.is_some_and(|t| t > 0.0));
    // Two cycles, two moves each, the outward one with its permit written; the outputs were set
    // and reset.
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 4, "{starts:?}");
    for (i, r) in starts.iter().enumerate() {
        let permitted = i % 2 == 0;
        assert_eq!(r.block.permit.mask[0] == 0x60, permitted, "start {i}");
        assert!(r.block.permit.holds(&r.inputs));
    }
    let (go, dt100) = shared.with(|m| {
        (
            m.memory().bit(linterpd::gateway::Area::Y, 0).unwrap(),
            m.read_words(100, 1).unwrap()[0],
        )
    });
    assert_eq!((go, dt100), (false, 7));
}

#[tokio::test]
async fn the_press_cycle_runs_the_same_over_modbus_tcp() {
    let shared = mock_at_seed_start("");
    let dir = programs("modbus", &[("press-load", press_cycle())]);
    let (_d, h) = spawn_on(modbus_connector(&shared).await, dir);
    taking_moves(&h).await;
    h.run_cycle("press-load", Some(1)).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    assert!(shared.with(|m| m.starts().is_empty()));
    shared.with(|m| m.set_input(5, true).unwrap());
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 1);
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 2, "{starts:?}");
    assert_eq!(
        starts[0].block.permit.mask[0], 0x60,
        "the permit went over Modbus"
    );
    assert!(starts.iter().all(|r| r.block.permit.holds(&r.inputs)));
    let (go, dt100) = shared.with(|m| {
        (
            m.memory().bit(linterpd::gateway::Area::Y, 0).unwrap(),
            m.read_words(100, 1).unwrap()[0],
        )
    });
    assert_eq!((go, dt100), (false, 7), "the outputs went over Modbus");
}

#[tokio::test]
async fn a_wait_that_times_out_faults_the_cycle_which_resumes_only_after_clear_fault() {
    let shared = mock_at_seed_start("");
    let program = format!(
        "[[step]]\nwait = \"part_present\"\ntimeout = \"300ms\"\n[[step]]\nmove = {}\n",
        at(P2)
    );
    let (_d, h) = spawn(&shared, programs("timeout", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    let s = until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    let why = s.reason.unwrap();
    assert!(
        why.contains("wait for part_present (X2) timed out after 0.3 s"),
        "{why}"
    );
    assert_eq!(s.step.unwrap().step, 1);
    // Never by itself, not even once the part is there; not on resume alone.
    shared.with(|m| m.set_input(2, true).unwrap());
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(h.cycle().unwrap().state, CycleState::Faulted);
    let e = h.resume_cycle().await.unwrap_err();
    assert!(matches!(e, CycleError::FaultNotCleared { .. }), "{e}");
    assert!(e.to_string().contains("clear the fault first"), "{e}");
    // Cleared (the PLC has no fault: the cycle's is cleared), then resumed: the wait again,
    // met now, and the move.
    h.clear_fault().await.unwrap();
    h.resume_cycle().await.unwrap();
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 1);
    assert_eq!(shared.with(|m| m.starts().len()), 1);
}

#[tokio::test]
async fn a_permit_that_drops_mid_move_pauses_the_cycle_naming_the_input_and_resume_finishes_it() {
    let shared = mock_at_seed_start("");
    let program = format!(
        "[[step]]\nmove = {}\npermit = \"press_open\"\n[[step]]\ndwell = \"10ms\"\n",
        at(P2)
    );
    let (_d, h) = spawn(&shared, programs("hold", &[("p", program)]));
    taking_moves(&h).await;
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(50)).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    // Once the robot moves, the press closes.
    for _ in 0..2_000 {
        if shared.with(|m| m.status().state) == State::Running.word() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    tokio::time::sleep(Duration::from_millis(100)).await;
    shared.with(|m| m.set_input(5, false).unwrap());
    let s = until(&h, "paused", |s| s.state == CycleState::Paused).await;
    let why = s.reason.unwrap();
    assert!(
        why.contains("held by the PLC") && why.contains("X5 is off"),
        "{why}"
    );
    // Open again, resumed: the move again, from where the robot stopped, to its target.
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(50)).await;
    h.resume_cycle().await.unwrap();
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 1);
    let last = h.reports().into_iter().max_by_key(|r| r.id).unwrap();
    assert_eq!(last.stage, linterpd::daemon::Stage::Done, "{last:?}");
}

#[tokio::test]
async fn the_move_after_a_wait_is_uploaded_during_it_and_started_only_once_it_is_met() {
    let shared = mock_at_seed_start("");
    let (_d, h) = spawn(
        &shared,
        programs("prepared", &[("press-load", press_cycle())]),
    );
    taking_moves(&h).await;
    h.run_cycle("press-load", Some(1)).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    // The move is uploaded and held while the press stays closed: nothing starts.
    let began = std::time::Instant::now();
    let prepared = loop {
        let r = h.reports().into_iter().next();
        if let Some(r) = r.filter(|r| r.upload_s.is_some()) {
            break r;
        }
        assert!(began.elapsed() < LIMIT, "never uploaded: {:?}", h.reports());
        tokio::time::sleep(Duration::from_millis(5)).await;
    };
    assert!(!prepared.stage.is_final(), "{prepared:?}");
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(shared.with(|m| m.starts().is_empty()));
    assert_eq!(h.cycle().unwrap().state, CycleState::Waiting);
    // Open: that very move starts, with its permit, and the cycle goes on.
    shared.with(|m| m.set_input(5, true).unwrap());
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.moves.first(), Some(&prepared.id));
    assert_eq!(
        h.report(prepared.id).unwrap().stage,
        linterpd::daemon::Stage::Done
    );
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 2);
    assert!(starts[0].block.permit.holds(&starts[0].inputs));
}

/// Until the daemon has uploaded move `n` (0-based, in report order): the reports then.
async fn until_uploaded(h: &RobotHandle, n: usize) -> Vec<linterpd::daemon::MoveReport> {
    let began = std::time::Instant::now();
    loop {
        let reports = h.reports();
        if reports.get(n).is_some_and(|r| r.upload_s.is_some()) {
            return reports;
        }
        assert!(began.elapsed() < LIMIT, "never uploaded: {reports:?}");
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
}

#[tokio::test]
async fn the_move_after_a_move_and_its_outputs_is_uploaded_while_that_one_runs_and_starts_from_rest_after_them()
 {
    let shared = mock_at_seed_start("");
    let program = format!(
        "[[step]]\nmove = {p2}\n[[step]]\nset = {{ gripper = true }}\n[[step]]\nmove = {p1}\n\
         [[step]]\nset = {{ gripper = false }}\n",
        p1 = at(P1),
        p2 = at(P2)
    );
    let (_d, h) = spawn(&shared, programs("ahead", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    // The second move is uploaded while the first still runs, and held.
    let reports = until_uploaded(&h, 1).await;
    assert!(!reports[0].stage.is_final(), "{reports:?}");
    assert_eq!(
        reports[1].stage,
        linterpd::daemon::Stage::Prepared,
        "{reports:?}"
    );
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.moves, vec![reports[0].id, reports[1].id]);
    let [first, second] = [reports[0].id, reports[1].id].map(|id| h.report(id).unwrap());
    assert_eq!(first.stage, linterpd::daemon::Stage::Done, "{first:?}");
    assert_eq!(second.stage, linterpd::daemon::Stage::Done, "{second:?}");
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 2, "{starts:?}");
    // Planned from where the first ends, started there from rest, after the output: the
    // gripper (R100) was on in the scan that started it, and off in the first's.
    let ends = first.target_counts.unwrap();
    assert!((0..4).all(|c| i64::from(starts[1].block.from[c]) == ends[c]));
    assert!(!starts[1].from_mismatch(), "{:?}", starts[1]);
    assert!(starts[1].seen_s >= starts[0].at_s);
    assert_eq!(starts[0].inputs[2] & 1, 0);
    assert_eq!(starts[1].inputs[2] & 1, 1);
}

#[tokio::test]
async fn past_a_move_to_where_the_robot_will_be_the_next_move_is_prepared_too_and_waits_for_its_wait()
 {
    let shared = mock_at_seed_start("");
    let program = format!(
        "[[step]]\nmove = {p2}\n[[step]]\nset = {{ gripper = true }}\n[[step]]\nmove = {p2}\n\
         [[step]]\nwait = \"part_present\"\ntimeout = \"10s\"\n[[step]]\nmove = {p1}\n",
        p1 = at(P1),
        p2 = at(P2)
    );
    let (_d, h) = spawn(&shared, programs("ahead-past", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    // Both queued behind the first move while it runs; the last uploaded, held.
    let reports = until_uploaded(&h, 2).await;
    assert!(!reports[0].stage.is_final(), "{reports:?}");
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(shared.with(|m| m.starts().len()), 1);
    let r = h.report(reports[1].id).unwrap();
    assert_eq!(r.stage, linterpd::daemon::Stage::Done, "{r:?}");
    assert!(r.motion_s.is_none(), "no start of its own: {r:?}");
    assert!(!h.report(reports[2].id).unwrap().stage.is_final());
    // The part arrives: the held move starts from where the first ended.
    shared.with(|m| m.set_input(2, true).unwrap());
    until(&h, "done", |s| s.state == CycleState::Done).await;
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 2, "{starts:?}");
    assert!(!starts[1].from_mismatch(), "{:?}", starts[1]);
    assert_eq!(starts[1].inputs[0] & 0b100, 0b100);
    let last = h.report(reports[2].id).unwrap();
    assert_eq!(last.stage, linterpd::daemon::Stage::Done, "{last:?}");
}

#[tokio::test]
async fn a_move_prepared_behind_one_the_plc_holds_is_cancelled_before_its_start_and_runs_after_the_resume()
 {
    let shared = mock_at_seed_start("");
    let program = format!(
        "[[step]]\nmove = {p2}\npermit = \"press_open\"\n[[step]]\nset = {{ gripper = true }}\n\
         [[step]]\nmove = {p1}\n",
        p1 = at(P1),
        p2 = at(P2)
    );
    let (_d, h) = spawn(&shared, programs("ahead-held", &[("p", program)]));
    taking_moves(&h).await;
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(50)).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    let reports = until_uploaded(&h, 1).await;
    let prepared = reports[1].id;
    // The press closes while the first move runs: it is held, the one behind it never starts.
    shared.with(|m| m.set_input(5, false).unwrap());
    until(&h, "paused", |s| s.state == CycleState::Paused).await;
    let r = h.report(prepared).unwrap();
    assert_eq!(r.stage, linterpd::daemon::Stage::Cancelled, "{r:?}");
    assert!(
        r.error.as_deref().unwrap().contains("before its start"),
        "{r:?}"
    );
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(shared.with(|m| m.starts().len()), 1);
    assert!(!shared.with(|m| m.memory().bit(linterpd::gateway::Area::R, 100).unwrap()));
    // Resumed: the first move again from where it stopped, then the second afresh.
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(50)).await;
    h.resume_cycle().await.unwrap();
    until(&h, "done", |s| s.state == CycleState::Done).await;
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 3, "{starts:?}");
    assert!(starts.iter().all(|s| !s.from_mismatch()), "{starts:?}");
    let last = h.reports().into_iter().max_by_key(|r| r.id).unwrap();
    assert_eq!(last.stage, linterpd::daemon::Stage::Done, "{last:?}");
    assert_eq!(starts[2].inputs[2] & 1, 1);
}

#[tokio::test]
async fn the_daemon_shuts_down_while_a_prepared_move_is_held_and_nothing_starts() {
    let shared = mock_at_seed_start("");
    let (d, h) = spawn(
        &shared,
        programs("prepared-shutdown", &[("press-load", press_cycle())]),
    );
    taking_moves(&h).await;
    h.run_cycle("press-load", Some(1)).await.unwrap();
    let began = std::time::Instant::now();
    while !h.reports().iter().any(|r| r.upload_s.is_some()) {
        assert!(began.elapsed() < LIMIT, "never uploaded: {:?}", h.reports());
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    // Well inside the wait's 10 s timeout: the hold itself gives way to the shutdown.
    let down = tokio::time::timeout(Duration::from_secs(5), d.shut_down()).await;
    assert!(
        down.is_ok(),
        "the daemon did not shut down while the bank was held"
    );
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert!(shared.with(|m| m.starts().is_empty()));
}

#[tokio::test]
async fn a_wait_that_times_out_cancels_its_prepared_move_before_any_start() {
    let shared = mock_at_seed_start("");
    let program = format!(
        "[[step]]\nwait = \"part_present\"\ntimeout = \"600ms\"\n[[step]]\nmove = {}\n",
        at(P2)
    );
    let (_d, h) = spawn(&shared, programs("prepared-timeout", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    let s = until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    assert!(s.reason.unwrap().contains("timed out"));
    let reports = h.reports();
    assert_eq!(reports.len(), 1, "{reports:?}");
    assert_eq!(reports[0].stage, linterpd::daemon::Stage::Cancelled);
    let why = reports[0].error.clone().unwrap();
    // The cycle faulted: the robot was stopped and the prepared move's gate shut, whichever
    // the worker saw first.
    assert!(
        why.contains("before its start: its cycle went another way")
            || why.contains("before its start: a stop was asked for"),
        "{why}"
    );
    assert!(shared.with(|m| m.starts().is_empty()));
}

#[tokio::test]
async fn a_stop_during_a_wait_ends_the_cycle_and_nothing_moves() {
    let shared = mock_at_seed_start("");
    let (_d, h) = spawn(&shared, programs("stop", &[("press-load", press_cycle())]));
    taking_moves(&h).await;
    h.run_cycle("press-load", None).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    // The CLI's stop (the robot's) always works, and ends the cycle.
    h.stop().await.unwrap();
    let s = until(&h, "stopped", |s| s.state == CycleState::Stopped).await;
    assert!(s.reason.unwrap().contains("stopped"));
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(shared.with(|m| m.starts().is_empty()));
    assert_eq!(h.cycle().unwrap().state, CycleState::Stopped);
}

#[tokio::test]
async fn one_cycle_at_a_time_and_a_bad_program_is_refused_before_anything_moves() {
    let shared = mock_at_seed_start("");
    let bad = "[[step]]\nwait = \"door\"\ntimeout = \"1s\"\n".to_owned();
    let (_d, h) = spawn(
        &shared,
        programs("one", &[("press-load", press_cycle()), ("bad", bad)]),
    );
    taking_moves(&h).await;
    let e = h.run_cycle("bad", Some(1)).await.unwrap_err();
    assert!(
        e.to_string()
            .contains("program \"bad\" step 1: wait: condition \"door\""),
        "{e}"
    );
    assert!(h.cycle().is_none());
    let e = h.run_cycle("nope", Some(1)).await.unwrap_err();
    assert!(
        e.to_string()
            .contains("no such program; there are: bad, press-load"),
        "{e}"
    );
    h.run_cycle("press-load", None).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    let e = h.run_cycle("press-load", Some(1)).await.unwrap_err();
    assert!(matches!(e, CycleError::Running { .. }), "{e}");
    assert!(e.to_string().contains("is waiting: stop it first"), "{e}");
    // A stop at the end of the step: the wait is the step; stop now ends it.
    h.stop_cycle(true).await.unwrap();
    until(&h, "stopped", |s| s.state == CycleState::Stopped).await;
    assert!(shared.with(|m| m.starts().is_empty()));
}

/// Waits until the robot's PLC is running a move.
async fn until_moving(shared: &SharedMock) {
    for _ in 0..5_000 {
        if shared.with(|m| m.status().state) == State::Running.word() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    panic!("the PLC never ran a move");
}

#[tokio::test]
async fn a_plc_power_cycle_mid_move_faults_the_cycle_which_never_resumes_by_itself() {
    let shared = mock_at_seed_start("");
    let program = format!("[[step]]\nmove = {}\n[[step]]\nmove = {}\n", at(P2), at(P1));
    let (_d, h) = spawn(&shared, programs("power", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", None).await.unwrap();
    until_moving(&shared).await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    shared.with(linterpd::mock::MockPlc::power_cycle);
    let s = until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    assert_eq!(s.step.unwrap().step, 1);
    let why = s.reason.unwrap();
    assert!(why.contains("restarted"), "{why}");
    // I7: it stays faulted, and nothing starts, however long one waits.
    let starts = shared.with(|m| m.starts().len());
    tokio::time::sleep(Duration::from_millis(1_500)).await;
    assert_eq!(h.cycle().unwrap().state, CycleState::Faulted);
    assert_eq!(shared.with(|m| m.starts().len()), starts);
    // The PLC came back unhomed: cleared and resumed, the move is refused (not homed) and the
    // cycle faults again; nothing moves.
    h.clear_fault().await.unwrap();
    h.resume_cycle().await.unwrap();
    let s = until(&h, "faulted again", |s| {
        s.state == CycleState::Faulted && s.reason.as_deref().is_some_and(|r| r.contains("homed"))
    })
    .await;
    assert!(s.reason.unwrap().contains("not homed"));
    assert_eq!(shared.with(|m| m.starts().len()), starts);
}

#[tokio::test]
async fn a_link_lost_during_a_wait_neither_faults_nor_meets_it_and_the_cycle_goes_on_once_back() {
    let shared = mock_at_seed_start("");
    let program = format!(
        "[[step]]\nwait = \"press_open\"\ntimeout = \"20s\"\n[[step]]\nmove = {}\npermit = \"press_open\"\n",
        at(P2)
    );
    let (_d, h) = spawn(&shared, programs("link", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    // Every command's connection closed for a while: the link is down, the inputs unknown.
    shared.with(|m| m.set_faults("close@100%".parse().unwrap()));
    for _ in 0..500 {
        if !h.state().link.connected {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert!(!h.state().link.connected);
    assert_eq!(h.state().inputs, None);
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(h.cycle().unwrap().state, CycleState::Waiting);
    assert!(shared.with(|m| m.starts().is_empty()));
    // Back: the wait is met on the first status read, and the move runs.
    shared.with(|m| m.set_faults("".parse().unwrap()));
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 1);
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), 1);
    assert!(starts[0].block.permit.holds(&starts[0].inputs));
}

#[tokio::test]
async fn a_restarted_daemon_has_no_cycle_and_does_not_move_the_robot() {
    let shared = mock_at_seed_start("");
    let dir = programs("restart", &[("press-load", press_cycle())]);
    let (d, h) = spawn(&shared, dir.clone());
    taking_moves(&h).await;
    shared.with(|m| m.set_input(5, true).unwrap());
    h.run_cycle("press-load", None).await.unwrap();
    until(&h, "running a move", |s| !s.moves.is_empty()).await;
    d.kill().await;
    // A start the old daemon wrote just before it died is acted on in the PLC's next scans.
    tokio::time::sleep(Duration::from_millis(200)).await;
    let starts = shared.with(|m| m.starts().len());
    let (_d2, h2) = spawn(&shared, dir);
    taking_moves(&h2).await;
    tokio::time::sleep(Duration::from_millis(1_500)).await;
    assert!(h2.cycle().is_none());
    // At most the start the old daemon left running; nothing after it.
    assert_eq!(shared.with(|m| m.starts().len()), starts);
}

#[tokio::test]
async fn a_loop_of_outputs_alone_goes_round_at_the_pace_of_the_status_reads_and_ends_on_its_condition()
 {
    let shared = mock_at_seed_start("");
    let program = "[[step]]\nlabel = \"x\"\nset = { press_go = true }\n[[step]]\nloop = { to = \"x\", until = \"press_open\" }\n".to_owned();
    let (_d, h) = spawn(&shared, programs("spin", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    tokio::time::sleep(Duration::from_millis(100)).await;
    let before = h.state().gateway.requests;
    tokio::time::sleep(Duration::from_millis(500)).await;
    let writes = h.state().gateway.requests - before;
    // One write a status read (every 20 ms while watched, or 250 ms idle): never a spin.
    assert!((1..=40).contains(&writes), "{writes} writes in 0.5 s");
    shared.with(|m| m.set_input(5, true).unwrap());
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 1);
}

#[tokio::test]
async fn a_pause_or_a_stop_asked_during_a_wait_takes_effect_at_once_and_a_resumed_wait_waits_again()
{
    let shared = mock_at_seed_start("");
    let (_d, h) = spawn(&shared, programs("pause", &[("press-load", press_cycle())]));
    taking_moves(&h).await;
    h.run_cycle("press-load", Some(1)).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    h.pause_cycle().await.unwrap();
    let s = until(&h, "paused", |s| s.state == CycleState::Paused).await;
    assert_eq!(s.reason.as_deref(), Some("paused by request"));
    // Paused, the press opening moves nothing.
    shared.with(|m| m.set_input(5, true).unwrap());
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(shared.with(|m| m.starts().is_empty()));
    shared.with(|m| m.set_input(5, false).unwrap());
    // Resumed once the daemon has read the press closed (a block read before would show it
    // open, and the wait would be met on it).
    for _ in 0..500 {
        if h.state().inputs.is_some_and(|w| w[0] & 0x20 == 0) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    h.resume_cycle().await.unwrap();
    until(&h, "waiting again", |s| s.state == CycleState::Waiting).await;
    // A stop at the step's end: a wait is ended at once (it moves nothing).
    h.stop_cycle(false).await.unwrap();
    until(&h, "stopped", |s| s.state == CycleState::Stopped).await;
    assert!(shared.with(|m| m.starts().is_empty()));
}

#[tokio::test]
async fn the_cycles_api_answers_every_request_with_its_status_and_a_json_error_naming_the_reason() {
    use common::http::Endpoint;
    use hyper::StatusCode;
    let shared = mock_at_seed_start("");
    let bad = "[[step]]\nwait = \"door\"\ntimeout = \"1s\"\n".to_owned();
    let dir = programs("api", &[("press-load", press_cycle()), ("bad", bad)]);
    let (d, h) = spawn(&shared, dir.clone());
    taking_moves(&h).await;
    let socket = dir.join("api.sock");
    let listener = tokio::net::UnixListener::bind(&socket).unwrap();
    let router = linterpd::daemon::api::Api::new(d.robots().clone()).router(None);
    tokio::spawn(linterpd::daemon::api::serve(
        listener,
        router,
        std::future::pending(),
    ));
    let api = Endpoint::unix(&socket);
    let base = "/v1/robots/press-loader/cycles";
    let a = api.get(base).await;
    assert_eq!(a.status, StatusCode::NOT_FOUND, "{}", a.text());
    let a = api.post(base, r#"{"program": "bad", "count": 1}"#).await;
    assert_eq!(a.status, StatusCode::BAD_REQUEST, "{}", a.text());
    assert_eq!(a.json()["field"], "program");
    assert!(
        a.json()["error"].as_str().unwrap().contains("step 1"),
        "{}",
        a.text()
    );
    let a = api
        .post(base, r#"{"program": "press-load", "cont": 1}"#)
        .await;
    assert_eq!(a.status, StatusCode::BAD_REQUEST, "{}", a.text());
    let a = api.post(base, r#"{"program": "press-load"}"#).await;
    assert_eq!(a.status, StatusCode::ACCEPTED, "{}", a.text());
    assert_eq!(a.json()["state"], "running");
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    let a = api.post(base, r#"{"program": "press-load"}"#).await;
    assert_eq!(a.status, StatusCode::CONFLICT, "{}", a.text());
    assert_eq!(a.json()["reason"], "cycle-running");
    let a = api.post(&format!("{base}/resume"), "").await;
    assert_eq!(a.status, StatusCode::CONFLICT, "{}", a.text());
    assert_eq!(a.json()["reason"], "cycle-state");
    let a = api.get("/v1/robots/press-loader").await;
    assert_eq!(a.json()["cycle"]["state"], "waiting", "{}", a.text());
    let a = api.post(&format!("{base}/stop"), r#"{"now": true}"#).await;
    assert_eq!(a.status, StatusCode::OK, "{}", a.text());
    until(&h, "stopped", |s| s.state == CycleState::Stopped).await;
    let a = api.get(base).await;
    assert_eq!(a.json()["state"], "stopped", "{}", a.text());
}

/// The writes the daemon made to Y0 (`press_go`) on the mock.
fn press_go_writes(shared: &SharedMock) -> Vec<linterpd::mock::HostWrite> {
    shared.with(|m| {
        m.host_writes()
            .iter()
            .filter(|w| w.area == linterpd::gateway::Area::Y && w.start == 0)
            .cloned()
            .collect()
    })
}

/// Issue 44: a PLC restarted during a wait let the cycle go on and write `press_go` to it.
#[tokio::test]
async fn a_plc_restart_during_a_wait_faults_the_cycle_and_writes_no_output_until_resumed() {
    let shared = mock_at_seed_start("");
    let program = "[[step]]\nwait = \"part_present\"\ntimeout = \"20s\"\n\
                   [[step]]\nset = { press_go = true }\n[[step]]\ndwell = \"200ms\"\n\
                   [[step]]\nset = { press_go = false }\n"
        .to_owned();
    let (_d, h) = spawn(&shared, programs("restart-wait", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    shared.with(linterpd::mock::MockPlc::power_cycle);
    let s = until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    assert_eq!(s.step.as_ref().unwrap().step, 1);
    assert!(s.reason.as_deref().unwrap().contains("restarted"), "{s:?}");
    // The input comes on: nothing is written, the cycle stays faulted.
    tokio::time::sleep(Duration::from_millis(300)).await;
    shared.with(|m| m.set_input(2, true).unwrap());
    tokio::time::sleep(Duration::from_millis(700)).await;
    assert_eq!(h.cycle().unwrap().state, CycleState::Faulted);
    assert!(
        press_go_writes(&shared).is_empty(),
        "{:?}",
        press_go_writes(&shared)
    );
    // A resume without a clear is refused; after one, the cycle goes on: the wait again, then
    // the outputs.
    assert!(matches!(
        h.resume_cycle().await,
        Err(CycleError::FaultNotCleared { .. })
    ));
    h.clear_fault().await.unwrap();
    let resumed = h.resume_cycle().await.unwrap();
    assert_eq!(resumed.state, CycleState::Running, "{resumed:?}");
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 1);
    let writes = press_go_writes(&shared);
    assert_eq!(writes.len(), 2, "{writes:?}");
    assert!(writes.iter().all(|w| w.after_restart_seen));
}

/// Issue 44: a cycle paused when the PLC restarted stayed paused.
#[tokio::test]
async fn a_paused_cycle_faults_when_the_plc_restarts_and_needs_a_clear_to_resume() {
    let shared = mock_at_seed_start("");
    let program =
        "[[step]]\nwait = \"part_present\"\ntimeout = \"20s\"\n[[step]]\nset = { press_go = true }\n"
            .to_owned();
    let (_d, h) = spawn(&shared, programs("restart-paused", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    h.pause_cycle().await.unwrap();
    until(&h, "paused", |s| s.state == CycleState::Paused).await;
    shared.with(linterpd::mock::MockPlc::power_cycle);
    let s = until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    assert!(s.reason.as_deref().unwrap().contains("restarted"), "{s:?}");
    assert!(matches!(
        h.resume_cycle().await,
        Err(CycleError::FaultNotCleared { .. })
    ));
    shared.with(|m| m.set_input(2, true).unwrap());
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert!(press_go_writes(&shared).is_empty());
}

/// A clear made before another incident does not let the cycle resume after it.
#[tokio::test]
async fn a_clear_before_a_second_restart_does_not_resume_the_cycle() {
    let shared = mock_at_seed_start("");
    let program =
        "[[step]]\nwait = \"part_present\"\ntimeout = \"20s\"\n[[step]]\nset = { press_go = true }\n"
            .to_owned();
    let (_d, h) = spawn(&shared, programs("restart-twice", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    until(&h, "waiting", |s| s.state == CycleState::Waiting).await;
    shared.with(linterpd::mock::MockPlc::power_cycle);
    until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    h.clear_fault().await.unwrap();
    // The daemon has written its host word again and read it echoed (a restart before that is
    // one the daemon cannot tell from its word not taken yet: the PLC is unhomed either way).
    for _ in 0..400 {
        if shared.with(|m| m.status().host) != 0 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let mut reads = h.watch_reads();
    reads.next().await.unwrap();
    reads.next().await.unwrap();
    let seen = h.incidents().count;
    shared.with(linterpd::mock::MockPlc::power_cycle);
    for _ in 0..400 {
        if h.incidents().count > seen {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    assert!(
        h.incidents().count > seen,
        "the second restart was never seen"
    );
    assert!(matches!(
        h.resume_cycle().await,
        Err(CycleError::FaultNotCleared { .. })
    ));
}

/// Issue 44: one bad file in the programs directory made every good program refuse, naming the
/// other file; a path file outside the directory was read.
#[tokio::test]
async fn a_bad_neighbour_never_keeps_a_good_program_from_running() {
    let shared = mock_at_seed_start("");
    let dwell = "[[step]]\ndwell = \"50ms\"\n".to_owned();
    let one = format!("number = 1\n{dwell}");
    let dir = programs(
        "neighbours",
        &[
            ("good", dwell.clone()),
            ("garbled", "[[step]\n".to_owned()),
            ("first", one.clone()),
            ("copy", one),
            (
                "escape",
                "[[step]]\npath = { file = \"../../x.toml\" }\n".to_owned(),
            ),
            (
                "passwd",
                "[[step]]\npath = { file = \"/etc/passwd\" }\n".to_owned(),
            ),
        ],
    );
    let (_d, h) = spawn(&shared, dir);
    taking_moves(&h).await;
    let refused = async |name: &str| match h.run_cycle(name, Some(1)).await {
        Err(CycleError::Program(e)) => e,
        other => panic!("{name}: {other:?}"),
    };
    let e = refused("first").await;
    assert!(
        e.contains("number = 1 is program \"copy\"'s number too"),
        "{e}"
    );
    let e = refused("escape").await;
    assert!(e.contains("\"../../x.toml\" goes up with .."), "{e}");
    let e = refused("passwd").await;
    assert!(e.contains("\"/etc/passwd\" is an absolute name"), "{e}");
    let e = refused("garbled").await;
    assert!(e.contains("cannot be read: garbled.toml: "), "{e}");
    let e = refused("nosuch").await;
    assert!(
        e.contains("no such program; there are: copy, first, good (and, unreadable: escape, garbled, passwd)"),
        "{e}"
    );
    h.run_cycle("good", Some(1)).await.unwrap();
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    assert_eq!(s.done, 1);
}

/// From P1 up, across and down to P2 blended, `between` (steps, then a `set` of the gripper),
/// and back to P1 blended: two path ops of three moves each.
fn blended_there_and_back(between: &str) -> String {
    let above = |p: [f64; 3]| [p[0], p[1], p[2] + 100.0];
    let step = |p: [f64; 3], blend: bool| {
        let blend = if blend { "blend_mm = 20\n" } else { "" };
        format!("[[step]]\nmove = {}\n{blend}", at(p))
    };
    [
        step(above(P1), true),
        step(above(P2), true),
        step(P2, false),
        between.to_owned(),
        "[[step]]\nset = { gripper = true }\n".to_owned(),
        step(above(P2), true),
        step(above(P1), true),
        step(P1, false),
    ]
    .concat()
}

/// A blended run after a dwell is uploaded while the run before it moves and the dwell waits,
/// and held: the gate opens at its step (after the output that follows the dwell), and it
/// starts from the held bank, with no table written between the output and its start.
#[tokio::test]
async fn a_blended_run_after_a_dwell_is_uploaded_ahead_and_starts_from_its_held_bank() {
    let shared = mock_at_seed_start("");
    let program = blended_there_and_back("[[step]]\ndwell = \"1s\"\n");
    let (_d, h) = spawn(&shared, programs("blended-ahead", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    let s = until(&h, "done", |s| s.state == CycleState::Done).await;
    let reports = h.reports();
    assert!(
        reports
            .iter()
            .all(|r| r.stage == linterpd::daemon::Stage::Done),
        "{reports:?}"
    );
    assert_eq!(s.moves.len(), reports.len(), "{s:?}");
    let starts = shared.with(|m| m.starts().to_vec());
    assert!(starts.iter().all(|st| !st.from_mismatch()), "{starts:?}");
    // The way back's first start: the first with the gripper on (R100, set after the dwell).
    let back = starts
        .iter()
        .position(|st| st.inputs[2] & 1 == 1)
        .expect("the way back started after the output");
    assert!(back > 0, "{starts:?}");
    let (writes, tables) = shared.with(|m| (m.host_writes().to_vec(), m.table_writes().to_vec()));
    let gripper_on = writes
        .iter()
        .find(|w| w.area == linterpd::gateway::Area::R && w.values == [1])
        .expect("the gripper's write")
        .command;
    // Its bank was written before the output that opens its gate (during the dwell)...
    let bank = starts[back].block.bank;
    assert!(
        tables
            .iter()
            .any(|t| t.bank == bank && t.command < gripper_on),
        "{tables:?}"
    );
    // ...and nothing was written to any table area from that output to its start: it
    // started from the bank held behind the gate.
    let late: Vec<_> = tables
        .iter()
        .filter(|t| t.command > gripper_on && t.at_s < starts[back].at_s)
        .collect();
    assert!(late.is_empty(), "written after the gate opened: {late:?}");
    // The way there ended before the dwell: the way back began after it, from rest.
    assert!(starts[back].seen_s > starts[back - 1].at_s);
}

/// A blended run held behind its gate while the wait before it times out: the cycle faults,
/// every start of the run is cancelled before its start, and nothing of it moves.
#[tokio::test]
async fn a_fault_while_a_blended_run_is_held_cancels_every_start_of_it_and_nothing_moves() {
    let shared = mock_at_seed_start("");
    let program =
        blended_there_and_back("[[step]]\nwait = \"part_present\"\ntimeout = \"1500ms\"\n");
    let (_d, h) = spawn(&shared, programs("blended-held-fault", &[("p", program)]));
    taking_moves(&h).await;
    h.run_cycle("p", Some(1)).await.unwrap();
    // The way there is queued first; the way back is queued behind it, prepared.
    let there = until(&h, "waiting", |s| s.state == CycleState::Waiting)
        .await
        .moves;
    let back: Vec<_> = h
        .reports()
        .into_iter()
        .filter(|r| !there.contains(&r.id))
        .collect();
    assert!(back.len() > 1, "a run in parts: {back:?}");
    // Held once its upload is done (under load it may still be uploading when the cycle waits).
    common::daemon::report_until(&mut h.subscribe(back[0].id).unwrap(), "prepared", |r| {
        r.stage == linterpd::daemon::Stage::Prepared
    })
    .await;
    let s = until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    assert!(s.reason.unwrap().contains("timed out"));
    for r in &back {
        let r = h.report(r.id).unwrap();
        assert_eq!(r.stage, linterpd::daemon::Stage::Cancelled, "{r:?}");
    }
    let first = h.report(back[0].id).unwrap();
    assert!(
        first.error.as_deref().unwrap().contains("before its start"),
        "{first:?}"
    );
    // The part arrives too late: nothing of the way back ever starts.
    shared.with(|m| m.set_input(2, true).unwrap());
    tokio::time::sleep(Duration::from_millis(300)).await;
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(starts.len(), there.len(), "{starts:?}");
    assert!(starts.iter().all(|st| st.inputs[2] & 1 == 0));
}
