//! `linterpd demo --pallet`: a pallet of 4 interlocked layers of 6 cases (24 slots) built to
//! full by the daemon's cycle runner on the seed robot against the mock PLC: pick beside the
//! pallet, place on the counter's slot (approach from above, the last millimetres slow, the
//! gripper opened at the slot), a slip sheet before every layer but the first, and at full the
//! pallet's signal set while the cycle waits for an empty pallet.
//!
//! ```text
//!  the pallet: 2 rows x 3 columns, 180 x 130 mm pitch, 90 mm layers; layers 2 and 4 turned
//!      half a turn and moved half a column pitch; counters in memory
//!  the cycle: move to the pick point, gripper (R100) closed, place on "out" (gripper open,
//!      100 ms); between layers "slip-sheet" (Y2 on, 200 ms, off); full: Y1 set, wait for X3
//!  measured: from the run to the pallet full (the cycle waiting for X3), s; the mock's record
//!      of its starts (counts and inputs): every slot placed once, on the slot's counts
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::rig::{self, Rig};
use super::{DemoError, DemoOptions, P1};
use crate::config::CellSettings;
use crate::daemon::pallets::{PalletCounters, Pallets};
use crate::daemon::{CycleState, Daemon, DaemonOptions, RobotHandle, RobotSetup};
use crate::gateway::{AccessList, Area, GatewaySettings};
use crate::kinematics::Kinematics;
use crate::mock::StartRecord;
use crate::pallet::doc::{FrameDoc, PalletDoc};
use crate::pallet::{Counter, Pattern, RobotPallets};
use crate::plc::exchange::ContractSettings;
use crate::robot::{Robot, seed_robot};

/// The pallet, as a robot's `[robots.NAME.pallets.out]` table.
pub const PALLET: &str = r#"
frame = "station"
a_deg = 140
rows = 2
columns = 3
pitch_mm = [180, 130]
layer_height_mm = 90
layers = ["A", "B", "A", "B"]
kinds.A = {}
kinds.B = { turn_deg = 180, shift_mm = [90, 0] }
order = "snake-rows"
approach = { height_mm = 80, slow_mm = 20, slow_speed_mm_s = 60 }
between_layers = "slip-sheet"
when_full = { signal = "pallet_full", wait_for = "pallet_empty" }
"#;
/// The pallet station's frame (level, world mm).
const STATION: &str = "station = { origin = [-700, 650, 0] }";
/// Where the cases are picked, mm: beside the pallet.
const PICK: [f64; 3] = [-900.0, 450.0, 120.0];
/// The slip sheet: a signal pulsed (a sheet dispenser in a real cell).
const SLIP_SHEET: &str = "[[step]]\nset = { sheet = true }\n[[step]]\ndwell = \"200ms\"\n\
                          [[step]]\nset = { sheet = false }\n";
/// The longest the demo may take.
const LIMIT: Duration = Duration::from_secs(900);

/// What the pallet demo did.
#[derive(Debug, Clone)]
pub struct PalletDemo {
    /// The pallet as laid out.
    pub pattern: Pattern,
    /// Its counter when the cycle was stopped.
    pub counter: Counter,
    /// From the run to the pallet full, s.
    pub took_s: f64,
    /// Slip sheets laid (the sheet signal's rises, from the mock's record of writes).
    pub sheets: usize,
    /// The places the mock saw, in order: for each start that began with the gripper open on a
    /// slot's counts (within a pulse), that slot.
    pub places: Vec<usize>,
    /// The layers drawn, the slots placed filled.
    pub svg: String,
}

/// The pick and place program.
fn program() -> String {
    format!(
        "[[step]]\nmove = {{ to = [{}, {}, {}] }}\n[[step]]\nset = {{ gripper = true }}\n\
         [[step]]\nplace = {{ pallet = \"out\", at_slot = [ {{ set = {{ gripper = false }} }}, \
         {{ dwell = \"100ms\" }} ] }}\n",
        PICK[0], PICK[1], PICK[2]
    )
}

