//! `linterpd demo --cycle`: the shipped press-loading cycle (config/examples/cycles/
//! press-load.toml) run by the daemon's cycle runner on the seed robot, against the mock PLC
//! running the shipped press cell (config/examples/cells/press.toml, `crate::mock::cell`), 10
//! cycles.
//!
//! ```text
//!  the cell (the mock steps it every scan): a stack of blanks, part present (X2) while any is
//!      left, one taken per rise of the gripper (Y1); the press open (X5) and still (X6 off)
//!      until press_go (Y0) rises, then closed and moving for its stroke (0.8 s), closed and
//!      still for its settle (0.2 s), open again; the robot's signals are the cell's
//!  once, in cycle 4, while the robot moves into the press: the demo, as the guard, forces X5
//!      off for 0.3 s -> the PLC holds the move within a scan, the cycle pauses naming X5;
//!      the demo releases X5 (the press model has it back) and, as the operator, resumes
//!  measured: each cycle's time and its time waiting; the moves' motion time; the hold
//! ```

use std::path::Path;
use std::time::{Duration, Instant};

use super::rig::{self, Rig};
use super::{DemoError, DemoOptions, P1};
use crate::config::CellSettings;
use crate::daemon::{
    Connector, CycleState, CycleStatus, Daemon, DaemonOptions, RobotHandle, RobotSetup, Stage,
};
use crate::gateway::{AccessList, GatewaySettings};
use crate::mock::SharedMock;
use crate::mock::cell::{Cell, Description};
use crate::plc::exchange::ContractSettings;
use crate::robot::{Robot, seed_robot};

/// The shipped press-loading program.
pub const PRESS_LOAD: &str = include_str!("../../config/examples/cycles/press-load.toml");
/// The shipped press cell the mock simulates.
pub const PRESS_CELL: &str = include_str!("../../config/examples/cells/press.toml");
/// Cycles the demo runs.
pub const PRESS_CYCLES: u64 = 10;
/// The signal the guard's glitch forces off.
const GUARD: &str = "press_open";
/// How long the guard opens in cycle 4, s.
const GLITCH_S: f64 = 0.3;
/// The step of the move into the press (press-load.toml).
const INTO_PRESS_STEP: usize = 7;
/// The longest the demo may take.
const LIMIT: Duration = Duration::from_secs(300);

/// One cycle as measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CycleTimes {
    /// From its first step to the end of its last, s.
    pub cycle_s: f64,
    /// Time its waits waited, s.
    pub waiting_s: f64,
    /// The planned time of its moves that ended done (the time the PLC runs their tables), s.
    pub motion_s: f64,
}

impl CycleTimes {
    /// What the cycle took beyond its motion and its waits, as a share of them.
    #[must_use]
    pub fn overhead(&self) -> f64 {
        overhead(self.cycle_s, self.motion_s, self.waiting_s)
    }
}

/// The time beyond `motion_s` and `waiting_s` in `cycle_s`, as a share of them.
fn overhead(cycle_s: f64, motion_s: f64, waiting_s: f64) -> f64 {
    (cycle_s - motion_s - waiting_s) / (motion_s + waiting_s)
}

/// The hold the glitch caused.
#[derive(Debug, Clone, PartialEq)]
pub struct Hold {
    /// In which cycle (from 1).
    pub cycle: u64,
    /// What the cycle said.
    pub why: String,
    /// From the guard opening to the cycle paused, s.
    pub seen_after_s: f64,
    /// From the resume to the cycle running again, s.
    pub resumed_after_s: f64,
}

/// The press demo's result.
#[derive(Debug, Clone, PartialEq)]
pub struct PressDemo {
    /// Every cycle.
    pub cycles: Vec<CycleTimes>,
    /// The hold, if it was seen.
    pub hold: Option<Hold>,
    /// Motion time of every move that ended done, s.
    pub motion_s: f64,
    /// Moves that ended done, and moves that did not (the held one).
    pub moves: (usize, usize),
    /// The whole run, s.
    pub total_s: f64,
}

