//! The operator's side of the pallets (issue 48, item 4) with the daemon on the mock: a count
//! left with a slot in progress comes back unsure and is shown so by the API; set, reset, redo
//! and go-on change it on disk, refused with a clear error for an index past the slots, an
//! unknown pallet and while a cycle runs (a choice for the unsure slot is taken then); every
//! command is journaled with who sent it; `/metrics` counts the parts and pallets; the cell
//! face shows the pallet's words at the end of its block and takes redo and go-on in remote mode.

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::daemon::{duplex_connector, signals, taking_moves};
use common::exchange::mock_at_seed_start;
use common::http::Endpoint;
use linterpd::cell::Mode;
use linterpd::cell::face::{
    BLOCK_WORDS, Refusal, STATUS_AT, bit, pallet_bit, status_bit, status_word,
};
use linterpd::config::{CellSettings, FaceSettings, JournalSettings};
use linterpd::daemon::api::Api;
use linterpd::daemon::pallets::{PALLETS_FILE, PalletCounters, Pallets};
use linterpd::daemon::{CycleState, Daemon, DaemonOptions, RobotHandle, RobotSetup};
use linterpd::journal::{Journal, Query};
use linterpd::kinematics::JOINTS;
use linterpd::pallet::RobotPallets;
use linterpd::pallet::doc::{FrameDoc, PalletDoc};
use linterpd::plc::exchange::ContractSettings;
use linterpd::robot::seed_robot;
use linterpd::wire::journal::{Kind, Source};
use serde_json::{Value, json};
use tokio_util::sync::CancellationToken;

const LIMIT: Duration = Duration::from_secs(20);
const ROBOT: &str = "/v1/robots/press-loader";

/// "out": 2 x 3 in 2 layers (12 slots); "in": a listed layer of 2.
const PALLETS: &str = r#"
[out]
origin_mm = [600, 0, 100]
rows = 2
columns = 3
pitch_mm = [50, 50]
layer_height_mm = 40
layers = 2
[in]
origin_mm = [0, 600, 100]
layer_height_mm = 40
layers = ["L"]
kinds.L = { slots = [[0, 0, 0], [50, 0, 0]] }
"#;

/// The counters a daemon killed while placing at slot 4 of "out" (the part at the slot) left.
const LEFT: &str = r#"{"linterpd_pallets": 1, "robots": {"press-loader": {"out": {"index": 4,
  "in_progress": {"slot": 4, "phase": "at-slot"}, "full": false, "parts": 16, "pallets": 1}}}}"#;

fn temp(test: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("linterpd-palletops-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn pallets(dir: &Path) -> Arc<Pallets> {
    let frames = std::collections::BTreeMap::<String, FrameDoc>::new();
    let docs: std::collections::BTreeMap<String, PalletDoc> = toml::from_str(PALLETS).unwrap();
    let set = RobotPallets::check(&frames, &docs).unwrap();
    Arc::new(Pallets {
        sets: [("press-loader".to_owned(), set)].into(),
        counters: PalletCounters::in_state_dir(dir),
    })
}

/// The counter of "out" as a restart reads it from `dir`.
fn on_disk(dir: &Path) -> linterpd::pallet::Counter {
    PalletCounters::in_state_dir(dir).get("press-loader", "out")
}

struct Rig {
    daemon: Daemon,
    h: RobotHandle,
    journal: Journal,
    closing: CancellationToken,
    api: Endpoint,
}

/// The daemon on the mock with the pallets counted in `dir`, a program `waits` that waits for
/// an input that never comes, the face showing `face_pallet`, and the API with a journal.
async fn rig(dir: &Path, face_pallet: Option<&str>) -> Rig {
    let shared = mock_at_seed_start("");
    let program = "[[step]]\nwait = \"press_open\"\ntimeout = \"60s\"\n".to_owned();
    let programs = common::daemon::programs_dir(
        "palletops",
        dir.file_name().unwrap().to_str().unwrap(),
        &[("waits", program)],
    );
    let journal = Journal::open(&dir.join("journal"), &JournalSettings::default()).unwrap();
    let options = DaemonOptions {
        journal: journal.clone(),
        pallets: pallets(dir),
        ..DaemonOptions::default()
    };
    let face = FaceSettings {
        registers: 50_000,
        plc: None,
        home: "home".to_owned(),
        positions: Vec::new(),
        mode: Mode::Local,
        pallet: face_pallet.map(str::to_owned),
    };
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect: duplex_connector(&shared, None),
        home_counts: [0; JOINTS],
        gateway: linterpd::gateway::GatewaySettings::default(),
        cell: CellSettings {
            signals: signals(&[("press_open", "X5")]),
            programs: Some(programs),
            face: Some(face),
            ..CellSettings::default()
        },
    };
    let daemon = Daemon::spawn(vec![setup], &options);
    let h = daemon.robot("press-loader").unwrap().clone();
    let closing = CancellationToken::new();
    let socket = dir.join("api.sock");
    let router = Api::new(daemon.robots().clone())
        .with_journal(journal.clone())
        .router(None);
    let listener = tokio::net::UnixListener::bind(&socket).unwrap();
    tokio::spawn(linterpd::daemon::api::serve(
        listener,
        router,
        closing.clone().cancelled_owned(),
    ));
    taking_moves(&h).await;
    Rig {
        daemon,
        h,
        journal,
        closing,
        api: Endpoint::unix(&socket),
    }
}

