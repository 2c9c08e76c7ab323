//! What the daemon tells about its robots and their moves: the robot's state and each move's
//! report, as the API serves them and the progress feed streams them.

use std::collections::{BTreeMap, VecDeque};

use serde::{Deserialize, Serialize};
use tokio::sync::watch;

use super::order::MoveOrder;
use crate::contract::State;
use crate::contract::machine::Phase;
use crate::geometry::{Path, Primitive};
use crate::plc::PlcMode;

/// A move's identifier, unique across daemon runs (see [`super::MoveIds`]).
pub type MoveId = u64;

/// Where a move is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stage {
    /// Accepted, waiting its turn.
    Queued,
    /// Planned; its bank is being written and verified.
    Uploading,
    /// A cycle's move prepared ahead: its bank written and verified, held until the cycle
    /// reaches its step (nothing given to the PLC yet).
    Prepared,
    /// Uploaded and started while the previous move runs: the PLC starts it when that one ends.
    Waiting,
    /// Running on the PLC.
    Running,
    /// Ended on its target.
    Done,
    /// Stopped while it ran (a stop request, the e-stop input, PROG mode): see `error`.
    Stopped,
    /// Failed: see `error`; nothing more will happen to it.
    Failed,
    /// Never ran: nothing moved (a stop came first, the move before it did not end, the PLC
    /// restarted, the daemon shut down): see `error`.
    Cancelled,
}

impl Stage {
    /// The final stages, in the order metrics list them.
    pub const FINAL: [Self; 4] = [Self::Done, Self::Stopped, Self::Failed, Self::Cancelled];

    /// Whether nothing more will happen to the move.
    #[must_use]
    pub fn is_final(self) -> bool {
        matches!(
            self,
            Self::Done | Self::Stopped | Self::Failed | Self::Cancelled
        )
    }

    /// Its name as the API writes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Queued => "queued",
            Self::Uploading => "uploading",
            Self::Prepared => "prepared",
            Self::Waiting => "waiting",
            Self::Running => "running",
            Self::Done => "done",
            Self::Stopped => "stopped",
            Self::Failed => "failed",
            Self::Cancelled => "cancelled",
        }
    }
}

/// The planner's prediction for a move.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Predicted {
    /// Table rows over all channels.
    pub rows: usize,
    /// DT words of the tables.
    pub words: usize,
    /// Planned duration, s.
    pub duration_s: f64,
    /// Path deviation the execution model predicts, mm.
    pub path_deviation_mm: f64,
    /// Tracking error the execution model predicts, mm.
    pub tracking_error_mm: f64,
}

/// Everything known about one move. Read back (by the CLI), a field an older daemon did not
/// write is `None` (or empty, false, 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MoveReport {
    /// Its identifier.
    pub id: MoveId,
    /// The robot.
    pub robot: String,
    /// Where it is.
    pub stage: Stage,
    /// The order as accepted (empty for a move found running after a restart).
    #[serde(default)]
    pub order: MoveOrder,
    /// Found running on the PLC when the daemon (re)connected, not started by this run.
    #[serde(default)]
    pub recovered: bool,
    /// The longest the move may take from now on before it is given up, s (its planned
    /// duration and upload plus margins); what `linterpd move` waits for at most.
    pub deadline_s: Option<f64>,
    /// The contract sequence number of its start.
    pub seq: Option<u16>,
    /// The table bank it uses.
    pub bank: Option<u16>,
    /// Counts per channel it was planned from.
    pub start_counts: Option<[i64; 4]>,
    /// Counts per channel it should end at.
    pub target_counts: Option<[i64; 4]>,
    /// The plan's prediction.
    pub predicted: Option<Predicted>,
    /// Time to write and verify its bank, s.
    pub upload_s: Option<f64>,
    /// Time from its start to its end on the PLC, as polled, s.
    pub motion_s: Option<f64>,
    /// How far along its plan it is, as a share of its planned duration (0 to 1): the planned
    /// instant whose counts come nearest the counts last read from the PLC (it never goes
    /// back); by the clock only for a move the daemon found running without its plan.
    #[serde(default)]
    pub progress: f64,
    /// The latest counts per channel read while it ran.
    pub counts: Option<[i64; 4]>,
    /// Final counts minus target counts per channel (`None` until it is done, and for a move
    /// that chained into the next, whose start the PLC made from exactly these).
    pub final_error_pulses: Option<[i64; 4]>,
    /// Why it failed or stopped.
    pub error: Option<String>,
    /// A path section's move: which section, and when it runs each of the path's pieces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section: Option<SectionReport>,
    /// Stopped by the PLC because its permit stopped holding (contract v3 fault 9): a hold, not
    /// a fault; `error` names the input.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub held: bool,
}

