//! The API's JSON of states and reports, byte for byte as the daemon wrote it before its types
//! were read back (issue 26), and read back into the same values.

use super::*;
use crate::contract::{PlcMode, State};
use crate::order::{MoveOrder, OrderMotion};
use serde::Serialize;

const STATE_NEW: &str = r#"{"name":"press-loader","link":{"connected":false,"error":null,"reconnects":0},"phase":"connecting","homed":false,"refuses":null,"plc_mode":null,"heartbeat_age_ms":null,"state":null,"fault":null,"counts":null,"pose":null,"current_move":null,"queued":[],"gateway":{"requests":0,"failed":0,"exchanges":0,"longest_exchange_ms":0,"longest_poll_delay_ms":0},"mode":"local"}"#;
const STATE_FULL: &str = r#"{"name":"press-loader","link":{"connected":true,"error":"timed out","reconnects":3},"phase":"running-chained","homed":true,"refuses":"a move runs","plc_mode":"prog","heartbeat_age_ms":12,"state":"fault","fault":3,"counts":[1,-2,3,40000],"inputs":[32,0,0,1],"pose":[-0.0,500.25,0.1,45.0],"current_move":7,"queued":[8,9],"gateway":{"requests":5,"failed":1,"exchanges":4,"longest_exchange_ms":30,"longest_poll_delay_ms":2},"cycle":{"program":"press-load","state":"running","done":0,"count":10},"mode":"remote","face":{"program":3,"program_name":"press-load","enabled":true,"commands":66,"refused":{"code":8,"meaning":"a cycle is under way or the robot is moving"}}}"#;
const REPORT_NEW: &str = r#"{"id":42,"robot":"press-loader","stage":"queued","order":{},"recovered":false,"deadline_s":null,"seq":null,"bank":null,"start_counts":null,"target_counts":null,"predicted":null,"upload_s":null,"motion_s":null,"progress":0.0,"counts":null,"final_error_pulses":null,"error":null}"#;
const REPORT_FULL: &str = r#"{"id":43,"robot":"press-loader","stage":"running","order":{"to":[1.0,2.0,3.0],"speed_mm_s":120.0,"method":"bounded-error"},"recovered":true,"deadline_s":4.5,"seq":17,"bank":1,"start_counts":[0,0,0,0],"target_counts":[100,-200,300,0],"predicted":{"rows":12,"words":96,"duration_s":1.25,"path_deviation_mm":0.0125,"tracking_error_mm":0.3},"upload_s":0.08,"motion_s":1.3,"progress":0.42,"counts":[50,-100,150,0],"final_error_pulses":[0,1,-1,0],"error":"stopped by a stop request","section":{"number":2,"of":3,"pieces":[{"kind":"line","element":1,"waypoint":null,"begins":0.0,"ends":0.5},{"kind":"arc","element":null,"waypoint":1,"begins":0.5,"ends":0.6}]}}"#;

fn new_state() -> RobotState {
    RobotState {
        name: "press-loader".into(),
        ..RobotState::default()
    }
}

fn full_state() -> RobotState {
    RobotState {
        name: "press-loader".into(),
        link: LinkState {
            connected: true,
            error: Some("timed out".into()),
            reconnects: 3,
        },
        phase: RobotPhase::RunningChained,
        homed: true,
        refuses: Some("a move runs".into()),
        plc_mode: Some(PlcMode::Prog),
        heartbeat_age_ms: Some(12),
        state: Some(State::Fault),
        fault: Some(3),
        counts: Some([1, -2, 3, 40000]),
        inputs: Some([0x20, 0, 0, 1]),
        pose: Some([-0.0, 500.25, 0.1, 45.0]),
        current_move: Some(7),
        queued: vec![8, 9],
        gateway: GatewayStats {
            requests: 5,
            failed: 1,
            exchanges: 4,
            longest_exchange_ms: 30,
            longest_poll_delay_ms: 2,
        },
        cycle: Some(crate::wire::CycleStatus::starting("press-load", Some(10))),
        mode: crate::cell::Mode::Remote,
        face: Some(FaceState {
            program: 3,
            program_name: Some("press-load".into()),
            enabled: true,
            commands: 0x42,
            refused: Some(FaceRefusal {
                code: 8,
                meaning: "a cycle is under way or the robot is moving".into(),
            }),
        }),
    }
}

