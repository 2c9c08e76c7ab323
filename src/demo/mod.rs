//! `linterpd demo`: the seed's move and a few others, run by the daemon's own move path against a
//! mock FP-X in process, with no hardware and no config file.
//!
//! ```text
//!  seed_robot() --Daemon::spawn--> worker --MEWTOCOL-COM, emulated 115200-baud line (duplex)-->
//!      MewtocolServer --> MockPlc (channels preset to P1's counts, pulse trace on)
//!  each batch of moves: submit, wait until every one ends, take the trace
//!  each move: re-plan it from the counts the daemon planned it from (the same plan), cut its
//!      pulses out of the trace, replay them through forward kinematics (replay.rs): measured
//!      figures beside the planner's predicted ones
//! ```
//! The moves ([`steps`]): the seed's move P1 -> P2 at the robot's defaults (240 mm/s, Ta 200 ms,
//! dT 50 ms), back to P1 bounded-error 0.05 mm, to P2 at 120 mm/s, then two moves queued at once
//! that the PLC chains (back to P1 with dT 20 ms, out to P2 and back bounded-error 0.05 mm, out
//! to P2 again at dT 50 ms: a bounded-error and a constant-period upload behind a bounded-error
//! move, each measured on the trace for idle time). All run on the
//! line P1P2, so one picture shows them all (the seed's Figs. 6 and 7: the path, and the
//! deviation along it). Last, planned only ([`drives`]): a line near a short arm's axis under
//! whole-move slow-down beside its time-optimal timing under drive limits.

pub mod console;
mod cycle;
pub mod drives;
pub mod pallet;
pub mod press;
mod replay;
mod rig;
mod text;

use std::time::Duration;

use thiserror::Error;

pub use cycle::{CYCLE_BLEND_MM, CYCLE_TOLERANCE_MM, Cycle};
pub use replay::{Played, cut, replay};
pub use rig::DemoLink;
pub use text::{picture, write_report};

use crate::daemon::{
    Daemon, DaemonOptions, MoveOrder, MoveReport, RobotHandle, RobotSetup, Stage, SubmitError,
};
use crate::kinematics::JOINTS;
use crate::mock::{StartOutcome, StartRecord};
use crate::order::OrderMotion;
use crate::plan::Plan;
use crate::plc::exchange::ContractSettings;
use crate::robot::{Robot, seed_robot};
use crate::table::FrequencyModel;
use rig::Rig;

/// The seed's P1, mm.
pub const P1: [f64; 3] = [-926.57, 535.03, 50.0];
/// The seed's P2, mm.
pub const P2: [f64; 3] = [-1144.43, 659.60, 186.60];
/// The emulated serial line's speed unless told otherwise, baud.
pub const DEFAULT_BAUD: u32 = 115_200;
/// The longest a batch of moves may take to end.
const BATCH_LIMIT: Duration = Duration::from_secs(30);

/// How the demo runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DemoOptions {
    /// The emulated serial line's speed (`None`: as fast as the in-process pipe).
    pub baud: Option<u32>,
    /// What the channels really output: the planner plans for it and the mock plays it.
    pub frequency_model: FrequencyModel,
    /// Whether to draw the SVG.
    pub svg: bool,
    /// The protocol: MEWTOCOL-COM in `%` frames by default; in `<` frames as a shipped
    /// config's `header = "auto"` ends up with when the PLC takes them; or Modbus RTU.
    pub link: DemoLink,
    /// Read every upload back before its start (a shipped config's `read_back`, on by default).
    pub read_back: bool,
}

impl Default for DemoOptions {
    fn default() -> Self {
        Self {
            baud: Some(DEFAULT_BAUD),
            frequency_model: seed_robot().motion.frequency_model,
            svg: true,
            link: DemoLink::Mewtocol { long_frames: false },
            read_back: true,
        }
    }
}