/// Runs the press demo.
///
/// # Panics
/// Never: the demo's ranges are written here and parse.
pub async fn run(options: DemoOptions) -> Result<PressDemo, DemoError> {
    let robot = seed_robot();
    let rig = Rig::start(&robot, P1, options.frequency_model)?;
    let dir = std::env::temp_dir().join(format!("linterpd-demo-cycles-{}", std::process::id()));
    write_programs(&dir)?;
    let cell = press_cell(&rig, &dir)?;
    let settings = ContractSettings {
        verify: options.read_back,
        ..ContractSettings::default()
    };
    let connect = rig.connector(options.baud, options.link);
    let setup = press_robot(&robot, settings, connect, cell)?;
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let result = match daemon.robot(&robot.name) {
        Some(handle) => drive(handle, &rig).await,
        None => Err(DemoError::Rig("the daemon has no robot".into())),
    };
    daemon.shut_down().await;
    rig.stop();
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// Writes the press-loading program into `dir` (made if missing).
pub(super) fn write_programs(dir: &Path) -> Result<(), DemoError> {
    std::fs::create_dir_all(dir)
        .and_then(|()| std::fs::write(dir.join("press-load.toml"), PRESS_LOAD))
        .map_err(|e| DemoError::Rig(format!("{}: {e}", dir.display())))
}

/// Puts the shipped press cell into the rig's mock: the cell as the daemon sees it, its cycle
/// programs read from `dir`.
pub(super) fn press_cell(rig: &Rig, dir: &Path) -> Result<CellSettings, DemoError> {
    let cell = Description::from_toml(PRESS_CELL)
        .map_err(|e| DemoError::Rig(format!("config/examples/cells/press.toml: {e}")))?;
    let signals = cell.signals.clone();
    rig.mock.with(|m| m.set_cell(Cell::new(cell)));
    Ok(CellSettings {
        signals,
        programs: Some(dir.to_path_buf()),
        require_wait_timeout: true,
        face: None,
    })
}

/// The robot as the daemon runs it in the press cell: over `connect`, the gateway open to
/// X0-X1F and Y0-Y7.
///
/// # Panics
/// Never: the ranges are written here and parse.
pub(super) fn press_robot(
    robot: &Robot,
    settings: ContractSettings,
    connect: Connector,
    cell: CellSettings,
) -> Result<RobotSetup, DemoError> {
    let access = AccessList::new(
        vec!["X0-X1F".parse().expect("a range")],
        vec!["Y0-Y7".parse().expect("a range")],
        &crate::contract::Layout::default(),
    )
    .map_err(|e| DemoError::Rig(e.to_string()))?;
    Ok(RobotSetup {
        robot: robot.clone(),
        settings,
        connect,
        home_counts: [0; crate::kinematics::JOINTS],
        gateway: GatewaySettings {
            access,
            modbus: None,
        },
        cell,
    })
}

/// What the demo measures and plays as it watches the cycle: the cycles counted so far, the
/// guard's glitch, the hold it caused and the resume.
struct Watch {
    cycles: Vec<CycleTimes>,
    cycle_began: Instant,
    glitch: Option<Instant>,
    hold: Option<Hold>,
    resumed_at: Option<Instant>,
    counted: std::collections::HashSet<u64>,
}

impl Watch {
    /// Counts a cycle that ended since the last look, with the planned motion of its moves.
    fn count(&mut self, handle: &RobotHandle, s: &CycleStatus) {
        if s.done as usize <= self.cycles.len() {
            return;
        }
        let motion_s = handle
            .reports()
            .iter()
            .filter(|r| r.stage == Stage::Done && self.counted.insert(r.id))
            // Seen running: a move to where the robot stood has no start of its own.
            .filter(|r| r.motion_s.is_some())
            .filter_map(|r| r.predicted.map(|p| p.duration_s))
            .sum();
        self.cycles.push(CycleTimes {
            cycle_s: s
                .last_cycle_s
                .unwrap_or_else(|| self.cycle_began.elapsed().as_secs_f64()),
            waiting_s: s.last_cycle_waiting_s.unwrap_or_default(),
            motion_s,
        });
        self.cycle_began = Instant::now();
    }

    /// Plays the guard and the operator: in cycle 4, while the robot moves into the press, the
    /// guard opens for [`GLITCH_S`]; once the cycle has paused and the guard is back, resume.
    async fn play(
        &mut self,
        handle: &RobotHandle,
        mock: &SharedMock,
        s: &CycleStatus,
    ) -> Result<(), DemoError> {
        let step = s.step.as_ref().map_or(0, |st| st.step);
        let moving = handle.state().current_move.is_some();
        let untouched = self.glitch.is_none() && self.hold.is_none();
        if s.done == 3 && step == INTO_PRESS_STEP && moving && untouched {
            tokio::time::sleep(Duration::from_millis(150)).await;
            mock.with(|m| m.cell_mut().force(GUARD, false))
                .map_err(|e| DemoError::Rig(e.to_string()))?;
            self.glitch = Some(Instant::now());
        }
        if let Some(at) = self.glitch {
            if s.state == CycleState::Paused && self.hold.is_none() {
                self.hold = Some(Hold {
                    cycle: s.done + 1,
                    why: s.reason.clone().unwrap_or_default(),
                    seen_after_s: at.elapsed().as_secs_f64(),
                    resumed_after_s: 0.0,
                });
            }
            let due = at.elapsed().as_secs_f64() >= GLITCH_S;
            if due && self.hold.is_some() && self.resumed_at.is_none() {
                mock.with(|m| m.cell_mut().release(GUARD))
                    .map_err(|e| DemoError::Rig(e.to_string()))?;
                tokio::time::sleep(Duration::from_millis(20)).await;
                handle
                    .resume_cycle()
                    .await
                    .map_err(|e| DemoError::Rig(e.to_string()))?;
                self.resumed_at = Some(Instant::now());
            }
        }
        if let (Some(at), Some(h)) = (self.resumed_at, self.hold.as_mut())
            && h.resumed_after_s == 0.0
            && s.state == CycleState::Running
        {
            h.resumed_after_s = at.elapsed().as_secs_f64();
        }
        Ok(())
    }
}

/// Whether the cycle ran all its count (an error when it ended any other way).
fn finished(s: &CycleStatus) -> Result<bool, DemoError> {
    match s.state {
        CycleState::Done => Ok(true),
        CycleState::Faulted | CycleState::Stopped => Err(DemoError::Rig(format!(
            "the cycle ended {:?}: {}",
            s.state,
            s.reason.clone().unwrap_or_default()
        ))),
        _ => Ok(false),
    }
}

/// Runs the cycles, playing the press and the operator, measuring as it goes.
async fn drive(handle: &RobotHandle, rig: &Rig) -> Result<PressDemo, DemoError> {
    rig::connected(handle).await?;
    tokio::time::sleep(Duration::from_millis(50)).await;
    let began = Instant::now();
    handle
        .run_cycle("press-load", Some(PRESS_CYCLES))
        .await
        .map_err(|e| DemoError::Rig(e.to_string()))?;
    let mut watch = Watch {
        cycles: Vec::new(),
        cycle_began: Instant::now(),
        glitch: None,
        hold: None,
        resumed_at: None,
        counted: std::collections::HashSet::new(),
    };
    loop {
        if began.elapsed() > LIMIT {
            return Err(DemoError::Rig(format!("the cycles took over {LIMIT:?}")));
        }
        tokio::time::sleep(Duration::from_millis(2)).await;
        let Some(s) = handle.cycle() else { continue };
        watch.count(handle, &s);
        watch.play(handle, &rig.mock, &s).await?;
        if finished(&s)? {
            break;
        }
    }
    let reports = handle.reports();
    let done: Vec<_> = reports.iter().filter(|r| r.stage == Stage::Done).collect();
    Ok(PressDemo {
        cycles: watch.cycles,
        hold: watch.hold,
        motion_s: done.iter().filter_map(|r| r.motion_s).sum(),
        moves: (done.len(), reports.len() - done.len()),
        total_s: began.elapsed().as_secs_f64(),
    })
}

/// Cycle `i` (from 0) as a row of the report's table.
fn write_cycle_row(
    i: usize,
    c: &CycleTimes,
    held: Option<u64>,
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    writeln!(
        out,
        "  {:>5}   {:>6.3}   {:>8.3}   {:>9.3}   {:>5.1} %{}",
        i + 1,
        c.cycle_s,
        c.motion_s,
        c.waiting_s,
        100.0 * c.overhead(),
        if held == Some(i as u64 + 1) {
            " (held)"
        } else {
            ""
        }
    )
}

/// The goal's measure: the cycles as the program runs them, without the one paused by the
/// hold (its time paused is neither motion nor a wait) nor the first (its first move comes
/// from the demo's start pose, not from the cycle before).
fn write_steady(
    d: &PressDemo,
    held: Option<u64>,
    out: &mut dyn std::io::Write,
) -> std::io::Result<()> {
    let steady: Vec<&CycleTimes> = d
        .cycles
        .iter()
        .enumerate()
        .filter(|(i, _)| *i > 0 && held != Some(*i as u64 + 1))
        .map(|(_, c)| c)
        .collect();
    if steady.is_empty() {
        return Ok(());
    }
    let sum = |f: fn(&CycleTimes) -> f64| steady.iter().map(|c| f(c)).sum::<f64>();
    let (cycle_s, motion_s, waiting_s) = (
        sum(|c| c.cycle_s),
        sum(|c| c.motion_s),
        sum(|c| c.waiting_s),
    );
    writeln!(
        out,
        "  the {} cycles after the first without the hold: {cycle_s:.3} s, {motion_s:.3} s \
         of motion (planned) and {waiting_s:.3} s waiting: {:.1} % beyond motion and waits",
        steady.len(),
        100.0 * overhead(cycle_s, motion_s, waiting_s)
    )
}

/// The report, in words.
pub fn write_press_report(d: &PressDemo, out: &mut dyn std::io::Write) -> std::io::Result<()> {
    writeln!(
        out,
        "Press-loading cycle (config/examples/cycles/press-load.toml) on the seed robot, mock PLC \
         and a simulated press: {} cycles",
        d.cycles.len()
    )?;
    writeln!(
        out,
        "  cycle   time s   motion s   waiting s   beyond motion and waits"
    )?;
    let held = d.hold.as_ref().map(|h| h.cycle);
    for (i, c) in d.cycles.iter().enumerate() {
        write_cycle_row(i, c, held, out)?;
    }
    let cycles_s: f64 = d.cycles.iter().map(|c| c.cycle_s).sum();
    let waiting_s: f64 = d.cycles.iter().map(|c| c.waiting_s).sum();
    let motion_s: f64 = d.cycles.iter().map(|c| c.motion_s).sum();
    writeln!(
        out,
        "  all: {cycles_s:.3} s in cycles, {waiting_s:.3} s waiting, {motion_s:.3} s of motion \
         (planned; {:.3} s as the daemon saw it) in {} moves done ({} not done); the rest \
         (uploads, chaining, polls, outputs, the hold): {:.3} s",
        d.motion_s,
        d.moves.0,
        d.moves.1,
        cycles_s - waiting_s - motion_s
    )?;
    write_steady(d, held, out)?;
    match &d.hold {
        Some(h) => writeln!(
            out,
            "  hold in cycle {}: {}; seen {:.3} s after the guard opened, running again {:.3} s \
             after the resume",
            h.cycle, h.why, h.seen_after_s, h.resumed_after_s
        ),
        None => writeln!(out, "  the hold was not seen"),
    }
}
