//! The cell face served on the Modbus face against the mock PLC: the line selects a program by
//! its number, strobe and check word, starts it and watches it to its end; bad strobes are
//! refused with their reason and nothing runs; one controller at a time (the mode); move-enable
//! holds the robot and the cycle, which goes on only on a fresh start; a stop works in both
//! modes; a restarted face starts nothing by itself.

use crate::common;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use common::daemon::{duplex_connector, signals, spawn_in_cell, taking_moves};
use common::exchange::{P1, P2, mock_at_seed_start};
use linterpd::cell::Mode;
use linterpd::cell::face::{Refusal, STATUS_AT, bit, check_of, status_bit, status_word};
use linterpd::config::{CellSettings, FaceSettings};
use linterpd::contract::{Layout, State};
use linterpd::daemon::modbus_face::ModbusFaceServer;
use linterpd::daemon::{CycleState, Daemon, MIRROR_EVERY, ModeError, RobotHandle};
use linterpd::gateway::{AccessList, GatewaySettings, ModbusFace};
use linterpd::mock::SharedMock;
use tokio::net::TcpListener;
use tokio_modbus::client::{Context, Reader, Writer};

const LIMIT: Duration = Duration::from_secs(20);
const BASE: u16 = 50_000;
const ON: u16 = bit::ENABLE;
/// Where the face is mirrored in the PLC.
const MIRROR: u32 = 3_000;

fn programs(test: &str, files: &[(&str, String)]) -> PathBuf {
    common::daemon::programs_dir("face", test, files)
}

fn to(p: [f64; 3]) -> String {
    format!("{{ to = [{}, {}, {}] }}", p[0], p[1], p[2])
}

/// Program 3: wait for the press, out to P2, back to P1.
fn load() -> String {
    format!(
        "number = 3\n[[step]]\nwait = \"press_open\"\ntimeout = \"20s\"\n\
         [[step]]\nmove = {}\n[[step]]\nmove = {}\n",
        to(P2),
        to(P1)
    )
}

struct Cell {
    shared: SharedMock,
    daemon: Daemon,
    h: RobotHandle,
    line: Context,
    address: SocketAddr,
}

async fn cell(test: &str, mode: Mode) -> Cell {
    cell_with(test, mode, None).await
}

/// A cell whose face is mirrored in the PLC from DT`mirror` (not served on Modbus).
async fn cell_with(test: &str, mode: Mode, mirror: Option<u32>) -> Cell {
    let shared = mock_at_seed_start("");
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let modbus = ModbusFace {
        listen: address,
        allow: Vec::new(),
    };
    let cell = CellSettings {
        signals: signals(&[("press_open", "X5")]),
        programs: Some(programs(test, &[("load", load())])),
        require_wait_timeout: false,
        face: Some(FaceSettings {
            registers: BASE,
            plc: mirror,
            home: "home".to_owned(),
            positions: vec!["home".to_owned(), "out".to_owned()],
            mode,
        }),
    };
    let access = AccessList::new(Vec::new(), Vec::new(), &Layout::default()).unwrap();
    let gateway = GatewaySettings {
        access,
        modbus: Some(modbus.clone()),
    };
    let (daemon, h) = spawn_in_cell(duplex_connector(&shared, None), cell, gateway);
    tokio::spawn(linterpd::daemon::mirror_face(
        h.clone(),
        std::future::pending(),
    ));
    let server = ModbusFaceServer::on(listener, &modbus);
    tokio::spawn(server.serve(h.clone(), std::future::pending()));
    taking_moves(&h).await;
    let line = tokio_modbus::client::tcp::connect(address).await.unwrap();
    Cell {
        shared,
        daemon,
        h,
        line,
        address,
    }
}

impl Cell {
    async fn write(&mut self, at: u16, words: &[u16]) {
        self.line
            .write_multiple_registers(BASE + at, words)
            .await
            .unwrap()
            .unwrap();
    }

    /// The command bits, as the line writes them.
    async fn bits(&mut self, bits: u16) {
        self.write(2, &[bits]).await;
    }

