//! The fault matrix's pallet flow (issue 48): a cycle that picks at A (the gripper, R100,
//! closes) and places on a pallet of two slots (its counter marked, the way in, the gripper let
//! go at the slot, a dwell, the slot counted, the way out), twice, until the pallet is full and
//! begun again. Each fault the matrix knows strikes around every distinct step of it, as a
//! fault-free run finds them (where the cycle's step, the counter, the PLC's state or the
//! gripper changes, sampled at each status read): the exchanges since the read before the
//! change, and the one after, and every exchange of the 8 before the robot is seen at a slot
//! (the end of the way in, which a case's run may read an exchange or two apart).
//!
//! The independent record of the places is the mock's (`tests/common/places.rs`): every write
//! of the gripper with the counts the robot stood on as it landed, and every power cut with the
//! relays it turned off and the counts it lost. The gripper opening (by a write, or by a power
//! cut) while it held a part, on a slot's counts, is a part left on that slot.
//!
//! A cycle the fault left faulted stays so once the PLC is well, starting, writing and counting
//! nothing (I8). Then the PLC is cleared and homed where it restarted, and
//!
//! - P1 the counter the API shows and the one in `pallets.json` are the same, and agree with
//!   the record: the slots placed are 0, 1, ... in fill order, none twice; every slot counted was
//!   placed; at most one more was placed, the slot in progress, and only when the counter has it
//!   at the slot or unsure (never when on its way, nor with nothing in progress);
//! - P2 a slot the counter is unsure of (a daemon killed, the PLC restarted mid-place), or one
//!   the robot reached before the fault, refuses the operator's fresh run on its place step,
//!   naming it, with nothing placed, until the operator chooses: go on when the record has the
//!   part on it, redo when not;
//! - P3 the operator's fresh run then ends done with every slot placed exactly once and two
//!   parts counted; the journal has each slot counted by a place once, and after a PLC restart
//!   with a slot in progress, a fault naming that slot.

use super::*;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use linterpd::config::JournalSettings;
use linterpd::daemon::pallets::{PALLETS_FILE, PalletCounters, Pallets};
use linterpd::daemon::{CycleState, PalletCommand};
use linterpd::gateway::Area;
use linterpd::journal::{Journal, Query};
use linterpd::pallet::counter::Phase;
use linterpd::pallet::doc::{FrameDoc, PalletDoc};
use linterpd::pallet::{Counter, RobotPallets};
use linterpd::wire::journal::Kind;

const ROBOT: &str = "press-loader";
const SLOTS: usize = 2;
/// The gripper: R100 (word 10, bit 0), as a bit number.
const GRIPPER: u32 = 10 * 16;

/// Slot 0 of the pallet, in world (no frame), beside A; slot 1 is 40 mm along x.
const SLOT_0: [f64; 3] = [-960.0, 565.0, 30.0];

/// Pick at A (the gripper closes), place on the pallet (the gripper opens at the slot).
pub(super) fn program() -> String {
    format!(
        "[[step]]\nmove = {{ to = [{}, {}, {}] }}\n\
         [[step]]\nset = {{ gripper = true }}\n\
         [[step]]\nplace = {{ pallet = \"out\", speed_mm_s = 200, at_slot = [ \
         {{ set = {{ gripper = false }} }}, {{ dwell = \"100ms\" }} ] }}\n",
        A[0], A[1], A[2]
    )
}

/// One row of two slots, approached from 40 mm above, the last 15 mm at 40 mm/s, the tool at
/// the angle the robot has over slot 0 with its wrist at 0.
fn robot_pallets() -> RobotPallets {
    let a_deg = seed_robot()
        .pose_with_wrist_at_zero(SLOT_0[0], SLOT_0[1], SLOT_0[2])
        .unwrap()
        .a_rad
        .to_degrees();
    let doc = format!(
        "origin_mm = [{}, {}, {}]\na_deg = {a_deg}\nrows = 1\ncolumns = {SLOTS}\n\
         pitch_mm = [40, 40]\nlayer_height_mm = 50\nlayers = 1\n\
         approach = {{ height_mm = 40, slow_mm = 15, slow_speed_mm_s = 40 }}\n",
        SLOT_0[0], SLOT_0[1], SLOT_0[2]
    );
    let pallets: BTreeMap<String, PalletDoc> =
        BTreeMap::from([("out".to_owned(), toml::from_str(&doc).unwrap())]);
    RobotPallets::check(&BTreeMap::<String, FrameDoc>::new(), &pallets).unwrap()
}