/// What `POST /v1/robots/{name}/moves` answers (202).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MoveAccepted {
    /// The move's last start: the move has ended when it has.
    pub id: MoveId,
    /// Every start, in order: one, or a line cut where a joint reverses (an older daemon gave
    /// only `id`: read back, then empty).
    #[serde(default)]
    pub ids: Vec<MoveId>,
    /// The last start's report.
    pub report: MoveReport,
}

/// What `POST /v1/robots/{name}/paths` answers (202): one move per section (or part of one), in
/// order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathAccepted {
    /// The moves' ids.
    pub ids: Vec<MoveId>,
    /// Their reports (one that ended and was dropped since is left out).
    #[serde(default)]
    pub reports: Vec<MoveReport>,
}

/// Which section of a path a move runs, and when it runs each piece of it, so that a client can
/// tell from a move's `progress` which element (or blend) the robot is on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SectionReport {
    /// The section, from 1.
    pub number: usize,
    /// How many sections the path has.
    pub of: usize,
    /// Its pieces, in order.
    pub pieces: Vec<PieceReport>,
}

/// One piece of a section, and when the move runs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PieceReport {
    /// A line or an arc.
    pub kind: PieceKind,
    /// The element it comes from (from 1); none for a blend.
    pub element: Option<usize>,
    /// A blend: the waypoint it rounds (the end of element n); none for an element's piece.
    pub waypoint: Option<usize>,
    /// Share of the move's planned duration when it is entered (0 to 1), as `progress` counts.
    pub begins: f64,
    /// Share of the move's planned duration when it is left.
    pub ends: f64,
}

/// What a piece of a path is (`line` or `arc` in the API).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PieceKind {
    /// A straight line.
    Line,
    /// A circular arc: an element's, or a blend rounding a waypoint.
    Arc,
}

impl From<&Primitive> for PieceKind {
    fn from(primitive: &Primitive) -> Self {
        match primitive {
            Primitive::Line(_) => Self::Line,
            Primitive::Arc(_) => Self::Arc,
        }
    }
}

impl SectionReport {
    /// Section `number` of `of`, its path `section` (measured from its start) reached at
    /// distance `s` at `time_at_mm(s)` on its profile's time, of which this start plays `window` (a part of a section cut into several starts shows
    /// the pieces before it done and those after it not begun).
    #[must_use]
    pub fn new(
        number: usize,
        of: usize,
        section: &Path,
        time_at_mm: &dyn Fn(f64) -> f64,
        window: &crate::plan::Window,
    ) -> Self {
        let duration_s = window.duration_s();
        let share = |s_mm: f64| ((time_at_mm(s_mm) - window.from_s) / duration_s).clamp(0.0, 1.0);
        let pieces = section
            .pieces()
            .iter()
            .map(|p| PieceReport {
                kind: PieceKind::from(&p.primitive),
                element: p.element,
                waypoint: p.waypoint,
                begins: share(p.start_mm),
                ends: share(p.start_mm + p.primitive.length_mm()),
            })
            .collect();
        Self { number, of, pieces }
    }
}

impl MoveReport {
    /// A new report for an order.
    #[must_use]
    pub fn new(id: MoveId, robot: &str, order: MoveOrder) -> Self {
        Self {
            id,
            robot: robot.to_owned(),
            stage: Stage::Queued,
            order,
            recovered: false,
            deadline_s: None,
            seq: None,
            bank: None,
            start_counts: None,
            target_counts: None,
            predicted: None,
            upload_s: None,
            motion_s: None,
            progress: 0.0,
            counts: None,
            final_error_pulses: None,
            held: false,
            error: None,
            section: None,
        }
    }
}