/// Why the demo did not complete.
#[derive(Debug, Error)]
pub enum DemoError {
    /// The mock PLC or the link to it could not be set up.
    #[error("demo rig: {0}")]
    Rig(String),
    /// The daemon refused a move.
    #[error("move {name:?} refused: {source}")]
    Refused {
        /// The move.
        name: &'static str,
        /// Why.
        #[source]
        source: SubmitError,
    },
    /// A move did not end done.
    #[error("move {name:?} ended {stage:?}: {why}")]
    NotDone {
        /// The move.
        name: &'static str,
        /// Where it ended.
        stage: Stage,
        /// What the daemon said.
        why: String,
    },
    /// The pulse trace does not match the plans (a bug in the daemon, the mock or the demo).
    #[error("pulse trace: {0}")]
    Trace(String),
    /// The SVG could not be drawn.
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
}

/// One move of the demo: a name and the order the daemon gets.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// What the report calls it.
    pub name: &'static str,
    /// The order.
    pub order: MoveOrder,
}

fn to(p: [f64; 3]) -> MoveOrder {
    MoveOrder {
        to: Some(p.to_vec()),
        ..MoveOrder::default()
    }
}

/// A bounded-error line to `p` (0.05 mm).
fn bounded(p: [f64; 3]) -> MoveOrder {
    MoveOrder {
        motion: OrderMotion {
            tolerance_mm: Some(0.05),
            ..OrderMotion::default()
        },
        ..to(p)
    }
}

/// The demo's moves, in batches: the moves of a batch are queued at once (the PLC chains them).
#[must_use]
pub fn steps() -> Vec<Vec<Step>> {
    let step = |name, order| Step { name, order };
    vec![
        vec![step("the seed's move, P1 -> P2", to(P2))],
        vec![step("back to P1, bounded", bounded(P1))],
        vec![step(
            "P1 -> P2 at 120 mm/s",
            MoveOrder {
                motion: OrderMotion {
                    speed_mm_s: Some(120.0),
                    ..OrderMotion::default()
                },
                ..to(P2)
            },
        )],
        vec![
            step(
                "P2 -> P1, dT 20 ms, queued",
                MoveOrder {
                    motion: OrderMotion {
                        period: Some("20ms".into()),
                        ..OrderMotion::default()
                    },
                    ..to(P1)
                },
            ),
            step("P1 -> P2, bounded, chained", bounded(P2)),
            step("P2 -> P1, bounded, chained behind bounded", bounded(P1)),
            step("P1 -> P2, dT 50 ms, chained behind bounded", to(P2)),
        ],
    ]
}

/// How a chained move followed the one before it, on the mock's clock, from that move's last
/// pulse.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChainWait {
    /// Until the PLC program first saw its start command, s: negative when the start was
    /// waiting in the PLC before that move ended (no idle time); positive, the PLC idled
    /// that long for its upload.
    pub seen_after_s: f64,
    /// Until the PLC started it, s.
    pub started_after_s: f64,
}

/// One move as run.
#[derive(Debug, Clone)]
pub struct DemoMove {
    /// Its name.
    pub name: &'static str,
    /// Queued while the move before it ran, its start written to wait behind that move
    /// (whether it was written in time: [`Self::chain`]).
    pub chained: bool,
    /// For a chained move: how it followed the move before it, on the trace.
    pub chain: Option<ChainWait>,
    /// The daemon's report.
    pub report: MoveReport,
    /// Its plan (the daemon's, re-planned from the same counts).
    pub plan: Plan,
    /// What the mock PLC did with it.
    pub played: Played,
}

impl DemoMove {
    /// Final counts minus target counts per channel: the daemon's, or the pulse trace's for a
    /// move that chained into the next (whose final counts the daemon does not read); `true`
    /// when from the trace.
    #[must_use]
    pub fn final_error_pulses(&self, robot: &Robot) -> ([i64; 4], bool) {
        if let Some(e) = self.report.final_error_pulses {
            return (e, false);
        }
        let target = self.report.target_counts.unwrap_or_default();
        let mut e = [0; 4];
        for (j, joint) in robot.joints.iter().enumerate() {
            let c = usize::from(joint.channel);
            e[c] = self.played.end_counts[j] - target[c];
        }
        (e, true)
    }
}