/// Each slot's counts per channel.
fn slot_counts() -> Vec<[i64; 4]> {
    static SLOTS_AT: std::sync::OnceLock<Vec<[i64; 4]>> = std::sync::OnceLock::new();
    SLOTS_AT
        .get_or_init(|| {
            let robot = seed_robot();
            let patterns = robot_pallets().patterns(&robot, &BTreeMap::new()).unwrap();
            patterns["out"]
                .slots()
                .iter()
                .map(|s| {
                    let q = linterpd::kinematics::Kinematics::ik(&robot.kinematics, &s.pose, None)
                        .unwrap();
                    let mut by_channel = [0; 4];
                    for (joint, count) in robot.joints.iter().zip(robot.counts_of(&q)) {
                        by_channel[usize::from(joint.channel)] = count;
                    }
                    by_channel
                })
                .collect()
        })
        .clone()
}

/// A fresh state directory for one case.
fn state_dir() -> PathBuf {
    static N: AtomicU64 = AtomicU64::new(0);
    let dir = programs().join(format!("state-{}", N.fetch_add(1, Ordering::SeqCst)));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The daemon's options: the pallet, its counters in `state` (as a start finds them), the
/// journal.
fn options(state: &Path, journal: &Journal) -> DaemonOptions {
    DaemonOptions {
        journal: journal.clone(),
        pallets: Arc::new(Pallets {
            sets: BTreeMap::from([(ROBOT.to_owned(), robot_pallets())]),
            counters: PalletCounters::in_state_dir(state),
        }),
        ..DaemonOptions::default()
    }
}

fn ended(s: CycleState) -> bool {
    matches!(
        s,
        CycleState::Done | CycleState::Stopped | CycleState::Faulted
    )
}

/// The flow: the cycle run for both slots to its end (done, stopped or faulted).
pub(super) async fn run(h: &RobotHandle, v: &mut Violations) {
    if let Err(e) = h.run_cycle("pallet", Some(SLOTS as u64)).await {
        v.0.push(format!("the pallet cycle was refused: {e}"));
        return;
    }
    let done = cycle_until(h, ended).await;
    v.check(done, || {
        format!("I3: the pallet cycle never ended: {:?}", h.cycle())
    });
}

fn counter(h: &RobotHandle) -> Counter {
    h.pallet_counters().get(ROBOT, "out")
}

/// The slots the mock's record has a part left on, in order.
fn places(shared: &SharedMock) -> Vec<usize> {
    common::places::places(shared, GRIPPER, &slot_counts())
}

/// The counter as `pallets.json` has it (the default when never written).
fn on_disk(state: &Path) -> Counter {
    match std::fs::read_to_string(state.join(PALLETS_FILE)) {
        Ok(text) => {
            let file: serde_json::Value = serde_json::from_str(&text).unwrap();
            serde_json::from_value(file["robots"][ROBOT]["out"].clone()).unwrap_or_default()
        }
        Err(_) => Counter::default(),
    }
}

/// P1: the API's counter, the file's and the mock's record agree.
fn agree(h: &RobotHandle, state: &Path, shared: &SharedMock, when: &str, v: &mut Violations) {
    let c = counter(h);
    // A restarted daemon has every slot in progress unsure; the file keeps the phase written.
    let file = on_disk(state).restored();
    v.check(file == c.restored(), || {
        format!("P1 {when}: the API's counter {c:?} is not pallets.json's {file:?}")
    });
    let placed = places(shared);
    let in_order: Vec<usize> = (0..placed.len()).collect();
    v.check(placed == in_order, || {
        format!("P1 {when}: slots placed {placed:?}: one skipped or placed twice")
    });
    let counted = usize::try_from(c.parts).unwrap();
    v.check(placed.len() >= counted, || {
        format!("P1 {when}: {counted} parts counted, {placed:?} placed: a slot counted unplaced")
    });
    let may_be_there = c
        .in_progress
        .is_some_and(|p| p.slot == counted && p.phase != Phase::Moving);
    v.check(
        placed.len() <= counted || (placed.len() == counted + 1 && may_be_there),
        || {
            format!(
                "P1 {when}: {placed:?} placed with the counter at {c:?}: a part on a slot it does \
                 not know may be there"
            )
        },
    );
}

/// I8 for the pallet: a cycle the fault left faulted stays so once the PLC is well, starting
/// nothing, writing nothing (the gripper neither) and counting nothing by itself.
async fn stays_faulted(h: &RobotHandle, shared: &SharedMock, v: &mut Violations) {
    if !h.cycle().is_some_and(|c| c.state == CycleState::Faulted) {
        return;
    }
    // The count, not the phase: a slot may turn unsure (PROG to RUN restarts the PLC).
    let seen = |h: &RobotHandle| {
        let (starts, writes) = shared.with(|m| (m.starts().len(), m.host_writes().len()));
        let c = counter(h).restored();
        (starts, writes, c)
    };
    let before = seen(h);
    heal(shared);
    tokio::time::sleep(Duration::from_secs(2)).await;
    let after = seen(h);
    v.check(after == before, || {
        format!("I8: a faulted pallet cycle went on by itself: {before:?} -> {after:?}")
    });
    v.check(
        h.cycle().is_some_and(|c| c.state == CycleState::Faulted),
        || format!("I8: a faulted pallet cycle left its fault: {:?}", h.cycle()),
    );
}

/// The fault's end: the PLC well, its fault cleared, homed where it restarted, the daemon
/// taking moves.
async fn make_well(h: &RobotHandle, shared: &SharedMock, v: &mut Violations) {
    heal(shared);
    tokio::time::sleep(Duration::from_secs(1)).await;
    if shared.with(|m| m.status().fault) != 0 {
        let clear = tokio::time::timeout(BOUND, h.clear_fault()).await;
        v.check(matches!(clear, Ok(Ok(()))), || {
            format!("clear-fault failed: {clear:?}")
        });
    }
    if !shared.with(|m| m.homed()) {
        let home = tokio::time::timeout(BOUND, h.home()).await;
        v.check(matches!(home, Ok(Ok(()))), || {
            format!("I4: home failed: {home:?}")
        });
    }
    if let Err(e) = until_ready(h).await {
        v.0.push(format!("I4: {e}"));
    }
}

/// The operator: the cycle left stopped, the unsure slot chosen for by what the record shows
/// (P2: the cycle refuses until then), and a fresh run for the slots left (P3).
async fn finish(h: &RobotHandle, shared: &SharedMock, v: &mut Violations) {
    if h.cycle()
        .is_some_and(|c| !matches!(c.state, CycleState::Done | CycleState::Stopped))
    {
        let _ = tokio::time::timeout(BOUND, h.stop_cycle(false)).await;
        cycle_until(h, ended).await;
    }
    let c = counter(h);
    let placed = places(shared).len();
    // A slot the robot reached (the part perhaps let go) or unsure: the run asks first.
    let asks = c.in_progress.filter(|p| p.phase != Phase::Moving);
    let choice = asks.map(|p| p.slot).map(|slot| {
        let there = placed > usize::try_from(c.parts).unwrap();
        (
            slot,
            if there {
                PalletCommand::GoOn
            } else {
                PalletCommand::Redo
            },
        )
    });
    let counted = c.parts + u64::from(matches!(choice, Some((_, PalletCommand::GoOn))));
    let left = if c.pallets > 0 {
        0
    } else {
        SLOTS as u64 - counted
    };
    let choose = |command| {
        let r = h.pallet_command("out", command);
        format!("{r:?}")
    };
    if left == 0 {
        if let Some((_, command)) = choice {
            let r = choose(command);
            v.check(r.starts_with("Ok"), || {
                format!("P2: {command:?} refused: {r}")
            });
        }
        return;
    }
    if let Err(e) = h.run_cycle("pallet", Some(left)).await {
        v.0.push(format!("P3: the operator's run was refused: {e}"));
        return;
    }
    if let Some((slot, command)) = choice {
        cycle_until(h, ended).await;
        let s = h.cycle().unwrap();
        let why = s.reason.clone().unwrap_or_default();
        v.check(
            s.state == CycleState::Faulted
                && why.contains(&format!("slot {slot}"))
                && why.contains("choose redo"),
            || {
                format!(
                    "P2: slot {slot} unsure, yet the cycle ended {:?}: {why}",
                    s.state
                )
            },
        );
        v.check(places(shared).len() == placed, || {
            "P2: a part placed before the operator chose".into()
        });
        let r = choose(command);
        v.check(r.starts_with("Ok"), || {
            format!("P2: {command:?} refused: {r}")
        });
        let _ = tokio::time::timeout(BOUND, h.clear_fault()).await;
        let resumed = tokio::time::timeout(BOUND, h.resume_cycle()).await;
        v.check(matches!(resumed, Ok(Ok(_))), || {
            format!("P2: the resume after {command:?} failed: {resumed:?}")
        });
    }
    let done = cycle_until(h, ended).await;
    let s = h.cycle();
    v.check(
        done && s.as_ref().is_some_and(|s| s.state == CycleState::Done),
        || format!("P3: the operator's run ended {s:?}"),
    );
}

/// P3 at the end: every slot placed once, both counted; the journal's places and restarts.
async fn check_end(
    h: &RobotHandle,
    shared: &SharedMock,
    journal: &Journal,
    unsure_by_restart: Option<usize>,
    v: &mut Violations,
) {
    let placed = places(shared);
    v.check(placed == [0, 1], || {
        format!("P3: the pallet ended with slots {placed:?} placed")
    });
    let c = counter(h);
    v.check(c.parts == SLOTS as u64, || {
        format!("P3: the pallet ended with {c:?}")
    });
    journal.flush().await;
    let entries = journal
        .read(&Query {
            limit: usize::MAX,
            ..Query::default()
        })
        .unwrap();
    let journaled: Vec<u32> = entries
        .iter()
        .filter_map(|e| match &e.kind {
            Kind::PalletPlaced { slot, .. } => Some(*slot),
            _ => None,
        })
        .collect();
    let mut once = journaled.clone();
    once.dedup();
    v.check(
        once == journaled && journaled.iter().all(|s| *s as usize <= SLOTS),
        || format!("P3: the journal's places {journaled:?}"),
    );
    if let Some(slot) = unsure_by_restart {
        let said = entries.iter().any(|e| {
            matches!(&e.kind, Kind::Fault { reason, .. }
                if reason.contains("PLC restarted") && reason.contains(&format!("slot {}", slot + 1)))
        });
        v.check(said, || {
            format!("P3: the journal does not say the PLC restart made slot {slot} unsure")
        });
    }
}

/// The daemon killed (its link frozen after request `k`), as a SIGKILL leaves it: its cycle
/// ends where it stood; a new daemon starts on the same mock and state directory.
async fn kill_and_restart(
    daemon: linterpd::daemon::Daemon,
    h: RobotHandle,
    switch: &Switch,
    (shared, state, journal): (&SharedMock, &Path, &Journal),
    v: &mut Violations,
) -> (linterpd::daemon::Daemon, RobotHandle) {
    let flow_task = {
        let h = h.clone();
        tokio::spawn(async move { run(&h, &mut Violations::default()).await })
    };
    for _ in 0..3_000 {
        if switch.killed.load(Ordering::SeqCst) || flow_task.is_finished() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    tokio::time::sleep(Duration::from_millis(3)).await;
    daemon.kill().await;
    flow_task.abort();
    // The killed daemon's cycle does nothing more (its worker is gone): it is ended before
    // the new daemon reads the state directory.
    let _ = tokio::time::timeout(BOUND, h.stop_cycle(true)).await;
    cycle_until(&h, ended).await;
    let (d, h2) = spawn_with(
        duplex_connector(shared, None),
        Flow::Pallet,
        &options(state, journal),
    );
    if let Err(e) = until_ready(&h2).await {
        v.0.push(format!("after the restart: {e}"));
    }
    v.check(h2.cycle().is_none(), || {
        format!("I8: a restarted daemon has a cycle: {:?}", h2.cycle())
    });
    (d, h2)
}

/// One case: `fault` at exchange `k` of the pallet flow.
pub(super) async fn case(fault: Fault, k: u64) -> Violations {
    let mut v = Violations::default();
    let (shared, driver) = mock_at_a(true);
    let state = state_dir();
    let journal = Journal::open(&state.join("journal"), &JournalSettings::default()).unwrap();
    let switch = Switch::new();
    let connect = if fault == Fault::DaemonRestart {
        killing_connector(&shared, &switch, None)
    } else {
        duplex_connector(&shared, None)
    };
    let (daemon, h) = spawn_with(connect, Flow::Pallet, &options(&state, &journal));
    if let Err(e) = until_ready(&h).await {
        v.0.push(e);
        daemon.shut_down().await;
        driver.abort();
        return v;
    }
    let script = fault.script(shared.with(|m| m.commands()) + k);
    shared.with(|m| m.set_faults(script.parse().unwrap()));
    switch.arm(k);
    let (daemon, h) = if fault == Fault::DaemonRestart {
        let rig = (&shared, state.as_path(), &journal);
        kill_and_restart(daemon, h, &switch, rig, &mut v).await
    } else {
        run(&h, &mut v).await;
        (daemon, h)
    };
    check_starts(&shared, &mut v);
    stays_faulted(&h, &shared, &mut v).await;
    make_well(&h, &shared, &mut v).await;
    agree(&h, &state, &shared, "after the fault", &mut v);
    let c = counter(&h);
    if std::env::var_os("MATRIX_TRACE").is_some() {
        let gripper = common::places::releases(&shared, GRIPPER, &slot_counts());
        eprintln!(
            "pallet {fault:?} @{k}: after the fault {c:?}, the gripper let go at {gripper:?}"
        );
    }
    let restarted = !shared.with(|m| m.power_cuts().is_empty());
    let unsure_by_restart = c.needs_choice().filter(|_| restarted);
    finish(&h, &shared, &mut v).await;
    agree(&h, &state, &shared, "at the end", &mut v);
    check_end(&h, &shared, &journal, unsure_by_restart, &mut v).await;
    check_starts(&shared, &mut v);
    daemon.shut_down().await;
    driver.abort();
    let _ = std::fs::remove_dir_all(&state);
    v
}

/// What a fault-free run changes between exchanges: the cycle's step, the counter, the PLC's
/// state and busy channels, the gripper.
type Signature = (Option<String>, Counter, u16, u16, bool);

fn signature(h: &RobotHandle, shared: &SharedMock) -> Signature {
    let step = h.cycle().and_then(|c| c.step).map(|s| s.does);
    let (state, busy, gripper) = shared.with(|m| {
        let s = m.status();
        (s.state, s.busy, m.read_bit(Area::R, GRIPPER).unwrap())
    });
    (step, counter(h), state, busy, gripper)
}

/// The exchanges (counted from the flow's first, from 1) at which the matrix strikes: around
/// each distinct step of the fault-free run, the exchanges since the last status read before it
/// was seen, and the one after; round each arrival at a slot, the 8 exchanges before it too.
pub(super) async fn positions() -> Vec<u64> {
    let (shared, driver) = mock_at_a(true);
    let state = state_dir();
    let journal = Journal::off();
    let (daemon, h) = spawn_with(
        duplex_connector(&shared, None),
        Flow::Pallet,
        &options(&state, &journal),
    );
    until_ready(&h).await.unwrap();
    let before = shared.with(|m| m.commands());
    // Sampled at each snapshot the worker publishes (each status read), so that the sampler
    // adds no timer of its own: the run keeps the exchange numbering of the cases.
    let sampler = {
        let (h, shared) = (h.clone(), shared.clone());
        let mut snapshots = h.watch_snapshot();
        tokio::spawn(async move {
            let mut last = None;
            let mut at = Vec::new();
            let mut seen_at = 0;
            loop {
                let now = signature(&h, &shared);
                let k = shared.with(|m| m.commands()) - before;
                if last.as_ref() != Some(&now) {
                    if std::env::var_os("MATRIX_TRACE").is_some() {
                        eprintln!("pallet flow @{k}: {now:?}");
                    }
                    // The exchanges from the first after the last sample to the one after this;
                    // round the arrival at a slot, every exchange from 8 before (a case's run
                    // may read the way in's end an exchange or two apart from this one's).
                    let arrived = now.1.in_progress.is_some_and(|p| p.phase == Phase::AtSlot)
                        && !last
                            .as_ref()
                            .is_some_and(|l: &Signature| l.1.in_progress == now.1.in_progress);
                    let from = if arrived {
                        k.saturating_sub(8)
                    } else {
                        seen_at + 1
                    };
                    at.extend(from..=k + 1);
                    last = Some(now);
                }
                seen_at = k;
                if h.cycle().is_some_and(|c| ended(c.state)) {
                    return at;
                }
                let changed =
                    tokio::time::timeout(Duration::from_millis(50), snapshots.changed()).await;
                if matches!(changed, Ok(Err(_))) {
                    return at;
                }
            }
        })
    };
    let mut v = Violations::default();
    run(&h, &mut v).await;
    let at = sampler.await.unwrap();
    let n = shared.with(|m| m.commands()) - before;
    assert!(v.0.is_empty(), "the pallet flow without a fault: {:?}", v.0);
    let c = h.cycle().unwrap();
    assert_eq!(c.state, CycleState::Done, "{c:?}");
    assert_eq!(
        places(&shared),
        [0, 1],
        "the fault-free run places each slot once"
    );
    let c = counter(&h);
    assert_eq!((c.parts, c.pallets, c.index), (2, 1, 0), "{c:?}");
    daemon.shut_down().await;
    driver.abort();
    let _ = std::fs::remove_dir_all(&state);
    let mut at: Vec<u64> = at.into_iter().filter(|k| (1..=n).contains(k)).collect();
    at.sort_unstable();
    at.dedup();
    at
}
