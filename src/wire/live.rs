//! PURE. A robot's live state as the console and `linterpd status --watch` see it, and the
//! stream that carries it: the whole snapshot first, then only what changed, as a JSON merge
//! patch (RFC 7396), once per status read that changed anything.
//!
//! ```text
//! {"type":"full","robot":"press-loader","seq":41,"live":{Live}}
//! {"type":"patch","robot":"press-loader","seq":42,"patch":{"state":{"counts":[...],"pose":[...]}}}
//! ```
//! `seq` grows by one per message of a robot: a reader that sees a gap has missed a change and
//! asks for the whole snapshot again (the WebSocket and the NDJSON stream end a reader that
//! falls that far behind; it reconnects).

use serde::{Deserialize, Serialize};

use super::{MoveReport, RobotState};

/// What the console and `status --watch` see of one robot, built in one place
/// (`daemon::stream::snapshot`) from the daemon's state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Live {
    /// The robot's state, as `GET /v1/robots/{name}` gives it.
    pub state: RobotState,
    /// How many status blocks the daemon has read (and links lost): what woke this snapshot.
    #[serde(default)]
    pub reads: u64,
    /// The joints' values from the counts, in the joints' order, degrees or mm.
    #[serde(default)]
    pub joints: Option<Vec<f64>>,
    /// The tool's speed between the last two status reads, mm/s.
    #[serde(default)]
    pub speed_mm_s: Option<f64>,
    /// The cell's signals by name, where the status block carries them (its input words).
    #[serde(default)]
    pub signals: Vec<SignalValue>,
    /// The move running now (its report, with its progress).
    #[serde(default)]
    pub current: Option<MoveReport>,
    /// Where the move running now goes: the tool's x, y, z (mm) at its start and at its end,
    /// from its planned counts (the line the robot view draws).
    #[serde(default)]
    pub path: Option<[[f64; 3]; 2]>,
    /// The newest move that ended.
    #[serde(default)]
    pub last: Option<MoveReport>,
    /// The speed override, 1 to 100 %: applied to every move planned after it was set.
    #[serde(default = "full_speed")]
    pub speed_override_pct: u8,
    /// The console's side: the control seat and the jog.
    #[serde(default)]
    pub console: ConsoleLive,
}

fn full_speed() -> u8 {
    100
}

/// One of the cell's signals, by name.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignalValue {
    /// Its name in `[robots.NAME.cell] signals`.
    pub name: String,
    /// Its address (`X5`).
    pub address: String,
    /// Its value in the last status block; `None` when the status block does not carry it
    /// (not in one of its input words) or the link is down.
    pub value: Option<bool>,
}

/// The console's side of a robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct ConsoleLive {
    /// Who holds the control seat.
    #[serde(default)]
    pub seat: Option<SeatHolder>,
    /// The hold-to-run jog.
    #[serde(default)]
    pub jog: JogLive,
}

/// Who holds the control seat.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SeatHolder {
    /// The user.
    pub user: String,
    /// Their role.
    pub role: String,
}

/// The jog as the console shows it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct JogLive {
    /// The jog under way: who, along what, which way.
    #[serde(default)]
    pub active: Option<ActiveJog>,
    /// Why the last jog ended, in words.
    #[serde(default)]
    pub last_end: Option<String>,
    /// Why a jog would be refused now (`None`: it may start).
    #[serde(default)]
    pub refuses: Option<String>,
    /// The robot's manual speed (config), mm/s.
    pub manual_speed_mm_s: f64,
    /// What a jog runs at now: the manual speed under the speed override, mm/s.
    pub speed_mm_s: f64,
    /// The lease, ms.
    pub lease_ms: u64,
    /// One piece's motion, ms.
    pub piece_ms: u64,
    /// The longest stop write seen (an assumed 100 ms before the first), ms.
    pub exchange_ms: u64,
    /// Worst-case travel after the last keep-alive with the daemon alive, mm.
    pub travel_alive_mm: f64,
    /// Worst-case travel after the last keep-alive with the daemon hung or the cable cut, mm.
    pub travel_hung_mm: f64,
}

/// A jog under way.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ActiveJog {
    /// Whose.
    pub user: String,
    /// Along what (`x`, `y`, `z`, `a`).
    pub axis: String,
    /// Which way.
    pub positive: bool,
}

/// One message of the live stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum LiveMessage {
    /// The whole snapshot.
    Full {
        /// The robot.
        robot: String,
        /// Its message number.
        seq: u64,
        /// The snapshot.
        live: Box<Live>,
    },
    /// What changed since message `seq - 1`, as a JSON merge patch of [`Live`].
    Patch {
        /// The robot.
        robot: String,
        /// Its message number.
        seq: u64,
        /// The changes.
        patch: serde_json::Value,
    },
}