/// What the demo did.
#[derive(Debug, Clone)]
pub struct Demo {
    /// The robot (the seed's, with the frequency model asked for).
    pub robot: Robot,
    /// The options it ran with.
    pub options: DemoOptions,
    /// The mock's scan time, s.
    pub scan_s: f64,
    /// Every move, in order.
    pub moves: Vec<DemoMove>,
    /// The pick-and-place cycle, blended and stopped.
    pub cycles: Vec<Cycle>,
    /// A line near a short arm's axis planned with and without drive limits.
    pub drives: drives::DriveComparison,
    /// The picture, when asked for.
    pub svg: Option<String>,
}

/// Runs the demo: starts the mock and the daemon, runs every step, measures every move.
pub async fn run(options: DemoOptions) -> Result<Demo, DemoError> {
    let mut robot = seed_robot();
    robot.motion.frequency_model = options.frequency_model;
    let rig = Rig::start(&robot, P1, options.frequency_model)?;
    let scan_s = rig.mock.scan_s();
    let setup = RobotSetup {
        robot: robot.clone(),
        settings: ContractSettings {
            verify: options.read_back,
            ..ContractSettings::default()
        },
        connect: rig.connector(options.baud, options.link),
        home_counts: [0; crate::kinematics::JOINTS],
        gateway: crate::gateway::GatewaySettings::default(),
        cell: crate::config::CellSettings::default(),
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let driven = match daemon.robot(&robot.name) {
        Some(handle) => drive(handle, &rig, scan_s).await,
        None => Err(DemoError::Rig("the daemon has no robot".into())),
    };
    daemon.shut_down().await;
    rig.stop();
    let (moves, cycles) = driven?;
    let drives =
        drives::compare().map_err(|e| DemoError::Rig(format!("the drive comparison: {e}")))?;
    let svg = options.svg.then(|| picture(&robot, &moves)).transpose()?;
    Ok(Demo {
        robot,
        options,
        scan_s,
        moves,
        cycles,
        drives,
        svg,
    })
}

/// Runs every batch in turn, then the cycles.
async fn drive(
    handle: &RobotHandle,
    rig: &Rig,
    scan_s: f64,
) -> Result<(Vec<DemoMove>, Vec<Cycle>), DemoError> {
    rig::connected(handle).await?;
    let mut moves = Vec::new();
    for batch in steps() {
        moves.extend(run_batch(handle, rig, &batch, scan_s).await?);
    }
    let cycles = cycle::run_cycles(handle, rig, scan_s).await?;
    Ok((moves, cycles))
}

/// Queues a batch, waits for every move of it, and measures each from the trace.
async fn run_batch(
    handle: &RobotHandle,
    rig: &Rig,
    batch: &[Step],
    scan_s: f64,
) -> Result<Vec<DemoMove>, DemoError> {
    let ids = submit(handle, batch).await?;
    let reports = wait_done(handle, batch, ids).await?;
    let plans = batch
        .iter()
        .zip(&reports)
        .map(|(step, report)| replan(handle.robot(), step, report))
        .collect::<Result<Vec<_>, _>>()?;
    let trace = rig.mock.with(crate::mock::MockPlc::take_pulses);
    let runs = cut(&trace, &plans.iter().collect::<Vec<_>>()).ok_or_else(|| {
        DemoError::Trace(format!("{} pulses do not match the plans", trace.len()))
    })?;
    let mut moves = batch
        .iter()
        .zip(reports)
        .zip(plans)
        .zip(runs)
        .enumerate()
        .map(|(i, (((step, report), plan), run))| DemoMove {
            name: step.name,
            chained: i > 0,
            chain: None,
            played: replay(handle.robot(), &plan, &run, scan_s),
            report,
            plan,
        })
        .collect::<Vec<_>>();
    measure_waits(&mut moves, &rig.mock.with(|m| m.starts().to_vec()));
    Ok(moves)
}

/// Submits every step of `batch` at once: the id of each one's start.
async fn submit(handle: &RobotHandle, batch: &[Step]) -> Result<Vec<u64>, DemoError> {
    let mut ids = Vec::new();
    for step in batch {
        let started = handle
            .submit_starts(step.order.clone())
            .await
            .map_err(|source| DemoError::Refused {
                name: step.name,
                source,
            })?;
        // Each step is measured as one start: none of the demo's lines passes a reversal.
        let [id] = started[..] else {
            return Err(DemoError::NotDone {
                name: step.name,
                stage: Stage::Queued,
                why: format!("planned as {} starts, measured as one", started.len()),
            });
        };
        ids.push(id);
    }
    Ok(ids)
}

/// Waits for every move `ids` of `batch` to end: their reports, once each ended done.
async fn wait_done(
    handle: &RobotHandle,
    batch: &[Step],
    ids: Vec<u64>,
) -> Result<Vec<MoveReport>, DemoError> {
    let mut reports = Vec::new();
    for (step, id) in batch.iter().zip(ids) {
        let report = handle
            .wait(id, BATCH_LIMIT)
            .await
            .unwrap_or_else(|| unreachable!("move {id} was just submitted and reports are kept"));
        if report.stage != Stage::Done {
            return Err(DemoError::NotDone {
                name: step.name,
                stage: report.stage,
                why: report.error.clone().unwrap_or_else(|| "timed out".into()),
            });
        }
        reports.push(report);
    }
    Ok(reports)
}

/// Every chained move's [`ChainWait`], for `moves` run one after another, from the trace and
/// the mock's record of its `starts`.
fn measure_waits(moves: &mut [DemoMove], starts: &[StartRecord]) {
    for i in 1..moves.len() {
        let before = &moves[i - 1].played;
        let ended_s = before.start_s + before.figures.finish_s;
        let seen_s = moves[i].report.seq.and_then(|seq| {
            starts
                .iter()
                .find(|s| s.block.seq == seq && s.outcome == StartOutcome::Started)
                .map(|s| s.seen_s)
        });
        if let (true, Some(seen_s)) = (moves[i].chained, seen_s) {
            moves[i].chain = Some(ChainWait {
                seen_after_s: seen_s - ended_s,
                started_after_s: moves[i].played.start_s - ended_s,
            });
        }
    }
}

/// Whether `plan`, made again, is the one the daemon reported (its rows and path deviation, to
/// the bit).
fn as_reported(plan: &Plan, report: &MoveReport) -> bool {
    report.predicted.is_some_and(|p| {
        p.rows == plan.figures.rows
            && p.path_deviation_mm.to_bits() == plan.figures.path_deviation_mm.to_bits()
    })
}

/// The daemon's plan of a move, made again from the counts it was planned from.
fn replan(robot: &Robot, step: &Step, report: &MoveReport) -> Result<Plan, DemoError> {
    let trace_error = |why: String| DemoError::Trace(format!("{}: {why}", step.name));
    let start = report
        .start_counts
        .ok_or_else(|| trace_error("no start counts".into()))?;
    let counts: [i64; JOINTS] =
        std::array::from_fn(|j| start[usize::from(robot.joints[j].channel)]);
    let checked = step
        .order
        .check(robot.motion)
        .map_err(|e| trace_error(e.to_string()))?;
    let plan = crate::daemon::plan_order(robot, &checked, counts)
        .map_err(|e| trace_error(e.to_string()))?;
    if !as_reported(&plan, report) {
        return Err(trace_error(
            "planned again, it differs from the daemon's plan".into(),
        ));
    }
    Ok(plan)
}
