//! A cycle program's pallet steps run by the daemon on the in-process mock (issue 48, items 3
//! and 4): a small interlocked pallet placed to full, each slot's place ending on that slot's
//! counts, the counter on disk and the journal; and a daemon killed mid-place, restarted on the
//! same state directory, refusing to place until the operator chooses, then neither skipping a
//! slot nor placing one twice. The independent record of the places is the mock's: every start
//! records the channels' counts and the cell's input words (the gripper, R100, is in them), so a
//! start that begins on a slot's counts with the gripper open is a part left on that slot. A
//! power cut of the PLC mid-place (the gripper's relay lost with the counts) is followed on the
//! mock's record of the gripper instead (`tests/common/places.rs`): the relay opening while it
//! held a part, on a slot's counts, is a part left there.

use crate::common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::daemon::{duplex_connector, signals, taking_moves};
use common::exchange::{P1, mock_at_seed_start};
use linterpd::config::{CellSettings, JournalSettings};
use linterpd::contract::Layout;
use linterpd::daemon::pallets::{PALLETS_FILE, PalletCounters, Pallets};
use linterpd::daemon::{
    CycleState, CycleStatus, Daemon, DaemonOptions, PalletCommand, RobotHandle, RobotSetup,
};
use linterpd::gateway::{AccessList, Area, GatewaySettings};
use linterpd::geometry::Pose;
use linterpd::journal::{Journal, Query};
use linterpd::kinematics::{JOINTS, Kinematics};
use linterpd::mock::{SharedMock, StartRecord};
use linterpd::pallet::counter::Phase;
use linterpd::pallet::doc::{FrameDoc, PalletDoc};
use linterpd::pallet::{Choice, Counter, Pattern, RobotPallets};
use linterpd::plc::exchange::ContractSettings;
use linterpd::robot::Robot;
use linterpd::wire::journal::Kind;

const LIMIT: Duration = Duration::from_secs(60);
const ROBOT: &str = "press-loader";
const SLOTS: usize = 6;

/// A pallet station near the seed's P2, and on it 2 layers of 1 x 3, the second turned half a
/// turn and moved half a pitch (interlocked); approached from 80 mm above, the last 30 mm at
/// 120 mm/s. When full: `pallet_full` (Y1) set until `pallet_empty` (X3). The tool angle is the
/// one the robot has at P1 (its wrist at 0): layer 2's half turn is the only wrist turn, slowed
/// down for (the wrist's 20 kHz turn it at 50 degrees a second).
const PALLET: &str = r#"
frame = "station"
a_deg = 150
rows = 1
columns = 3
pitch_mm = [100, 100]
layer_height_mm = 60
layers = ["A", "B"]
kinds.A = {}
kinds.B = { turn_deg = 180, shift_mm = [50, 0] }
approach = { height_mm = 80, slow_mm = 30, slow_speed_mm_s = 120 }
when_full = { signal = "pallet_full", wait_for = "pallet_empty" }
"#;

/// Pick at P1 (the gripper closes), place on the pallet (the gripper opens at the slot).
fn program() -> String {
    program_at(P1, ", speed_mm_s = 300")
}

/// Pick at `pick`, place on the pallet, the moves' `speed` given as a key of their tables
/// (`""`: the robot's).
fn program_at(pick: [f64; 3], speed: &str) -> String {
    format!(
        r#"
[[step]]
move = {{ to = [{}, {}, {}]{speed} }}
[[step]]
set = {{ gripper = true }}
[[step]]
place = {{ pallet = "out"{speed}, at_slot = [ {{ set = {{ gripper = false }} }}, {{ dwell = "300ms" }} ] }}
"#,
        pick[0], pick[1], pick[2]
    )
}