/// The link to a robot's PLC.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(default)]
pub struct LinkState {
    /// Whether the link is up and the contract answered.
    pub connected: bool,
    /// The last link or contract error.
    pub error: Option<String>,
    /// Reconnections since the daemon started.
    pub reconnects: u64,
}

/// A robot's state as last read. Read back (by the CLI), a field an older daemon did not write
/// is `None` (or empty, false, 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct RobotState {
    /// Robot name.
    pub name: String,
    /// The PLC link.
    #[serde(default)]
    pub link: LinkState,
    /// Where the daemon and the PLC stand.
    #[serde(default)]
    pub phase: RobotPhase,
    /// Whether the PLC's homed bit is set (`false` until known).
    #[serde(default)]
    pub homed: bool,
    /// Why a new move would be refused now (`None`: it would be accepted).
    pub refuses: Option<String>,
    /// `run` or `prog`, when known.
    pub plc_mode: Option<PlcMode>,
    /// Milliseconds since the heartbeat last changed.
    pub heartbeat_age_ms: Option<u64>,
    /// The PLC program's state (`idle`, `running`, `done`, `stopped`, `fault`, `homing`).
    pub state: Option<State>,
    /// The fault word, when not 0.
    pub fault: Option<u16>,
    /// Counts per channel.
    pub counts: Option<[i64; 4]>,
    /// The cell's input words as the last status block showed them (contract v3, status
    /// +22..+25); `None` while the link is down.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inputs: Option<[u16; 4]>,
    /// The pose those counts put the tool in: x, y, z mm, a deg.
    pub pose: Option<[f64; 4]>,
    /// The move running now.
    pub current_move: Option<MoveId>,
    /// Moves waiting, in order.
    #[serde(default)]
    pub queued: Vec<MoveId>,
    /// The register gateway's work on this robot's link.
    #[serde(default)]
    pub gateway: GatewayStats,
    /// The robot's cycle, if one ran since the daemon started.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cycle: Option<super::CycleStatus>,
    /// Who drives the robot: `local` (the CLI and the API) or `remote` (the cell face).
    #[serde(default)]
    pub mode: crate::cell::Mode,
    /// The cell face's command side, when the robot has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub face: Option<FaceState>,
}

/// The cell face as the robot's state shows it: what the line selected and last asked.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FaceState {
    /// The selected program: its number (0: none).
    pub program: u16,
    /// Its name, when one is selected.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub program_name: Option<String>,
    /// Whether move-enable is on.
    pub enabled: bool,
    /// The command word as last taken.
    pub commands: u16,
    /// Why the last command was refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refused: Option<FaceRefusal>,
}

/// A refused cell face command: the status block's refusal word and what it means.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FaceRefusal {
    /// The refusal word's code.
    pub code: u16,
    /// What it means.
    pub meaning: String,
}

/// Where the daemon and the PLC stand, as [`RobotState::phase`] shows it: the contract machine's
/// [`Phase`] without its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum RobotPhase {
    /// Not published yet: the worker's first connection attempt has not ended (the API wrote
    /// `""` for it before; that still reads).
    #[default]
    #[serde(rename = "connecting", alias = "")]
    NotPublished,
    /// No link to the PLC (or no status block yet).
    LinkDown,
    /// The PLC's heartbeat stands still (stalled, or in PROG mode).
    Stalled,
    /// The PLC's homed bit is clear.
    Unhomed,
    /// The home routine runs.
    Homing,
    /// Nothing in flight.
    Idle,
    /// A bank is being written (behind the running move, if there is one).
    Uploading,
    /// A start was written while nothing ran; not yet seen taken.
    Starting,
    /// A move runs.
    Running,
    /// A move runs and the next was written behind it.
    RunningChained,
    /// A stop was written: the moves in flight end as the PLC shows.
    Stopping,
}