fn full_report() -> MoveReport {
    let order = MoveOrder {
        to: Some(vec![1.0, 2.0, 3.0]),
        motion: OrderMotion {
            speed_mm_s: Some(120.0),
            method: Some("bounded-error".into()),
            ..OrderMotion::default()
        },
        ..MoveOrder::default()
    };
    let piece = |kind, element, waypoint, begins, ends| PieceReport {
        kind,
        element,
        waypoint,
        begins,
        ends,
    };
    MoveReport {
        stage: Stage::Running,
        recovered: true,
        deadline_s: Some(4.5),
        seq: Some(17),
        bank: Some(1),
        start_counts: Some([0, 0, 0, 0]),
        target_counts: Some([100, -200, 300, 0]),
        predicted: Some(Predicted {
            rows: 12,
            words: 96,
            duration_s: 1.25,
            path_deviation_mm: 0.012_5,
            tracking_error_mm: 0.3,
        }),
        upload_s: Some(0.08),
        motion_s: Some(1.3),
        progress: 0.42,
        counts: Some([50, -100, 150, 0]),
        final_error_pulses: Some([0, 1, -1, 0]),
        error: Some("stopped by a stop request".into()),
        section: Some(SectionReport {
            number: 2,
            of: 3,
            pieces: vec![
                piece(PieceKind::Line, Some(1), None, 0.0, 0.5),
                piece(PieceKind::Arc, None, Some(1), 0.5, 0.6),
            ],
        }),
        ..MoveReport::new(43, "press-loader", order)
    }
}

/// `value` is written as `json`, and `json` reads back as `value`.
fn assert_json<T>(value: &T, json: &str)
where
    T: Serialize + serde::de::DeserializeOwned + PartialEq + std::fmt::Debug,
{
    assert_eq!(serde_json::to_string(value).unwrap(), json);
    assert_eq!(&serde_json::from_str::<T>(json).unwrap(), value);
}

#[test]
fn a_robot_state_is_written_as_before_and_reads_back() {
    assert_json(&new_state(), STATE_NEW);
    assert_json(&full_state(), STATE_FULL);
}

#[test]
fn a_move_report_is_written_as_before_and_reads_back() {
    assert_json(
        &MoveReport::new(42, "press-loader", MoveOrder::default()),
        REPORT_NEW,
    );
    assert_json(&full_report(), REPORT_FULL);
}

#[test]
fn a_hold_is_written_as_held_and_a_cancel_before_the_start_not_at_all() {
    let mut held = MoveReport::new(42, "press-loader", MoveOrder::default());
    held.end = Some(EndReason::Held);
    let with_held = REPORT_NEW.replace("\"error\":null}", "\"error\":null,\"held\":true}");
    assert_json(&held, &with_held);
    let mut cancelled = held.clone();
    cancelled.end = Some(EndReason::CancelledBeforeStart);
    assert_eq!(serde_json::to_string(&cancelled).unwrap(), REPORT_NEW);
}

#[test]
fn every_phase_state_mode_stage_and_piece_kind_keeps_its_word() {
    // The words `Phase::name()`, `State::name()` and the daemon wrote before.
    let phases = [
        "connecting",
        "link-down",
        "stalled",
        "unhomed",
        "homing",
        "idle",
        "uploading",
        "starting",
        "running",
        "running-chained",
        "stopping",
    ];
    for (phase, word) in RobotPhase::ALL.into_iter().zip(phases) {
        assert_json(&phase, &format!("\"{word}\""));
        assert_eq!(phase.name(), word);
    }
    // What a daemon before "connecting" wrote still reads.
    let old: RobotPhase = serde_json::from_str("\"\"").unwrap();
    assert_eq!(old, RobotPhase::NotPublished);
    for word in ["idle", "running", "done", "stopped", "fault", "homing"] {
        let state: State = serde_json::from_str(&format!("\"{word}\"")).unwrap();
        assert_json(&state, &format!("\"{word}\""));
        assert_eq!(state.name(), word);
    }
    assert_json(&PlcMode::Run, "\"run\"");
    assert_json(&PlcMode::Prog, "\"prog\"");
    assert_json(&PieceKind::Line, "\"line\"");
    assert_json(&PieceKind::Arc, "\"arc\"");
    for stage in Stage::FINAL.into_iter().chain([
        Stage::Queued,
        Stage::Uploading,
        Stage::Prepared,
        Stage::Waiting,
        Stage::Running,
    ]) {
        assert_json(&stage, &format!("\"{}\"", stage.name()));
    }
}

#[test]
fn a_report_or_state_without_the_optional_fields_still_reads() {
    let report: MoveReport =
        serde_json::from_str(r#"{"id":3,"robot":"r","stage":"done"}"#).unwrap();
    assert_eq!(report, {
        let mut r = MoveReport::new(3, "r", MoveOrder::default());
        r.stage = Stage::Done;
        r
    });
    let state: RobotState =
        serde_json::from_str(r#"{"name":"r","link":{"connected":true},"phase":"idle"}"#).unwrap();
    assert!(state.link.connected && state.phase == RobotPhase::Idle);
    assert_eq!(state.gateway, GatewayStats::default());
    assert!(state.queued.is_empty() && state.plc_mode.is_none());
}
