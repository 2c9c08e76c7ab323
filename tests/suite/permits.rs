//! Contract version 3's permits end to end: a move order's `permit` resolved by the daemon,
//! written with its start, enforced by the (mock) PLC. A permit that does not hold starts
//! nothing; one that drops mid-move holds the robot within a scan, and the report says which
//! input dropped.

use crate::common;

use std::time::Duration;

use common::daemon::{duplex_connector, signals, spawn_in_cell, taking_moves};
use common::exchange::{P1, P2, mock_at_seed_start};
use linterpd::config::CellSettings;
use linterpd::contract::{Fault, State};
use linterpd::daemon::{Daemon, MoveOrder, RobotHandle, Stage, SubmitError};
use linterpd::mock::SharedMock;
use linterpd::order::OrderMotion;

const LIMIT: Duration = Duration::from_secs(15);

fn spawn(shared: &SharedMock) -> (Daemon, RobotHandle) {
    let cell = CellSettings {
        signals: signals(&[("press_open", "X5"), ("press_moving", "X6")]),
        ..CellSettings::default()
    };
    spawn_in_cell(
        duplex_connector(shared, None),
        cell,
        linterpd::gateway::GatewaySettings::default(),
    )
}

fn to(p: [f64; 3], permit: &str) -> MoveOrder {
    MoveOrder {
        to: Some(p.to_vec()),
        permit: Some(permit.to_owned()),
        ..MoveOrder::default()
    }
}

#[tokio::test]
async fn a_move_whose_permit_does_not_hold_starts_nothing_and_says_which_input() {
    let shared = mock_at_seed_start("");
    let (_d, h) = spawn(&shared);
    taking_moves(&h).await;
    shared.with(|m| m.set_input(6, true).unwrap()); // the press moves
    let before = shared.with(|m| (0..4).map(|c| m.count(c)).collect::<Vec<_>>());
    let id = h
        .submit(to(P2, "press_open & !press_moving"))
        .await
        .unwrap();
    let r = h.wait(id, LIMIT).await.unwrap();
    assert_eq!(r.stage, Stage::Failed, "{r:?}");
    let why = r.error.unwrap();
    assert!(
        why.contains("X5 is off (the permit needs it on)")
            && why.contains("X6 is on (the permit needs it off)")
            && why.contains("nothing was written"),
        "{why}"
    );
    assert!(shared.with(|m| m.starts().is_empty()));
    let after = shared.with(|m| (0..4).map(|c| m.count(c)).collect::<Vec<_>>());
    assert_eq!(before, after);
    // The press opens and stands: the same order runs, its permit written with its start.
    shared.with(|m| {
        m.set_input(6, false).unwrap();
        m.set_input(5, true).unwrap();
    });
    tokio::time::sleep(Duration::from_millis(50)).await;
    let id = h
        .submit(to(P2, "press_open & !press_moving"))
        .await
        .unwrap();
    let r = h.wait(id, LIMIT).await.unwrap();
    assert_eq!(r.stage, Stage::Done, "{r:?}");
    let started = shared.with(|m| m.starts().to_vec());
    assert_eq!(started.len(), 1);
    assert_eq!(started[0].block.permit.mask, [0x60, 0, 0, 0]);
    assert_eq!(started[0].block.permit.value, [0x20, 0, 0, 0]);
    assert!(started[0].block.permit.holds(&started[0].inputs));
}