impl RobotPhase {
    /// Every phase, in the order of its declaration.
    pub const ALL: [Self; 11] = [
        Self::NotPublished,
        Self::LinkDown,
        Self::Stalled,
        Self::Unhomed,
        Self::Homing,
        Self::Idle,
        Self::Uploading,
        Self::Starting,
        Self::Running,
        Self::RunningChained,
        Self::Stopping,
    ];

    /// Its name as the API writes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::NotPublished => "connecting",
            Self::LinkDown => "link-down",
            Self::Stalled => "stalled",
            Self::Unhomed => "unhomed",
            Self::Homing => "homing",
            Self::Idle => "idle",
            Self::Uploading => "uploading",
            Self::Starting => "starting",
            Self::Running => "running",
            Self::RunningChained => "running-chained",
            Self::Stopping => "stopping",
        }
    }
}

impl From<&Phase> for RobotPhase {
    fn from(phase: &Phase) -> Self {
        match phase {
            Phase::LinkDown { .. } => Self::LinkDown,
            Phase::Stalled => Self::Stalled,
            Phase::Unhomed => Self::Unhomed,
            Phase::Homing { .. } => Self::Homing,
            Phase::Idle => Self::Idle,
            Phase::Uploading { .. } => Self::Uploading,
            Phase::Starting { .. } => Self::Starting,
            Phase::Running { .. } => Self::Running,
            Phase::Chained { .. } => Self::RunningChained,
            Phase::Stopping { .. } => Self::Stopping,
        }
    }
}

/// What the register gateway did on a robot's link since the daemon started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(default)]
pub struct GatewayStats {
    /// Requests answered (read or write).
    pub requests: u64,
    /// Of them, failed (link down, PLC error).
    pub failed: u64,
    /// Exchanges with the PLC they took.
    pub exchanges: u64,
    /// The longest of those exchanges, ms.
    pub longest_exchange_ms: u64,
    /// The longest a due status read waited behind a gateway exchange, ms.
    pub longest_poll_delay_ms: u64,
}

/// The moves of one robot: the report of every move not ended and of the latest [`KEPT`] ended
/// ones, and a feed per move.
#[derive(Debug, Default)]
pub struct Moves {
    feeds: BTreeMap<MoveId, watch::Sender<MoveReport>>,
    order: VecDeque<MoveId>,
}

/// Ended moves whose reports are kept per robot (a move not ended is always kept).
pub const KEPT: usize = 500;

impl Moves {
    /// Records a new report; past [`KEPT`] ended reports, the oldest ended ones are dropped
    /// (never the report of a move queued or running).
    pub fn insert(&mut self, report: MoveReport) {
        let id = report.id;
        self.feeds.insert(id, watch::channel(report).0);
        self.order.push_back(id);
        let ended = |feeds: &BTreeMap<MoveId, watch::Sender<MoveReport>>, id: &MoveId| {
            feeds.get(id).is_some_and(|f| f.borrow().stage.is_final())
        };
        let mut excess = self
            .order
            .iter()
            .filter(|id| ended(&self.feeds, id))
            .count()
            .saturating_sub(KEPT);
        while excess > 0 {
            let Some(at) = self.order.iter().position(|id| ended(&self.feeds, id)) else {
                break;
            };
            if let Some(old) = self.order.remove(at) {
                self.feeds.remove(&old);
            }
            excess -= 1;
        }
    }

    /// Changes a report and tells its watchers.
    pub fn update(&self, id: MoveId, change: impl FnOnce(&mut MoveReport)) {
        if let Some(feed) = self.feeds.get(&id) {
            feed.send_modify(change);
        }
    }

    /// A report.
    #[must_use]
    pub fn get(&self, id: MoveId) -> Option<MoveReport> {
        self.feeds.get(&id).map(|f| f.borrow().clone())
    }

    /// A feed of a move's reports.
    #[must_use]
    pub fn subscribe(&self, id: MoveId) -> Option<watch::Receiver<MoveReport>> {
        self.feeds.get(&id).map(watch::Sender::subscribe)
    }

