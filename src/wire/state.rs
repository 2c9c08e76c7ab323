//! PURE. What the API says of a robot: its link, the phase the daemon and the PLC stand in, the
//! status block's words as last read, its moves in flight, its cycle, mode and cell face.

use serde::{Deserialize, Serialize};

use crate::contract::machine::Phase;
use crate::contract::{PlcMode, State};
use crate::wire::MoveId;

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