/// The seed robot's frames and pallets: the station and the pallet on it.
///
/// # Errors
/// Never for the tables written here; a refusal is named.
pub fn robot_pallets() -> Result<RobotPallets, DemoError> {
    let bad = |e: String| DemoError::Rig(format!("the demo's pallet: {e}"));
    let frames: BTreeMap<String, FrameDoc> =
        toml::from_str(STATION).map_err(|e| bad(e.to_string()))?;
    let pallet: PalletDoc = toml::from_str(PALLET).map_err(|e| bad(e.to_string()))?;
    let pallets = BTreeMap::from([("out".to_owned(), pallet)]);
    RobotPallets::check(&frames, &pallets).map_err(|e| bad(e.to_string()))
}

/// Runs the pallet demo.
pub async fn run(options: DemoOptions) -> Result<PalletDemo, DemoError> {
    let mut robot = seed_robot();
    // The turned layers turn the wrist half a turn: slowed down for, not refused.
    robot.motion.over_speed = crate::robot::OverSpeed::SlowDown;
    let rig = Rig::start(&robot, P1, options.frequency_model)?;
    // Hundreds of moves: their pulses are not kept.
    rig.mock.with(|m| m.record_pulses(false));
    let dir = std::env::temp_dir().join(format!("linterpd-demo-pallet-{}", std::process::id()));
    write_programs(&dir)?;
    let setup = RobotSetup {
        robot: robot.clone(),
        settings: ContractSettings {
            verify: options.read_back,
            ..ContractSettings::default()
        },
        connect: rig.connector(options.baud, options.link),
        home_counts: [0; crate::kinematics::JOINTS],
        gateway: gateway()?,
        cell: cell(&dir),
    };
    let daemon_options = DaemonOptions {
        pallets: Arc::new(Pallets {
            sets: BTreeMap::from([(robot.name.clone(), robot_pallets()?)]),
            counters: PalletCounters::in_memory(),
        }),
        ..DaemonOptions::default()
    };
    let daemon = Daemon::spawn(vec![setup], &daemon_options);
    let result = match daemon.robot(&robot.name) {
        Some(handle) => drive(handle, &rig).await,
        None => Err(DemoError::Rig("the daemon has no robot".into())),
    };
    daemon.shut_down().await;
    rig.stop();
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// Writes the demo's cycle programs into `dir` (made if missing).
fn write_programs(dir: &std::path::Path) -> Result<(), DemoError> {
    let programs = [
        ("palletise", program()),
        ("slip-sheet", SLIP_SHEET.to_owned()),
    ];
    for (name, text) in &programs {
        std::fs::create_dir_all(dir)
            .and_then(|()| std::fs::write(dir.join(format!("{name}.toml")), text))
            .map_err(|e| DemoError::Rig(format!("{}: {e}", dir.display())))?;
    }
    Ok(())
}

/// The cell: the gripper in the status block's input words (R100), the pallet's signals.
fn cell(dir: &std::path::Path) -> CellSettings {
    let signals = [
        ("gripper", "R100"),
        ("pallet_full", "Y1"),
        ("sheet", "Y2"),
        ("pallet_empty", "X3"),
    ];
    CellSettings {
        signals: signals
            .iter()
            .map(|(n, a)| ((*n).to_owned(), a.parse().expect("an address")))
            .collect(),
        programs: Some(dir.to_path_buf()),
        require_wait_timeout: false,
        face: None,
    }
}

/// The gateway: X read, Y and R100-R10F written.
fn gateway() -> Result<GatewaySettings, DemoError> {
    let access = AccessList::new(
        vec!["X0-X1F".parse().expect("a range")],
        vec![
            "Y0-Y7".parse().expect("a range"),
            "R100-R10F".parse().expect("a range"),
        ],
        &crate::contract::Layout::default(),
    )
    .map_err(|e| DemoError::Rig(e.to_string()))?;
    Ok(GatewaySettings {
        access,
        modbus: None,
    })
}

/// Runs the cycle until the pallet is full, stops it, and reads what the mock saw.
async fn drive(handle: &RobotHandle, rig: &Rig) -> Result<PalletDemo, DemoError> {
    rig::connected(handle).await?;
    let pattern = handle
        .pallet_patterns()
        .map_err(|e| DemoError::Rig(e.to_string()))?
        .remove("out")
        .ok_or_else(|| DemoError::Rig("the robot has no pallet \"out\"".into()))?;
    let began = Instant::now();
    handle
        .run_cycle("palletise", None)
        .await
        .map_err(|e| DemoError::Rig(e.to_string()))?;
    let counter = until_full(handle, began).await?;
    let took_s = began.elapsed().as_secs_f64();
    let _ = handle.stop_cycle(true).await;
    let (starts, sheets) = rig.mock.with(|m| {
        let sheets = m
            .host_writes()
            .iter()
            .filter(|w| w.area == Area::Y && w.start == 2 && w.values == [1])
            .count();
        (m.starts().to_vec(), sheets)
    });
    let places = places(&starts, &slot_counts(handle.robot(), &pattern)?);
    let svg = crate::plot::layers_svg(&pattern, counter.index);
    Ok(PalletDemo {
        pattern,
        counter,
        took_s,
        sheets,
        places,
        svg,
    })
}

/// Waits until the pallet is full and the cycle waits for an empty one: the counter.
async fn until_full(handle: &RobotHandle, began: Instant) -> Result<Counter, DemoError> {
    let robot = handle.robot().name.clone();
    loop {
        let counter = handle.pallet_counters().get(&robot, "out");
        let status = handle.cycle();
        let waiting = status
            .as_ref()
            .is_some_and(|s| s.state == CycleState::Waiting);
        if counter.full && waiting {
            return Ok(counter);
        }
        if let Some(s) =
            status.filter(|s| matches!(s.state, CycleState::Faulted) || s.state.is_final())
        {
            return Err(DemoError::Rig(format!(
                "the cycle {:?}: {}",
                s.state,
                s.reason.unwrap_or_default()
            )));
        }
        if began.elapsed() > LIMIT {
            return Err(DemoError::Rig(format!(
                "the pallet not full after {} s: {counter:?}",
                LIMIT.as_secs()
            )));
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Each slot's counts per channel: the robot's inverse kinematics of its pose.
fn slot_counts(robot: &Robot, pattern: &Pattern) -> Result<Vec<[i64; 4]>, DemoError> {
    pattern
        .slots()
        .iter()
        .map(|s| {
            let q = robot
                .kinematics
                .ik(&s.pose, None)
                .map_err(|e| DemoError::Rig(format!("slot {}: {e}", s.index)))?;
            let by_joint = robot.counts_of(&q);
            let mut by_channel = [0; 4];
            for (j, joint) in robot.joints.iter().enumerate() {
                by_channel[usize::from(joint.channel)] = by_joint[j];
            }
            Ok(by_channel)
        })
        .collect()
}

/// The places in the mock's record of `starts`: for each start that began with the gripper
/// (R100, bit 0 of the third input word) open on one of `slots`' counts (within a pulse), that
/// slot.
#[must_use]
pub fn places(starts: &[StartRecord], slots: &[[i64; 4]]) -> Vec<usize> {
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

/// Writes the pallet demo's report; `svg`: where the picture went.
///
/// # Errors
/// Writing to `out`.
pub fn write_pallet_report(
    d: &PalletDemo,
    svg: Option<&std::path::Path>,
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    let len = d.pattern.len();
    let layers = d.pattern.layers();
    writeln!(
        out,
        "Palletising on the seed robot and the mock PLC: pallet \"out\", {layers} layers of {} \
         ({len} slots), interlocked (every other layer turned half a turn and moved half a pitch)",
        len / layers.max(1)
    )?;
    writeln!(
        out,
        "  {} parts placed in {:.1} s ({:.2} s a part), {} slip sheets; full: pallet_full set, the \
         cycle waiting for pallet_empty",
        d.counter.parts,
        d.took_s,
        d.took_s / (d.counter.parts.max(1) as f64),
        d.sheets
    )?;
    let once = d.places == (0..len).collect::<Vec<_>>();
    writeln!(
        out,
        "  the mock's record: {} places; {}",
        d.places.len(),
        if once {
            "every slot once, in fill order, the robot on the slot's counts (within a pulse)"
        } else {
            "NOT every slot once in fill order"
        }
    )?;
    if let Some(path) = svg {
        writeln!(out, "Picture: {}", path.display())?;
    }
    Ok(())
}