    /// Every kept report, oldest first.
    #[must_use]
    pub fn all(&self) -> Vec<MoveReport> {
        self.order.iter().filter_map(|id| self.get(*id)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 25: a path of 1,000 stopped elements got 503 while its moves ran: the reports of
    /// its first starts, still queued, had been dropped to keep 500 per robot.
    #[test]
    fn the_report_of_a_move_not_ended_is_never_dropped() {
        let mut moves = Moves::default();
        let count = KEPT as u64 * 2;
        for id in 1..=count {
            moves.insert(MoveReport::new(id, "r", MoveOrder::default()));
        }
        assert!(
            (1..=count).all(|id| moves.get(id).is_some()),
            "a queued report was dropped"
        );
        // Once ended, only the latest KEPT ended reports stay, and every one not ended.
        for id in 1..=KEPT as u64 + 10 {
            moves.update(id, |r| r.stage = Stage::Done);
        }
        moves.insert(MoveReport::new(count + 1, "r", MoveOrder::default()));
        assert!(moves.get(10).is_none() && moves.get(11).is_some());
        assert!((KEPT as u64 + 11..=count + 1).all(|id| moves.get(id).is_some()));
        assert_eq!(moves.all().len(), KEPT + (count as usize - KEPT - 10) + 1);
    }
    use crate::geometry::{Corner, Element, PathSpec, Pose, Profile, ProfileRequest};

    #[test]
    fn a_sections_report_gives_each_piece_its_share_of_the_planned_time() {
        let to = |x, y| Element::Line {
            to: Pose::from_mm_deg(x, y, 0.0, 0.0),
        };
        let path = Path::build(&PathSpec {
            start: Pose::from_mm_deg(0.0, 0.0, 0.0, 0.0),
            elements: vec![
                (to(100.0, 0.0), Corner::Blend(20.0)),
                (to(100.0, 100.0), Corner::Stop),
            ],
        })
        .unwrap();
        let profile = Profile::new(ProfileRequest {
            length_mm: path.length_mm(),
            speed_mm_s: 100.0,
            accel_s: 0.2,
            period_s: 0.01,
        })
        .unwrap();
        let report = SectionReport::new(
            2,
            3,
            &path,
            &|s| profile.time_at_mm(s),
            &crate::plan::Window::whole(&profile),
        );
        assert_eq!((report.number, report.of), (2, 3));
        let names: Vec<_> = report
            .pieces
            .iter()
            .map(|p| (p.kind, p.element, p.waypoint))
            .collect();
        assert_eq!(
            names,
            [
                (PieceKind::Line, Some(1), None),
                (PieceKind::Arc, None, Some(1)),
                (PieceKind::Line, Some(2), None)
            ]
        );
        // Back to back from 0 to 1; the blend's share is its time on the cruise.
        assert!(report.pieces[0].begins.abs() < 1e-12);
        assert!((report.pieces[2].ends - 1.0).abs() < 1e-12);
        for w in report.pieces.windows(2) {
            assert!((w[0].ends - w[1].begins).abs() < 1e-12);
        }
        let blend_s = (report.pieces[1].ends - report.pieces[1].begins) * profile.duration_s();
        let blend_mm = path.pieces()[1].primitive.length_mm();
        assert!(
            (blend_s - blend_mm / profile.speed_mm_s).abs() < 1e-6,
            "{blend_s}"
        );
    }
}

/// The API's JSON of states and reports, byte for byte as the daemon wrote it before its types
/// were read back (issue 26), and read back into the same values.
#[cfg(test)]
mod json_tests {
    use super::*;

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
            cycle: Some(super::super::CycleStatus::starting("press-load", Some(10))),
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
            speed_mm_s: Some(120.0),
            method: Some("bounded-error".into()),
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
            serde_json::from_str(r#"{"name":"r","link":{"connected":true},"phase":"idle"}"#)
                .unwrap();
        assert!(state.link.connected && state.phase == RobotPhase::Idle);
        assert_eq!(state.gateway, GatewayStats::default());
        assert!(state.queued.is_empty() && state.plc_mode.is_none());
    }
}