fn temp(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("linterpd-pallets-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The pallet station's frame.
const STATION: &str = "station = { origin = [-1050, 600, 60] }";

/// The robot's pallets: `out`, as `pallet` gives it, on the station `frames` give.
fn robot_pallets(frames: &str, pallet: &str) -> RobotPallets {
    let frames: BTreeMap<String, FrameDoc> = toml::from_str(frames).unwrap();
    let pallets: BTreeMap<String, PalletDoc> =
        BTreeMap::from([("out".to_owned(), toml::from_str(pallet).unwrap())]);
    RobotPallets::check(&frames, &pallets).unwrap()
}

/// The daemon in a cell with a gripper (R100, in the status block's input words) and the
/// pallet's signals, its programs in `programs`, its counters and journal in `state`.
fn spawn(shared: &SharedMock, programs: &Path, state: &Path) -> (Daemon, RobotHandle, Journal) {
    spawn_with(shared, programs, state, (STATION, PALLET))
}

/// [`spawn`] with the frames and the pallet `out` as `frames` and `pallet` give them.
fn spawn_with(
    shared: &SharedMock,
    programs: &Path,
    state: &Path,
    (frames, pallet): (&str, &str),
) -> (Daemon, RobotHandle, Journal) {
    let ranges = |l: &[&str]| l.iter().map(|r| r.parse().unwrap()).collect();
    let access = AccessList::new(
        ranges(&["DT0-DT199"]),
        ranges(&["Y0-Y7", "R100-R10F"]),
        &Layout::default(),
    )
    .unwrap();
    let cell = CellSettings {
        signals: signals(&[
            ("gripper", "R100"),
            ("pallet_full", "Y1"),
            ("pallet_empty", "X3"),
        ]),
        programs: Some(programs.to_owned()),
        require_wait_timeout: false,
        face: None,
    };
    let journal = Journal::open(&state.join("journal"), &JournalSettings::default()).unwrap();
    let options = DaemonOptions {
        journal: journal.clone(),
        pallets: Arc::new(Pallets {
            sets: BTreeMap::from([(ROBOT.to_owned(), robot_pallets(frames, pallet))]),
            counters: PalletCounters::in_state_dir(state),
        }),
        ..DaemonOptions::default()
    };
    let setup = RobotSetup {
        robot: common::cylindrical(),
        settings: ContractSettings::default(),
        connect: duplex_connector(shared, None),
        home_counts: counts_at_p1(),
        gateway: GatewaySettings {
            access,
            modbus: None,
        },
        cell,
    };
    let d = Daemon::spawn(vec![setup], &options);
    let h = d.robot(ROBOT).unwrap().clone();
    (d, h, journal)
}

/// A cell of a test's own: the mock at the seed's start, the daemon on it ([`spawn_with`]) with
/// `program` as `palletise` and the frames and pallet given, taking moves.
struct Cell {
    shared: SharedMock,
    state: PathBuf,
    daemon: Daemon,
    h: RobotHandle,
    journal: Journal,
}

/// [`Cell`] for test `test` (its state and programs directories named for it).
async fn cell(test: &str, program: String, frames_and_pallet: (&str, &str)) -> Cell {
    let shared = mock_at_seed_start("");
    let state = temp(test);
    let programs = common::daemon::programs_dir("pallets", test, &[("palletise", program)]);
    let (daemon, h, journal) = spawn_with(&shared, &programs, &state, frames_and_pallet);
    taking_moves(&h).await;
    Cell {
        shared,
        state,
        daemon,
        h,
        journal,
    }
}

/// The joints' counts at P1, where the robot homes (after a power cut of the PLC).
fn counts_at_p1() -> [i64; JOINTS] {
    let robot = common::cylindrical();
    let pose = robot.pose_with_wrist_at_zero(P1[0], P1[1], P1[2]).unwrap();
    robot.counts_of(&robot.kinematics.ik(&pose, None).unwrap())
}

async fn until<T>(what: &str, mut done: impl FnMut() -> Option<T>) -> T {
    let began = Instant::now();
    loop {
        if let Some(t) = done() {
            return t;
        }
        assert!(began.elapsed() < LIMIT, "never {what}");
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

async fn cycle_until(h: &RobotHandle, what: &str, f: impl Fn(&CycleStatus) -> bool) -> CycleStatus {
    let began = Instant::now();
    loop {
        if let Some(s) = h.cycle().filter(|s| f(s)) {
            return s;
        }
        assert!(
            began.elapsed() < LIMIT,
            "never {what}: {:?}, counter {:?}",
            h.cycle(),
            counter(h)
        );
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

fn counter(h: &RobotHandle) -> Counter {
    h.pallet_counters().get(ROBOT, "out")
}

fn gripper_closed(shared: &SharedMock) -> bool {
    // R100: word 10, bit 0.
    shared.with(|m| m.read_bit(Area::R, 10 * 16).unwrap())
}

/// The counts per channel at `pose`: the robot's inverse kinematics of it.
fn channel_counts(robot: &Robot, pose: &Pose) -> [i64; 4] {
    let q = robot.kinematics.ik(pose, None).unwrap();
    let by_joint = robot.counts_of(&q);
    let mut by_channel = [0; 4];
    for (j, joint) in robot.joints.iter().enumerate() {
        by_channel[usize::from(joint.channel)] = by_joint[j];
    }
    by_channel
}

/// Each slot's counts per channel.
fn slot_counts(robot: &Robot, pattern: &Pattern) -> Vec<[i64; 4]> {
    pattern
        .slots()
        .iter()
        .map(|s| channel_counts(robot, &s.pose))
        .collect()
}

/// The mock's record of places: for every start that began with the gripper open on a slot's
/// counts (within a pulse), that slot, in order.
fn places(starts: &[StartRecord], slots: &[[i64; 4]]) -> Vec<usize> {
    starts
        .iter()
        .filter(|s| s.inputs[2] & 1 == 0)
        .filter_map(|s| {
            slots.iter().position(|c| {
                c.iter()
                    .zip(&s.counts)
                    .all(|(want, got)| (want - got).abs() <= 1)
            })
        })
        .collect()
}

fn file_counter(state: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(state.join(PALLETS_FILE)).unwrap();
    let file: serde_json::Value = serde_json::from_str(&text).unwrap();
    file["robots"][ROBOT]["out"].clone()
}

#[tokio::test(start_paused = true)]
async fn an_interlocked_pallet_is_placed_to_full_slot_by_slot_on_each_slots_counts() {
    let Cell {
        shared,
        state,
        daemon: _d,
        h,
        journal,
    } = cell("full", program(), (STATION, PALLET)).await;
    let pattern = h.pallet_patterns().unwrap().remove("out").unwrap();
    assert_eq!((pattern.len(), pattern.layers()), (SLOTS, 2));
    h.run_cycle("palletise", Some(SLOTS as u64)).await.unwrap();
    // Full: the cycle waits for an empty pallet with its signal set.
    let s = cycle_until(&h, "waiting for an empty pallet", |s| {
        s.waiting_for
            .as_deref()
            .is_some_and(|w| w.contains("pallet_empty"))
    })
    .await;
    assert_eq!(s.done, SLOTS as u64 - 1);
    let c = counter(&h);
    assert!(
        c.full && c.parts == SLOTS as u64 && c.in_progress.is_none(),
        "{c:?}"
    );
    let on_disk = file_counter(&state);
    assert_eq!(
        (on_disk["full"].as_bool(), on_disk["parts"].as_u64()),
        (Some(true), Some(6))
    );
    assert!(shared.with(|m| m.read_bit(Area::Y, 1).unwrap()));
    // Every slot once, in fill order, each where the robot's kinematics puts it.
    let robot = common::cylindrical();
    let slots = slot_counts(&robot, &pattern);
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(places(&starts, &slots), (0..SLOTS).collect::<Vec<_>>());
    // The turned layer is another place: no slot of layer 2 is on layer 1's.
    assert!(slots[3..].iter().all(|s| !slots[..3].contains(s)));
    // The journal: six parts placed, slot and layer from 1, and the pallet full.
    journal.flush().await;
    let entries = journal
        .read(&Query {
            limit: usize::MAX,
            ..Query::default()
        })
        .unwrap();
    let placed: Vec<(u32, u32)> = entries
        .iter()
        .filter_map(|e| match &e.kind {
            Kind::PalletPlaced { slot, layer, .. } => Some((*slot, *layer)),
            _ => None,
        })
        .collect();
    assert_eq!(placed, [(1, 1), (2, 1), (3, 1), (4, 2), (5, 2), (6, 2)]);
    let full: Vec<u32> = entries
        .iter()
        .filter_map(|e| match &e.kind {
            Kind::PalletFull { parts, .. } => Some(*parts),
            _ => None,
        })
        .collect();
    assert_eq!(full, [6]);
    // An empty pallet: the signal reset, the counter back to slot 0, a pallet counted.
    shared.with(|m| m.set_input(3, true).unwrap());
    cycle_until(&h, "done", |s| s.state == CycleState::Done).await;
    let c = counter(&h);
    assert_eq!((c.index, c.full, c.parts, c.pallets), (0, false, 6, 1));
    assert!(!shared.with(|m| m.read_bit(Area::Y, 1).unwrap()));
}

/// Runs 2 places of the program with the pallet `out` as `pallet` gives it: the slots placed
/// (the mock's record) and how many starts began on the counts of a slot's approach point,
/// `height_mm` above it, carrying a part (the gripper closed: the way in, at rest there).
async fn two_places(test: &str, pallet: &str) -> (Vec<usize>, usize) {
    let (places, at_above) = placed(test, (STATION, pallet), program(), 2).await;
    (places, at_above.len())
}

/// Runs `count` places of the program picking at `pick`, with `frames` and the pallet `out`
/// as given: the slots placed (the mock's record) and the slots whose way in came to rest at
/// its approach point (a start, carrying a part, began on that point's counts).
async fn placed(
    test: &str,
    frames_and_pallet: (&str, &str),
    program: String,
    count: u64,
) -> (Vec<usize>, Vec<usize>) {
    let Cell {
        shared,
        daemon: _d,
        h,
        ..
    } = cell(test, program, frames_and_pallet).await;
    let pattern = h.pallet_patterns().unwrap().remove("out").unwrap();
    h.run_cycle("palletise", Some(count)).await.unwrap();
    cycle_until(&h, "done", |s| s.state == CycleState::Done).await;
    let robot = common::cylindrical();
    let starts = shared.with(|m| m.starts().to_vec());
    let above: Vec<[i64; 4]> = pattern
        .slots()
        .iter()
        .map(|s| channel_counts(&robot, &s.approach[0].pose))
        .collect();
    let at_above = starts
        .iter()
        .filter(|s| s.inputs[2] & 1 != 0)
        .filter_map(|s| {
            above.iter().position(|c| {
                c.iter()
                    .zip(&s.counts)
                    .all(|(want, got)| (want - got).abs() <= 1)
            })
        })
        .collect();
    (places(&starts, &slot_counts(&robot, &pattern)), at_above)
}

/// `approach.blend_mm`: the way into each slot passes the approach point without coming to
/// rest there (no start begins on its counts, where without the blend the line down to the
/// slot begins), and still places each slot on its counts, in order.
#[tokio::test(start_paused = true)]
async fn a_blended_approach_passes_its_point_above_the_slot_without_a_stop() {
    let stopped = two_places("approach-stopped", PALLET).await;
    assert_eq!(stopped, (vec![0, 1], 2), "a stop above each slot");
    let blend = PALLET.replace(
        "slow_speed_mm_s = 120 }",
        "slow_speed_mm_s = 120, blend_mm = 40 }",
    );
    assert_ne!(blend, PALLET);
    let blended = two_places("approach-blended", &blend).await;
    assert_eq!(blended, (vec![0, 1], 0), "no stop above a slot");
}

/// `demo --pallet`'s pallet (interlocked layers of 6, every other one turned half a turn), its
/// approach blended, its slip sheets left out. The blended way into the first slot of the turned
/// layer would chain a part behind one too short for a serial link (measured at 115200 baud:
/// refused at its turn, the cycle faulted): that way runs with its corner a stop; the ways into
/// the other slots pass their approach point without one. Every slot is placed on its counts,
/// in order.
#[tokio::test(start_paused = true)]
async fn a_blended_approach_too_short_to_chain_behind_runs_stopped_the_others_blended() {
    let pallet = linterpd::demo::pallet::PALLET
        .replace(
            "slow_speed_mm_s = 60 }",
            "slow_speed_mm_s = 60, blend_mm = 30 }",
        )
        .replace("between_layers = \"slip-sheet\"\n", "");
    assert!(pallet.contains("blend_mm") && !pallet.contains("between_layers"));
    let frames = "station = { origin = [-700, 650, 0] }";
    let (places, stopped) = placed(
        "demo-blended",
        (frames, &pallet),
        program_at([-900.0, 450.0, 120.0], ""),
        12,
    )
    .await;
    assert_eq!(places, (0..12).collect::<Vec<_>>());
    // Blended into slot 6, the first of the turned layer, its way would chain a part behind
    // one of 0.10 s (the demo's refusal): stopped there; every other way blended.
    assert_eq!(stopped, [6]);
}

/// A daemon on a runtime of its own, as a process: killing it ends every task it spawned (the
/// worker, the cycle's owner and driver, its link to the mock) where it is, nothing written
/// after, as a SIGKILL would.
struct Process {
    daemon: Daemon,
    runtime: tokio::runtime::Runtime,
    h: RobotHandle,
}

impl Process {
    fn start(shared: &SharedMock, programs: &Path, state: &Path) -> Self {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .enable_all()
            .build()
            .unwrap();
        let (daemon, h, _) = {
            let _in = runtime.enter();
            spawn(shared, programs, state)
        };
        Self { daemon, runtime, h }
    }

    /// Kills it once `when` holds of the counter, then waits until the PLC (`shared`) has
    /// ended the starts it left running.
    async fn kill_when(self, shared: &SharedMock, what: &str, when: impl Fn(&Counter) -> bool) {
        until(what, || when(&counter(&self.h)).then_some(())).await;
        let Self {
            daemon, runtime, ..
        } = self;
        tokio::task::spawn_blocking(move || {
            drop(daemon);
            runtime.shutdown_timeout(Duration::from_secs(5));
        })
        .await
        .unwrap();
        // The start the killed daemon left running (and any waiting behind it) ends in the PLC.
        let running = linterpd::contract::State::Running.word();
        until("the killed daemon's starts ended", || {
            let s = shared.with(|m| m.status());
            (s.state != running && s.waiting == 0).then_some(())
        })
        .await;
    }
}

/// Runs the program on a restarted daemon: it refuses to place, naming the slot, until the
/// operator chooses `choice`; then it goes on (cleared and resumed).
async fn restart_and_choose(h: &RobotHandle, slot: usize, choice: Choice) {
    taking_moves(h).await;
    let c = counter(h);
    assert_eq!(c.needs_choice(), Some(slot), "{c:?}");
    h.run_cycle("palletise", None).await.unwrap();
    let s = cycle_until(h, "refusing to place", |s| s.state == CycleState::Faulted).await;
    let why = s.reason.unwrap_or_default();
    assert!(
        why.contains(&format!("slot {slot}")) && why.contains("choose redo"),
        "{why}"
    );
    h.pallet_counters()
        .set_by_operator(ROBOT, "out", |c| c.choose("out", choice, SLOTS))
        .unwrap();
    h.clear_fault().await.unwrap();
    h.resume_cycle().await.unwrap();
}

// Real time: each daemon "process" runs on a runtime of its own, whose clock paused time would
// not move (the mock's scans on this one would race ahead of it).
#[tokio::test]
async fn a_daemon_killed_mid_place_waits_for_the_operator_and_then_skips_no_slot_and_places_none_twice()
 {
    let shared = mock_at_seed_start("");
    let state = temp("kill");
    let programs = common::daemon::programs_dir("pallets", "kill", &[("palletise", program())]);
    let first = Process::start(&shared, &programs, &state);
    taking_moves(&first.h).await;
    first.h.run_cycle("palletise", None).await.unwrap();
    // Killed at slot 1 with the part let go: it is on the pallet.
    let open_at_slot = |c: &Counter, slot| {
        c.in_progress
            .is_some_and(|p| p.slot == slot && p.phase == Phase::AtSlot)
            && !gripper_closed(&shared)
    };
    first
        .kill_when(&shared, "at slot 1, the gripper open", |c| {
            open_at_slot(c, 1)
        })
        .await;
    let second = Process::start(&shared, &programs, &state);
    restart_and_choose(&second.h, 1, Choice::GoOn).await;
    // Killed on the way into slot 3, the part still held: nothing was placed there.
    let moving = second.h.clone();
    let moving_to = |c: &Counter, slot| {
        c.in_progress
            .is_some_and(|p| p.slot == slot && p.phase == Phase::Moving)
            && moving.state().current_move.is_some()
    };
    second
        .kill_when(&shared, "on the way to slot 3", |c| moving_to(c, 3))
        .await;
    let (_d, h, _) = spawn(&shared, &programs, &state);
    restart_and_choose(&h, 3, Choice::Redo).await;
    cycle_until(&h, "full", |s| {
        s.waiting_for
            .as_deref()
            .is_some_and(|w| w.contains("pallet_empty"))
    })
    .await;
    let c = counter(&h);
    assert!(c.full && c.parts == SLOTS as u64, "{c:?}");
    let pattern = h.pallet_patterns().unwrap().remove("out").unwrap();
    let slots = slot_counts(&common::cylindrical(), &pattern);
    let starts = shared.with(|m| m.starts().to_vec());
    assert_eq!(places(&starts, &slots), (0..SLOTS).collect::<Vec<_>>());
    h.stop_cycle(true).await.unwrap();
}

/// After a restart of the PLC with slot `slot` (from 0) in progress, the cycle faulted: nothing
/// is started or written by itself, the index stays at the slot and the slot waits for the
/// operator's choice, unsure on disk, and the journal says so (`why`: the cycle's reasons, for
/// the failure's message).
async fn left_unsure_by_the_restart(
    h: &RobotHandle,
    shared: &SharedMock,
    state: &Path,
    journal: &Journal,
    slot: usize,
    why: &str,
) {
    let before = shared.with(|m| (m.starts().len(), m.host_writes().len()));
    tokio::time::sleep(Duration::from_secs(1)).await;
    assert_eq!(
        shared.with(|m| (m.starts().len(), m.host_writes().len())),
        before,
        "nothing started or written by itself"
    );
    let c = counter(h);
    assert_eq!(
        (c.index, c.parts as usize, c.needs_choice()),
        (slot, slot, Some(slot)),
        "{why}: {c:?}"
    );
    assert_eq!(file_counter(state)["in_progress"]["phase"], "unsure");
    journal.flush().await;
    let said = format!("slot {} was in progress when the PLC restarted", slot + 1);
    let faults = journal
        .read(&Query {
            limit: usize::MAX,
            ..Query::default()
        })
        .unwrap();
    assert!(
        faults
            .iter()
            .any(|e| matches!(&e.kind, Kind::Fault { reason, .. } if reason.contains(&said))),
        "the journal says {said:?}"
    );
}

/// A power cut of the PLC at slot 2 with the part let go: the cycle faults and stays faulted
/// (nothing started, written or counted by itself), the slot becomes unsure (on disk, and the
/// journal says so). The operator homes, goes on (the part is there) and resumes: the cycle,
/// resumed at its dwell at the slot, faults rather than count the next slot, which it never
/// reached; a fresh run then places the pallet to full, every slot once.
#[tokio::test(start_paused = true)]
async fn a_plc_power_cut_mid_place_leaves_the_slot_to_the_operator_and_the_pallet_completes() {
    let Cell {
        shared,
        state,
        daemon: _d,
        h,
        journal,
    } = cell("power-cut", program(), (STATION, PALLET)).await;
    let pattern = h.pallet_patterns().unwrap().remove("out").unwrap();
    let slots = slot_counts(&common::cylindrical(), &pattern);
    let placed = || common::places::places(&shared, 10 * 16, &slots);
    h.run_cycle("palletise", None).await.unwrap();
    until("at slot 2, the gripper open", || {
        let c = counter(&h);
        let at = c
            .in_progress
            .is_some_and(|p| p.slot == 2 && p.phase == Phase::AtSlot);
        (at && !gripper_closed(&shared)).then_some(())
    })
    .await;
    shared.with(linterpd::mock::MockPlc::power_cycle);
    let s = cycle_until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    let why = s.reason.clone().unwrap_or_default();
    assert!(why.contains("PLC restarted"), "{s:?}");
    left_unsure_by_the_restart(&h, &shared, &state, &journal, 2, "").await;
    assert_eq!(placed(), [0, 1, 2], "the part let go at slot 2 is there");
    // The operator homes, goes on and resumes: resumed at the slot's dwell, the cycle holds no
    // part and reached no slot since; it faults rather than count slot 3 as placed.
    h.home().await.unwrap();
    taking_moves(&h).await;
    h.pallet_command("out", PalletCommand::GoOn).unwrap();
    h.clear_fault().await.unwrap();
    h.resume_cycle().await.unwrap();
    let s = cycle_until(&h, "faulted again", |s| s.state == CycleState::Faulted).await;
    let why = s.reason.unwrap_or_default();
    assert!(why.contains("count as placed"), "{why}");
    let c = counter(&h);
    assert_eq!((c.index, c.parts, c.in_progress), (3, 3, None), "{c:?}");
    // A fresh run picks a part and places the rest.
    h.stop_cycle(false).await.unwrap();
    cycle_until(&h, "stopped", |s| s.state == CycleState::Stopped).await;
    h.run_cycle("palletise", None).await.unwrap();
    cycle_until(&h, "full", |s| {
        s.waiting_for
            .as_deref()
            .is_some_and(|w| w.contains("pallet_empty"))
    })
    .await;
    let c = counter(&h);
    assert!(c.full && c.parts == SLOTS as u64, "{c:?}");
    assert_eq!(placed(), (0..SLOTS).collect::<Vec<_>>());
    h.stop_cycle(true).await.unwrap();
}

/// The PLC switched to PROG on the way into slot 2, the part held, then back to RUN (its
/// program starts over with a first scan, CONTRACT.md step 0, and its outputs went off
/// meanwhile): the cycle faults and stays faulted, nothing is started, written or counted by
/// itself, and the slot is the operator's to choose (the gripper let go wherever the robot
/// was), as after a power cut.
#[tokio::test(start_paused = true)]
async fn a_plc_switched_to_prog_on_the_way_into_a_slot_leaves_the_slot_to_the_operator() {
    use linterpd::plc::PlcMode;
    let Cell {
        shared,
        state,
        daemon: _d,
        h,
        journal,
    } = cell("prog", program(), (STATION, PALLET)).await;
    h.run_cycle("palletise", None).await.unwrap();
    until("on the way into slot 2, the part held", || {
        let c = counter(&h);
        let moving = c
            .in_progress
            .is_some_and(|p| p.slot == 2 && p.phase == Phase::Moving);
        (moving && h.state().current_move.is_some() && gripper_closed(&shared)).then_some(())
    })
    .await;
    shared.with(|m| m.set_mode(PlcMode::Prog));
    let s = cycle_until(&h, "faulted", |s| s.state == CycleState::Faulted).await;
    let in_prog = s.reason.clone().unwrap_or_default();
    assert!(in_prog.contains("PROG"), "{s:?}");
    tokio::time::sleep(Duration::from_secs(2)).await;
    shared.with(|m| m.set_mode(PlcMode::Run));
    let s = cycle_until(&h, "faulted for the restart", |s| {
        s.state == CycleState::Faulted
            && s.reason.as_deref().is_some_and(|r| r.contains("restarted"))
    })
    .await;
    let why = format!("{in_prog}; then {:?}", s.reason);
    left_unsure_by_the_restart(&h, &shared, &state, &journal, 2, &why).await;
}
