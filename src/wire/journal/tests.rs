use super::*;

fn entry(kind: Kind) -> Entry {
    Entry {
        seq: 41,
        at_ms: 1_795_855_681_123,
        robot: Some("press-loader".into()),
        kind,
    }
}

#[test]
fn an_entry_is_one_json_line_with_its_kind_flattened() {
    let e = entry(Kind::Fault {
        code: Some(3),
        reason: "stopped from outside (e-stop input)".into(),
    });
    let line = e.to_line();
    assert_eq!(
        line,
        "{\"seq\":41,\"at\":\"2026-11-28T08:48:01.123Z\",\"robot\":\"press-loader\",\
         \"kind\":\"fault\",\"code\":3,\"reason\":\"stopped from outside (e-stop input)\"}"
    );
    assert!(!line.contains('\n'));
    assert_eq!(Entry::from_line(&line).unwrap(), e);
}

#[test]
fn every_kind_reads_back_as_written_and_names_itself() {
    let kinds = vec![
        Kind::DaemonStarted {
            version: "0.1.0".into(),
        },
        Kind::DaemonStopping,
        Kind::FaultCleared { code: 3 },
        Kind::LinkLost { error: None },
        Kind::LinkRestored,
        Kind::CycleStarted {
            program: "main".into(),
            cycle: 2,
        },
        Kind::CycleEnded {
            program: "main".into(),
            cycle: 2,
            outcome: CycleOutcome::Done,
            cycle_s: Some(4.25),
        },
        Kind::Hold { reason: None },
        Kind::Resume,
        Kind::ModeChanged { mode: Mode::Remote },
        Kind::Command {
            source: Source::Cli,
            who: Some("uid 1000".into()),
            action: "POST stop".into(),
            status: Some(200),
            refused: None,
        },
        Kind::PalletPlaced {
            pallet: "out".into(),
            slot: 7,
            layer: 1,
        },
        Kind::PalletFull {
            pallet: "out".into(),
            parts: 96,
        },
        Kind::ConfigReloaded {
            applied: vec!["[robots.r.gateway] read".into()],
            needs_restart: vec![],
        },
        Kind::ConfigRefused {
            error: "config line 3: ...".into(),
        },
        Kind::Dropped { entries: 12 },
        Kind::TornLine {
            file: "000000000001.jsonl".into(),
            bytes: 17,
        },
    ];
    for kind in kinds {
        let e = entry(kind);
        let line = e.to_line();
        assert!(
            line.contains(&format!("\"kind\":\"{}\"", e.kind.name())),
            "{line}"
        );
        assert_eq!(Entry::from_line(&line).unwrap(), e, "{line}");
    }
}

#[test]
fn the_human_line_says_when_what_and_who() {
    let e = entry(Kind::Command {
        source: Source::Console,
        who: Some("alice from 10.0.0.5".into()),
        action: "POST cycles/pause".into(),
        status: Some(202),
        refused: None,
    });
    assert_eq!(
        e.to_string(),
        "2026-11-28T08:48:01.123Z #41 press-loader command: POST cycles/pause from console \
         (alice from 10.0.0.5) -> 202"
    );
    let daemon = Entry {
        robot: None,
        ..entry(Kind::DaemonStopping)
    };
    assert_eq!(
        daemon.to_string(),
        "2026-11-28T08:48:01.123Z #41 daemon-stopping"
    );
}

#[test]
fn faults_cycle_ends_pallets_and_reloads_are_durable_commands_are_batched() {
    assert!(
        Kind::Fault {
            code: None,
            reason: String::new()
        }
        .durable()
    );
    assert!(
        Kind::PalletFull {
            pallet: "p".into(),
            parts: 1
        }
        .durable()
    );
    assert!(Kind::ModeChanged { mode: Mode::Local }.durable());
    assert!(
        Kind::ConfigRefused {
            error: String::new()
        }
        .durable()
    );
    assert!(!Kind::Resume.durable());
    assert!(
        !Kind::Command {
            source: Source::Api,
            who: None,
            action: String::new(),
            status: None,
            refused: None
        }
        .durable()
    );
}

#[test]
fn a_line_that_is_not_an_entry_is_refused() {
    for line in [
        "",
        "{",
        "{\"seq\":1}",
        "{\"seq\":1,\"at\":\"x\",\"kind\":\"resume\"}",
    ] {
        assert!(Entry::from_line(line).is_err(), "{line}");
    }
}