async fn until_cycle(h: &RobotHandle, state: CycleState) {
    let began = Instant::now();
    while h.cycle().is_none_or(|c| c.state != state) {
        assert!(began.elapsed() < LIMIT, "never {state:?}: {:?}", h.cycle());
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

fn pallet<'a>(list: &'a Value, name: &str) -> &'a Value {
    list["pallets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == name)
        .unwrap_or_else(|| panic!("no {name} in {list}"))
}

#[tokio::test]
async fn the_operator_sees_and_changes_the_counts_through_the_api_refused_while_a_cycle_runs() {
    let dir = temp("api");
    std::fs::write(dir.join(PALLETS_FILE), LEFT).unwrap();
    let Rig {
        daemon,
        h,
        journal,
        closing,
        api,
    } = rig(&dir, None).await;

    // The slot in progress comes back unsure.
    let list = api.get(&format!("{ROBOT}/pallets")).await;
    assert_eq!(list.status, 200, "{}", list.text());
    let list = list.json();
    assert_eq!(
        pallet(&list, "out"),
        &json!({"name": "out", "slots": 12, "layers": 2, "index": 4, "layer": 0,
                "in_progress": {"slot": 4, "phase": "unsure", "unsure": true},
                "full": false, "parts": 16, "pallets": 1, "known": true})
    );
    assert_eq!(pallet(&list, "in")["slots"], 2);
    assert_eq!(pallet(&list, "in")["index"], 0);
    assert!(list.get("warning").is_none(), "{list}");

    refusals_name_the_value_and_change_nothing(&api, &dir).await;
    a_running_cycle_takes_only_the_choice(&api, &h, &dir).await;
    metrics_and_journal_count_the_changes(&api, &journal).await;
    closing.cancel();
    daemon.shut_down().await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad input: named, nothing changed.
async fn refusals_name_the_value_and_change_nothing(api: &Endpoint, dir: &Path) {
    let past = api
        .post(&format!("{ROBOT}/pallets/out/set"), r#"{"index": 13}"#)
        .await;
    assert_eq!(past.status, 400, "{}", past.text());
    let e = past.json();
    assert_eq!(e["field"], "index");
    let message = e["error"].as_str().unwrap();
    assert!(
        message.contains("index 13 is past its last slot (11)")
            && message.contains("12 marks the pallet full"),
        "{message}"
    );
    let none = api.post(&format!("{ROBOT}/pallets/top/reset"), "").await;
    assert_eq!(none.status, 404);
    assert_eq!(none.json()["field"], "pallet");
    assert!(
        none.text().contains("its pallets: in, out"),
        "{}",
        none.text()
    );
    let nothing = api.post(&format!("{ROBOT}/pallets/in/go-on"), "").await;
    assert_eq!(
        (nothing.status.as_u16(), nothing.json()["reason"].clone()),
        (409, json!("nothing-to-choose"))
    );
    assert_eq!(on_disk(dir).index, 4);
}

/// A cycle waits: set and reset are refused, the choice for the unsure slot is taken; stopped,
/// set to the end and reset.
async fn a_running_cycle_takes_only_the_choice(api: &Endpoint, h: &RobotHandle, dir: &Path) {
    h.run_cycle("waits", None).await.unwrap();
    until_cycle(h, CycleState::Waiting).await;
    let refused = api
        .post(&format!("{ROBOT}/pallets/out/set"), r#"{"index": 2}"#)
        .await;
    assert_eq!(refused.status, 409, "{}", refused.text());
    assert_eq!(refused.json()["reason"], "cycle-running");
    assert!(
        refused.text().contains("cycle waits is waiting"),
        "{}",
        refused.text()
    );
    let went_on = api.post(&format!("{ROBOT}/pallets/out/go-on"), "").await;
    assert_eq!(went_on.status, 200, "{}", went_on.text());
    let went_on = went_on.json();
    assert_eq!(
        (went_on["index"].clone(), went_on["parts"].clone()),
        (json!(5), json!(17))
    );
    assert!(went_on.get("in_progress").is_none(), "{went_on}");
    let c = on_disk(dir);
    assert_eq!((c.index, c.parts, c.in_progress), (5, 17, None));
    // Nothing left to choose: while the cycle runs that is the cycle's count.
    let again = api.post(&format!("{ROBOT}/pallets/out/redo"), "").await;
    assert_eq!(again.json()["reason"], "cycle-running");

    // Stopped: set to the end (full), then a new pallet.
    h.stop_cycle(true).await.unwrap();
    until_cycle(h, CycleState::Stopped).await;
    let full = api
        .post(&format!("{ROBOT}/pallets/out/set"), r#"{"index": 12}"#)
        .await;
    assert_eq!(full.status, 200, "{}", full.text());
    assert_eq!(
        (full.json()["full"].clone(), full.json()["layer"].clone()),
        (json!(true), json!(1))
    );
    let reset = api
        .post(&format!("{ROBOT}/pallets/out/reset"), "")
        .await
        .json();
    assert_eq!(
        (
            reset["index"].clone(),
            reset["full"].clone(),
            reset["pallets"].clone()
        ),
        (json!(0), json!(false), json!(2))
    );
    let c = on_disk(dir);
    assert_eq!((c.index, c.full, c.parts, c.pallets), (0, false, 17, 2));
}

/// `/metrics` counts the parts and the pallets; every command is journaled with who sent it.
async fn metrics_and_journal_count_the_changes(api: &Endpoint, journal: &Journal) {
    let metrics = api.get("/metrics").await.text();
    for want in [
        "linterpd_pallet_parts_total{robot=\"press-loader\",pallet=\"out\"} 17",
        "linterpd_pallets_total{robot=\"press-loader\",pallet=\"out\"} 2",
        "linterpd_pallet_parts_total{robot=\"press-loader\",pallet=\"in\"} 0",
        "linterpd_pallet_index{robot=\"press-loader\",pallet=\"out\"} 0",
    ] {
        assert!(
            metrics.lines().any(|l| l == want),
            "no {want:?} in\n{metrics}"
        );
    }

    // Every command journaled with who sent it and how it was answered.
    journal.flush().await;
    let entries = journal
        .read(&Query {
            limit: usize::MAX,
            ..Query::default()
        })
        .unwrap();
    let commands: Vec<(String, Option<u16>, Option<String>)> = entries
        .iter()
        .filter_map(|e| match &e.kind {
            Kind::Command {
                source: Source::Api,
                who: Some(_),
                action,
                status,
                refused,
            } if action.contains("pallets/") => Some((action.clone(), *status, refused.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(
        commands[0],
        (
            "POST pallets/out/set {\"index\":13}".to_owned(),
            Some(400),
            commands[0].2.clone()
        )
    );
    assert!(
        commands[0]
            .2
            .as_deref()
            .is_some_and(|r| r.contains("past its last slot")),
        "{commands:?}"
    );
    assert!(
        commands.contains(&("POST pallets/out/go-on".to_owned(), Some(200), None)),
        "{commands:?}"
    );
    assert!(
        commands.contains(&(
            "POST pallets/out/set {\"index\":2}".to_owned(),
            Some(409),
            Some("cycle-running".to_owned())
        )),
        "{commands:?}"
    );
    assert_eq!(commands.len(), 8, "{commands:?}");
}

/// The face's status words (+8..) as the line reads them.
fn words(h: &RobotHandle) -> Vec<u16> {
    h.face_block().unwrap()[STATUS_AT..].to_vec()
}

#[tokio::test]
async fn the_face_shows_the_pallet_at_the_end_of_its_block_and_takes_redo_in_remote_mode() {
    let dir = temp("face");
    std::fs::write(dir.join(PALLETS_FILE), LEFT).unwrap();
    let Rig {
        daemon, h, closing, ..
    } = rig(&dir, Some("out")).await;
    assert_eq!(BLOCK_WORDS, 23);
    let w = words(&h);
    assert_eq!(
        w[status_word::PALLET..],
        [pallet_bit::SHOWN | pallet_bit::UNSURE, 4, 12, 0, 4]
    );
    assert!(w[status_word::BITS] & status_bit::LINKED != 0);
    // Local mode: the line's choice is refused; the baseline write first.
    assert!(h.face_write(0, &[0, 0, 0, 0]).await);
    h.face_write(2, &[bit::PALLET_REDO]).await;
    assert_eq!(words(&h)[status_word::REFUSED], Refusal::Local.code());
    h.set_mode(Mode::Remote).await.unwrap();
    h.face_write(0, &[0, 0, 0, 0]).await;
    h.face_write(2, &[bit::PALLET_REDO]).await;
    let w = words(&h);
    assert_eq!(w[status_word::REFUSED], 0);
    assert_eq!(w[status_word::PALLET..], [pallet_bit::SHOWN, 4, 12, 0, 0]);
    let c = on_disk(&dir);
    assert_eq!((c.index, c.parts, c.in_progress), (4, 16, None));
    // Nothing left to choose: refused with its code.
    h.face_write(2, &[0]).await;
    h.face_write(2, &[bit::PALLET_GO_ON]).await;
    assert_eq!(
        words(&h)[status_word::REFUSED],
        Refusal::NothingToChoose.code()
    );
    assert_eq!(on_disk(&dir).index, 4);
    closing.cancel();
    daemon.shut_down().await;
    let _ = std::fs::remove_dir_all(&dir);
}