#[tokio::test]
async fn a_permit_that_drops_mid_move_holds_the_robot_and_the_report_names_the_input() {
    let shared = mock_at_seed_start("");
    let (_d, h) = spawn(&shared);
    taking_moves(&h).await;
    shared.with(|m| {
        m.set_input(5, true).unwrap();
        m.record_pulses(true);
    });
    tokio::time::sleep(Duration::from_millis(50)).await;
    let id = h.submit(to(P2, "press_open")).await.unwrap();
    // Once it runs, the press closes.
    for _ in 0..500 {
        if h.report(id).unwrap().stage == Stage::Running {
            break;
        }
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    tokio::time::sleep(Duration::from_millis(100)).await;
    let (dropped_at, scan_s) = shared.with(|m| {
        m.set_input(5, false).unwrap();
        (m.now_s(), m.config().scan_s)
    });
    let r = h.wait(id, LIMIT).await.unwrap();
    assert_eq!(r.stage, Stage::Stopped, "{r:?}");
    assert!(r.held(), "{r:?}");
    let why = r.error.unwrap();
    assert!(
        why.contains("held by the PLC") && why.contains("X5 is off"),
        "{why}"
    );
    let (state, fault, last_pulse) = shared.with(|m| {
        let s = m.status();
        let last = m.take_pulses().iter().map(|p| p.time_s).fold(0.0, f64::max);
        (s.state, s.fault, last)
    });
    assert_eq!(
        (state, fault),
        (State::Stopped.word(), Fault::PermitDropped.word())
    );
    // It moved, and no pulse came after the first scan past the drop.
    assert!(last_pulse > 0.0);
    assert!(
        last_pulse <= dropped_at + scan_s + 1e-9,
        "{last_pulse} vs {dropped_at}"
    );
}

#[tokio::test]
async fn a_permit_the_plc_cannot_check_is_refused_naming_it_and_nothing_is_queued() {
    let shared = mock_at_seed_start("");
    let (_d, h) = spawn(&shared);
    taking_moves(&h).await;
    for (permit, words) in [
        ("press_open | X7", "`|` cannot be a permit"),
        (
            "X25",
            "not in the input words the PLC copies (WX0, WX1, WR10, WR11)",
        ),
        ("door", "neither a signal (press_moving, press_open)"),
    ] {
        let e = h.submit(to(P1, permit)).await.unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, SubmitError::Order(_)), "{e:?}");
        assert!(text.contains("permit") && text.contains(words), "{text}");
    }
    assert!(h.reports().is_empty());
}

/// The mock's counts, per channel.
fn mock_counts(shared: &SharedMock) -> [i64; 4] {
    shared.with(|m| std::array::from_fn(|c| m.count(c)))
}

/// Issue 44: a move stopped by `linterpd stop` or held by its permit ended `stopped` with the
/// counts of a status read from before the stop (274 pulses off, seconds later) and no error.
#[tokio::test]
async fn a_stopped_or_held_moves_report_says_where_the_plc_stopped_it() {
    for held in [false, true] {
        let shared = mock_at_seed_start("");
        let (_d, h) = spawn(&shared);
        taking_moves(&h).await;
        shared.with(|m| m.set_input(5, true).unwrap());
        let order = MoveOrder {
            motion: OrderMotion {
                speed_mm_s: Some(60.0),
                ..OrderMotion::default()
            },
            ..to(P2, "press_open")
        };
        let id = h.submit(order).await.unwrap();
        for _ in 0..2_000 {
            if shared.with(|m| m.status().state) == State::Running.word() {
                break;
            }
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
        tokio::time::sleep(Duration::from_millis(400)).await;
        if held {
            shared.with(|m| m.set_input(5, false).unwrap());
        } else {
            h.stop().await.unwrap();
        }
        let r = h.wait(id, LIMIT).await.unwrap();
        assert_eq!(r.stage, Stage::Stopped, "{r:?}");
        assert_eq!(r.held(), held, "{r:?}");
        let counts = r.counts.expect("counts");
        assert_eq!(counts, mock_counts(&shared), "held {held}: {r:?}");
        let targets = r.target_counts.expect("targets");
        let error = r.final_error_pulses.expect("the error to the target");
        assert_eq!(error, std::array::from_fn(|c| counts[c] - targets[c]));
        assert!(error.iter().any(|e| e.abs() > 100), "{error:?}");
        // Seconds later it is still the truth.
        tokio::time::sleep(Duration::from_millis(500)).await;
        assert_eq!(h.report(id).unwrap().counts, Some(mock_counts(&shared)));
    }
}