    /// A rising edge of `edge` with move-enable on.
    async fn edge(&mut self, edge: u16) {
        self.bits(ON).await;
        self.bits(ON | edge).await;
    }

    async fn status(&mut self) -> Vec<u16> {
        self.line
            .read_holding_registers(BASE + STATUS_AT as u16, 10)
            .await
            .unwrap()
            .unwrap()
    }

    async fn until(&mut self, what: &str, done: impl Fn(&[u16]) -> bool) -> Vec<u16> {
        let began = Instant::now();
        loop {
            let s = self.status().await;
            if done(&s) {
                return s;
            }
            assert!(
                began.elapsed() < LIMIT,
                "never {what}: {s:?} {:?}",
                self.h.cycle()
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }

    /// Program `number` strobed with `check`, then the strobe dropped.
    async fn strobe(&mut self, number: u16, check: u16) {
        self.write(0, &[number, check, ON | bit::STROBE]).await;
        self.bits(ON).await;
    }
}

fn on(s: &[u16], b: u16) -> bool {
    s[status_word::BITS] & b != 0
}

#[tokio::test]
async fn the_line_selects_by_number_and_check_starts_and_watches_the_cycle_to_done() {
    let mut c = cell("select", Mode::Remote).await;
    c.write(0, &[0, 0, ON, 0]).await; // the baseline
    let s = c.status().await;
    assert!(
        on(&s, status_bit::READY) && on(&s, status_bit::REMOTE),
        "{s:?}"
    );
    assert!(on(&s, status_bit::ENABLED) && on(&s, status_bit::LINKED));
    c.strobe(3, check_of(3)).await;
    let s = c.status().await;
    assert!(on(&s, status_bit::SELECTED), "{s:?}");
    assert_eq!(s[status_word::PROGRAM], 3);
    assert_eq!(s[status_word::REFUSED], 0);
    c.write(3, &[2]).await; // two cycles
    c.edge(bit::START).await;
    let s = c.until("waiting", |s| on(s, status_bit::WAITING)).await;
    assert_eq!(s[status_word::STEP], 1);
    assert!(!on(&s, status_bit::READY));
    let beat = s[status_word::HEARTBEAT];
    // Nothing moves until the press opens.
    tokio::time::sleep(Duration::from_millis(150)).await;
    assert!(c.shared.with(|m| m.starts().is_empty()));
    let now = c.status().await[status_word::HEARTBEAT];
    assert_ne!(now, beat, "the heartbeat counts: {:?}", c.h.state());
    c.shared.with(|m| m.set_input(5, true).unwrap());
    let s = c
        .until("two cycles done", |s| {
            s[status_word::DONE_LOW] == 2 && on(s, status_bit::READY)
        })
        .await;
    assert_eq!(s[status_word::STEP], 0);
    assert_eq!(c.h.cycle().unwrap().state, CycleState::Done);
    assert_eq!(c.shared.with(|m| m.starts().len()), 4);
}

#[tokio::test]
async fn bad_strobes_and_starts_are_refused_with_their_reason_and_nothing_runs() {
    let mut c = cell("strobes", Mode::Remote).await;
    c.write(0, &[0, 0, ON, 0]).await;
    for (number, check, why) in [
        (0, check_of(0), Refusal::NoProgram),
        (3, 3, Refusal::BadCheck),
        (9, check_of(9), Refusal::UnknownProgram),
    ] {
        c.strobe(number, check).await;
        let s = c.status().await;
        assert_eq!(s[status_word::REFUSED], why.code(), "{number}: {s:?}");
        assert!(on(&s, status_bit::REFUSED) && !on(&s, status_bit::SELECTED));
        c.edge(bit::START).await;
        let s = c.status().await;
        assert_eq!(s[status_word::REFUSED], Refusal::NotSelected.code());
        // The robot's state says it too, in words.
        let face = c.h.state().face.unwrap();
        assert_eq!((face.program, face.enabled), (0, true));
        let refused = face.refused.unwrap();
        assert_eq!(
            (refused.code, refused.meaning.as_str()),
            (7, "no program is selected")
        );
    }
    // The number toggled while the strobe is on: the selection goes, and a start is refused.
    c.write(0, &[3, check_of(3), ON | bit::STROBE]).await;
    assert_eq!(c.status().await[status_word::PROGRAM], 3);
    c.write(0, &[4, check_of(4)]).await;
    let s = c.status().await;
    assert_eq!(s[status_word::REFUSED], Refusal::ChangedDuringStrobe.code());
    assert_eq!(s[status_word::PROGRAM], 0);
    c.edge(bit::START).await;
    assert_eq!(
        c.status().await[status_word::REFUSED],
        Refusal::NotSelected.code()
    );
    assert!(c.h.cycle().is_none(), "no cycle ran");
    assert!(c.shared.with(|m| m.starts().is_empty()));
    // The status words and the reserved words are not the line's to write.
    let e = c.line.write_single_register(BASE + 8, 1).await.unwrap();
    assert_eq!(e, Err(tokio_modbus::ExceptionCode::IllegalDataAddress));
    let e = c.line.write_single_register(BASE + 4, 1).await.unwrap();
    assert_eq!(e, Err(tokio_modbus::ExceptionCode::IllegalDataAddress));
}

#[tokio::test]
async fn one_controller_at_a_time_and_exactly_one_of_two_racing_wins() {
    let mut c = cell("mode", Mode::Local).await;
    c.write(0, &[0, 0, ON, 0]).await;
    // Local: the face's start is refused, the CLI's is taken.
    c.strobe(3, check_of(3)).await;
    assert_eq!(
        c.status().await[status_word::REFUSED],
        Refusal::Local.code()
    );
    assert!(c.h.owned_by(Mode::Local).await.is_ok());
    // Remote: the CLI's is refused, naming the mode.
    c.h.set_mode(Mode::Remote).await.unwrap();
    let e = c.h.owned_by(Mode::Local).await.unwrap_err();
    assert!(e.to_string().contains("remote mode"), "{e}");
    // Racing a mode change back to local against the face's start: exactly one wins.
    c.write(0, &[0, 0, ON, 0]).await; // the baseline after the mode change
    c.strobe(3, check_of(3)).await;
    c.bits(ON).await;
    let h = c.h.clone();
    let to_local = tokio::spawn(async move { h.set_mode(Mode::Local).await });
    c.bits(ON | bit::START).await;
    let mode_won = to_local.await.unwrap();
    let face_won = c.h.cycle().is_some();
    assert!(
        mode_won.is_ok() != face_won,
        "{mode_won:?} {:?}",
        c.h.cycle()
    );
    if face_won {
        assert!(matches!(mode_won, Err(ModeError::Busy { .. })));
        assert_eq!(c.h.mode(), Mode::Remote);
        // And a local run now is refused, while the face's cycle runs.
        assert!(c.h.owned_by(Mode::Local).await.is_err());
    } else {
        // The mode changed first: the start was the new baseline's write (no edge), and
        // nothing ran.
        assert_eq!(c.h.mode(), Mode::Local);
        assert!(c.shared.with(|m| m.starts().is_empty()));
    }
    // The mode never changes under a running cycle.
    if face_won {
        c.edge(bit::STOP_NOW).await;
        c.until("stopped", |s| !on(s, status_bit::WAITING)).await;
    }
}

#[tokio::test]
async fn move_enable_dropping_stops_the_robot_and_pauses_the_cycle_until_a_fresh_start() {
    let mut c = cell("enable", Mode::Remote).await;
    c.shared.with(|m| m.set_input(5, true).unwrap());
    c.write(0, &[0, 0, ON, 1]).await;
    c.strobe(3, check_of(3)).await;
    c.edge(bit::START).await;
    // Once the robot moves, the line drops move-enable.
    let began = Instant::now();
    while c.shared.with(|m| m.status().state) != State::Running.word() {
        assert!(began.elapsed() < LIMIT, "never moved");
        tokio::time::sleep(Duration::from_millis(2)).await;
    }
    c.bits(0).await;
    let s = c.until("paused", |s| on(s, status_bit::PAUSED)).await;
    assert!(!on(&s, status_bit::ENABLED));
    assert_ne!(c.shared.with(|m| m.status().state), State::Running.word());
    let status = c.h.cycle().unwrap();
    assert!(
        status
            .reason
            .as_deref()
            .unwrap()
            .contains("move-enable dropped"),
        "{status:?}"
    );
    // No motion while it is off, from anyone; a start is refused naming it.
    let e =
        c.h.submit(linterpd::daemon::MoveOrder {
            to: Some(P1.to_vec()),
            ..Default::default()
        })
        .await;
    assert!(e.unwrap_err().to_string().contains("move-enable is off"));
    c.bits(bit::START).await;
    assert_eq!(
        c.status().await[status_word::REFUSED],
        Refusal::NotEnabled.code()
    );
    // On again: nothing goes on by itself; a start edge resumes the held move, and it ends.
    c.bits(ON).await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    assert_eq!(c.h.cycle().unwrap().state, CycleState::Paused);
    c.edge(bit::START).await;
    let s = c.until("done", |s| s[status_word::DONE_LOW] == 1).await;
    assert!(on(&s, status_bit::READY), "{s:?}");
    let ended_at = c.h.state().counts.unwrap();
    let started_at = c.shared.with(|m| m.starts()[0].counts);
    assert_eq!(ended_at, started_at, "back at P1");
}

#[tokio::test]
async fn a_stop_works_in_both_modes_and_home_moves_to_the_taught_home() {
    let mut c = cell("stop", Mode::Local).await;
    c.write(0, &[0, 0, ON, 0]).await;
    // A locally run cycle, stopped now from the face in local mode.
    c.h.run_cycle("load", None).await.unwrap();
    c.until("waiting", |s| on(s, status_bit::WAITING)).await;
    c.edge(bit::STOP_NOW).await;
    let s = c.until("stopped", |s| !on(s, status_bit::WAITING)).await;
    assert_eq!(c.h.cycle().unwrap().state, CycleState::Stopped, "{s:?}");
    // Home: refused without a taught home, then to it.
    c.h.set_mode(Mode::Remote).await.unwrap();
    c.write(0, &[0, 0, ON, 0]).await;
    c.edge(bit::HOME).await;
    assert_eq!(
        c.status().await[status_word::REFUSED],
        Refusal::NoHome.code()
    );
    c.h.save_position("home", None).unwrap();
    let s = c.status().await;
    assert!(
        on(&s, status_bit::IN_HOME) && s[status_word::POSITION] == 1,
        "{s:?}"
    );
    c.h.set_mode(Mode::Local).await.unwrap();
    let id =
        c.h.submit(linterpd::daemon::MoveOrder {
            to: Some(P2.to_vec()),
            ..Default::default()
        })
        .await
        .unwrap();
    c.h.wait(id, LIMIT).await;
    c.h.save_position("out", None).unwrap();
    let s = c.status().await;
    assert!(
        !on(&s, status_bit::IN_HOME) && s[status_word::POSITION] == 2,
        "{s:?}"
    );
    c.h.set_mode(Mode::Remote).await.unwrap();
    c.write(0, &[0, 0, ON, 0]).await;
    c.edge(bit::HOME).await;
    let s = c.until("in home", |s| on(s, status_bit::IN_HOME)).await;
    assert_eq!(s[status_word::REFUSED], 0);
    assert_eq!(s[status_word::POSITION], 1);
}

#[tokio::test]
async fn a_fresh_face_takes_its_first_write_as_the_baseline_and_starts_nothing() {
    let mut c = cell("baseline", Mode::Remote).await;
    c.shared.with(|m| m.set_input(5, true).unwrap());
    // A line that writes its whole block every scan, start held on from before the restart.
    for _ in 0..3 {
        c.write(0, &[3, check_of(3), ON | bit::STROBE | bit::START, 1])
            .await;
    }
    tokio::time::sleep(Duration::from_millis(100)).await;
    assert!(c.h.cycle().is_none());
    assert_eq!(c.status().await[status_word::PROGRAM], 0);
    // A second connection (the HMI reconnecting) is no edge either.
    let mut again = tokio_modbus::client::tcp::connect(c.address).await.unwrap();
    again
        .write_multiple_registers(BASE, &[3, check_of(3), ON | bit::STROBE | bit::START, 1])
        .await
        .unwrap()
        .unwrap();
    assert!(c.h.cycle().is_none());
    assert!(c.shared.with(|m| m.starts().is_empty()));
}

#[tokio::test]
async fn the_api_shows_and_sets_the_mode_and_refuses_local_orders_in_remote_mode() {
    use common::http::Endpoint;
    use hyper::StatusCode;
    let mut c = cell("api", Mode::Local).await;
    let dir = common::process::TempDir::new("face-api");
    let path = dir.path().join("api.sock");
    let listener = tokio::net::UnixListener::bind(&path).unwrap();
    let router = linterpd::daemon::api::Api::new(c.daemon.robots().clone()).router(None);
    tokio::spawn(linterpd::daemon::api::serve(
        listener,
        router,
        std::future::pending(),
    ));
    let api = Endpoint::unix(&path);
    let robot = "/v1/robots/press-loader";
    let mode = api.get(&format!("{robot}/mode")).await;
    assert_eq!(mode.json()["mode"], "local");
    let set = |m: &str| format!(r#"{{"mode": "{m}"}}"#);
    let put = api
        .call("PUT", &format!("{robot}/mode"), Some(&set("remote")), None)
        .await;
    assert_eq!(put.status, StatusCode::OK, "{}", put.text());
    assert_eq!(api.get(robot).await.json()["mode"], "remote");
    // Remote: the local controller's orders are 409 mode-remote; a stop is taken.
    c.write(0, &[0, 0, ON, 0]).await;
    let to = format!(r#"{{"to": [{}, {}, {}]}}"#, P2[0], P2[1], P2[2]);
    for (path, body) in [
        ("moves", to.as_str()),
        ("cycles", r#"{"program": "load"}"#),
        ("home", ""),
    ] {
        let a = api.post(&format!("{robot}/{path}"), body).await;
        assert_eq!(a.status, StatusCode::CONFLICT, "{path}: {}", a.text());
        assert_eq!(a.json()["reason"], "mode-remote", "{path}");
        assert!(a.json()["error"].as_str().unwrap().contains("remote mode"));
    }
    assert_eq!(
        api.post(&format!("{robot}/stop"), "").await.status,
        StatusCode::OK
    );
    // The face's cycle runs: the mode does not change under it.
    c.strobe(3, check_of(3)).await;
    c.edge(bit::START).await;
    c.until("waiting", |s| on(s, status_bit::WAITING)).await;
    let put = api
        .call("PUT", &format!("{robot}/mode"), Some(&set("local")), None)
        .await;
    assert_eq!(put.status, StatusCode::CONFLICT, "{}", put.text());
    assert_eq!(put.json()["reason"], "busy");
    assert!(
        put.text().contains("cycle load is waiting"),
        "{}",
        put.text()
    );
    // A cycle stop from the API is taken in remote mode; then the mode changes.
    let stop = api.post(&format!("{robot}/cycles/stop"), "{}").await;
    assert_eq!(stop.status, StatusCode::OK, "{}", stop.text());
    c.until("stopped", |s| !on(s, status_bit::WAITING)).await;
    let put = api
        .call("PUT", &format!("{robot}/mode"), Some(&set("local")), None)
        .await;
    assert_eq!(put.status, StatusCode::OK, "{}", put.text());
    let bad = api
        .call("PUT", &format!("{robot}/mode"), Some(&set("auto")), None)
        .await;
    assert_eq!(bad.status, StatusCode::BAD_REQUEST, "{}", bad.text());
}

#[tokio::test]
async fn a_press_plc_wired_to_the_robots_plc_drives_the_face_mirrored_in_its_dt_words() {
    let c = cell_with("mirror", Mode::Remote, Some(MIRROR)).await;
    c.shared.with(|m| m.set_input(5, true).unwrap());
    let plc = |words: &[u16]| c.shared.with(|m| m.write_words(MIRROR, words).unwrap());
    // The mirror writes the status words, the heartbeat counting.
    let s = mirrored_until(&c.shared, "the status words", |s| on(s, status_bit::REMOTE)).await;
    let beat = s[status_word::HEARTBEAT];
    mirrored_until(&c.shared, "a heartbeat", |s| {
        s[status_word::HEARTBEAT] != beat
    })
    .await;
    // The press PLC's program: the baseline, the strobe, the start.
    plc(&[0, 0, ON, 1]);
    mirrored_until(&c.shared, "ready", |s| on(s, status_bit::READY)).await;
    plc(&[3, check_of(3), ON | bit::STROBE]);
    mirrored_until(&c.shared, "selected", |s| s[status_word::PROGRAM] == 3).await;
    plc(&[3, check_of(3), ON]);
    mirrored_until(&c.shared, "strobe taken off", |s| {
        s[status_word::COMMANDS] == ON
    })
    .await;
    plc(&[3, check_of(3), ON | bit::START]);
    let s = mirrored_until(&c.shared, "one cycle done", |s| {
        s[status_word::DONE_LOW] == 1
    })
    .await;
    assert_eq!(s[status_word::REFUSED], 0, "{s:?}");
    assert_eq!(c.shared.with(|m| m.starts().len()), 2);
    assert_eq!(c.h.cycle().unwrap().state, CycleState::Done);
    // The command words are the line's: the daemon never wrote them.
    let commands = c.shared.with(|m| m.read_words(MIRROR, 4).unwrap());
    assert_eq!(commands, [3, check_of(3), ON | bit::START, 1]);
}

/// The status words mirrored in the PLC, once `done` says so.
async fn mirrored_until(
    shared: &SharedMock,
    what: &str,
    done: impl Fn(&[u16]) -> bool,
) -> Vec<u16> {
    let began = Instant::now();
    loop {
        let s = shared.with(|m| m.read_words(MIRROR + STATUS_AT as u32, 10).unwrap());
        if done(&s) {
            return s;
        }
        assert!(began.elapsed() < LIMIT, "never {what}: {s:?}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test]
async fn the_mirror_goes_quiet_while_the_link_is_down_and_rewrites_the_status_once_back() {
    let c = cell_with("mirror-link", Mode::Remote, Some(MIRROR)).await;
    mirrored_until(&c.shared, "linked", |s| on(s, status_bit::LINKED)).await;
    // The press PLC selects program 3 while the link is down: nothing is read, nothing written.
    c.shared
        .with(|m| m.set_faults("close@100%".parse().unwrap()));
    let began = Instant::now();
    while c.h.state().link.connected {
        assert!(began.elapsed() < LIMIT, "the link never went down");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    let frozen = c
        .shared
        .with(|m| m.read_words(MIRROR + STATUS_AT as u32, 10).unwrap());
    c.shared.with(|m| {
        m.write_words(MIRROR, &[3, check_of(3), ON | bit::STROBE, 0])
            .unwrap();
    });
    tokio::time::sleep(MIRROR_EVERY * 3).await;
    let still = c
        .shared
        .with(|m| m.read_words(MIRROR + STATUS_AT as u32, 10).unwrap());
    assert_eq!(still, frozen, "written while the link was down");
    assert_eq!(
        c.h.state().face.unwrap().commands,
        0,
        "read while the link was down"
    );
    // Back: the command words are read (the strobe's edge selects program 3) and the status
    // words written again.
    c.shared.with(|m| m.set_faults("".parse().unwrap()));
    let s = mirrored_until(&c.shared, "program 3 selected", |s| {
        s[status_word::PROGRAM] == 3 && on(s, status_bit::LINKED)
    })
    .await;
    assert_eq!(s[status_word::COMMANDS], ON | bit::STROBE);
    assert_eq!(s[status_word::REFUSED], 0);
}
