//! The config file's schema exactly as written: serde structs that reject unknown keys and keep
//! the span of every value the validation pass checks, so its errors can name the line.
//!
//! Nothing here is checked beyond TOML types; `validate` and the section modules turn these into
//! [`crate::robot::Robot`]s. A new section (say `[robots.NAME.plc]`) is one more field of
//! [`RawRobot`], one more struct here and one more section module.

use std::collections::BTreeMap;

use serde::Deserialize;
use toml::Spanned;

use crate::plc::{Parity, Protocol};
use crate::robot::OverSpeed;
use crate::table::{FrequencyModel, OutputMethod};

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawConfig {
    /// Robots by name; sorted by name here, put back in file order by the keys' spans.
    #[serde(default)]
    pub robots: BTreeMap<Spanned<String>, Spanned<RawRobot>>,
    /// `[daemon]`: how `linterpd serve` offers its API; checked by `daemon`.
    pub daemon: Option<Spanned<RawDaemon>>,
    /// `[console]`: the operator's console; checked by `console`.
    pub console: Option<Spanned<RawConsole>>,
}

/// `[console]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawConsole {
    pub listen: Option<Spanned<String>>,
    pub allow: Option<Vec<Spanned<String>>>,
    pub origins: Option<Vec<Spanned<String>>>,
    pub session: Option<Spanned<String>>,
    pub users: Option<BTreeMap<Spanned<String>, Spanned<RawConsoleUser>>>,
}

/// `[console.users.NAME]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawConsoleUser {
    pub role: Spanned<String>,
    pub password_hash: Option<Spanned<String>>,
    pub token_file: Option<Spanned<String>>,
}

/// `[robots.NAME.console]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRobotConsole {
    pub manual_speed_mm_s: Option<Spanned<f64>>,
}

/// `[daemon]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawDaemon {
    pub socket: Option<Spanned<String>>,
    pub socket_mode: Option<Spanned<String>>,
    pub listen: Option<Spanned<String>>,
    pub token_file: Option<Spanned<String>>,
    pub start_within: Option<Spanned<String>>,
    pub state_dir: Option<Spanned<String>>,
    pub journal: Option<Spanned<RawJournal>>,
}

/// `[daemon.journal]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawJournal {
    pub file_bytes: Option<Spanned<i64>>,
    pub files: Option<Spanned<i64>>,
    pub queue: Option<Spanned<i64>>,
}

/// `[robots.NAME]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRobot {
    pub area_words: Option<Spanned<i64>>,
    pub kinematics: Spanned<RawKinematics>,
    pub motion: Spanned<RawMotion>,
    pub joints: Spanned<Vec<Spanned<RawJoint>>>,
    pub plc: Option<Spanned<RawPlc>>,
    pub gateway: Option<Spanned<RawGateway>>,
    pub cell: Option<Spanned<RawCell>>,
    pub console: Option<Spanned<RawRobotConsole>>,
    /// `[robots.NAME.frames.NAME]`: user frames; checked by `pallets`.
    pub frames: Option<BTreeMap<String, Spanned<crate::pallet::doc::FrameDoc>>>,
    /// `[robots.NAME.pallets.NAME]`: pallet patterns; checked by `pallets`.
    pub pallets: Option<BTreeMap<String, Spanned<crate::pallet::doc::PalletDoc>>>,
    /// `[robots.NAME.tool]`: the tool centre from the flange; checked by `pallets`.
    pub tool: Option<Spanned<RawTool>>,
}

/// `[robots.NAME.tool]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTool {
    pub offset: Spanned<[Spanned<f64>; 3]>,
}

/// `[robots.NAME.cell]`: the cell's signals and cycle programs; checked by `cell`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCell {
    pub signals: Option<BTreeMap<Spanned<String>, Spanned<String>>>,
    pub programs: Option<Spanned<String>>,
    pub require_wait_timeout: Option<Spanned<bool>>,
    pub face: Option<Spanned<RawCellFace>>,
}

/// `[robots.NAME.cell.face]`: the register face the line drives; checked by `cell`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCellFace {
    pub registers: Option<Spanned<i64>>,
    pub plc: Option<Spanned<String>>,
    pub home: Option<Spanned<String>>,
    pub positions: Option<Vec<Spanned<String>>>,
    pub mode: Option<Spanned<String>>,
    pub pallet: Option<Spanned<String>>,
}

/// `[robots.NAME.gateway]`: the register gateway's access list; checked by `gateway`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGateway {
    pub read: Option<Vec<Spanned<String>>>,
    pub write: Option<Vec<Spanned<String>>>,
    pub modbus: Option<Spanned<RawModbusFace>>,
}

/// `gateway.modbus`: the Modbus TCP server face.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawModbusFace {
    pub listen: Option<Spanned<String>>,
    pub allow: Option<Vec<Spanned<String>>>,
}

/// `[robots.NAME.plc]`: how to reach the robot's PLC; checked by `plc`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPlc {
    pub protocol: Protocol,
    pub serial: Option<Spanned<RawSerial>>,
    pub tcp: Option<Spanned<RawTcp>>,
    pub station: Option<Spanned<i64>>,
    pub header: Option<Spanned<String>>,
    pub multi_frame_reads: Option<Spanned<bool>>,
    pub read_back: Option<Spanned<bool>>,
    pub timeout: Option<Spanned<String>>,
    pub retries: Option<Spanned<i64>>,
    pub heartbeat_timeout: Option<Spanned<String>>,
    pub mode_relay: Option<Spanned<String>>,
    pub modbus_max_write: Option<Spanned<i64>>,
    pub modbus_max_read: Option<Spanned<i64>>,
    pub scan_time: Option<Spanned<String>>,
    pub home_counts: Option<Spanned<Vec<Spanned<i64>>>>,
    pub contract: Option<Spanned<RawContract>>,
}

/// `plc.serial`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSerial {
    pub path: Spanned<String>,
    pub baud: Option<Spanned<i64>>,
    pub data_bits: Option<Spanned<i64>>,
    pub parity: Option<Parity>,
    pub stop_bits: Option<Spanned<i64>>,
}

/// `plc.tcp`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTcp {
    pub address: Spanned<String>,
    pub connect_timeout: Option<Spanned<String>>,
}

/// `[robots.NAME.plc.contract]`: DT addresses of the register contract (CONTRACT.md); each
/// defaults to `contract::Layout::default()`'s. The areas' size is `robots.NAME.area_words`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawContract {
    pub status_base: Option<Spanned<i64>>,
    pub command_base: Option<Spanned<i64>>,
    pub table_base: Option<Spanned<i64>>,
    pub bank_stride: Option<Spanned<i64>>,
    pub channel_stride: Option<Spanned<i64>>,
    pub inputs: Option<Spanned<Vec<Spanned<String>>>>,
}

/// `[robots.NAME.kinematics]`: every model's keys, optional here; which ones a model takes is
/// checked by `kinematics`, so a key of another model gets an error that names the model.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawKinematics {
    #[serde(rename = "type")]
    pub model: Spanned<ModelType>,
    pub l0_mm: Option<Spanned<f64>>,
    pub min_axis_distance_mm: Option<Spanned<f64>>,
    pub l1_mm: Option<Spanned<f64>>,
    pub l2_mm: Option<Spanned<f64>>,
    pub elbow: Option<Spanned<RawElbow>>,
    pub reach_margin_mm: Option<Spanned<f64>>,
}

/// `kinematics.type`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum ModelType {
    Cylindrical,
    Cartesian,
    Scara,
}

/// `kinematics.elbow` (scara).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawElbow {
    Left,
    Right,
}

/// `[robots.NAME.motion]`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMotion {
    pub method: Option<Spanned<RawMethod>>,
    pub period: Spanned<String>,
    pub speed_mm_s: Spanned<f64>,
    pub accel_time: Spanned<String>,
    pub frequency_model: Option<FrequencyModel>,
    pub over_speed: Option<RawOverSpeed>,
    pub tolerance_mm: Option<Spanned<f64>>,
    pub max_speed_mm_s: Option<Spanned<f64>>,
    pub profile: Option<Spanned<RawRamp>>,
    pub jerk_mm_s3: Option<Spanned<f64>>,
}

/// `motion.profile`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawRamp {
    Trapezoid,
    SCurve,
}

/// `motion.method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawMethod {
    ConstantPeriod,
    BoundedError,
}

/// `motion.over_speed`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawOverSpeed {
    Reject,
    SlowDown,
}

impl From<RawOverSpeed> for OverSpeed {
    fn from(raw: RawOverSpeed) -> Self {
        match raw {
            RawOverSpeed::Reject => Self::Reject,
            RawOverSpeed::SlowDown => Self::SlowDown,
        }
    }
}

/// `[[robots.NAME.joints]]`: both unit spellings of each quantity, optional here; `joints` picks
/// the one the joint's kind needs and refuses the other by name.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawJoint {
    pub name: Spanned<String>,
    pub channel: Spanned<i64>,
    pub step_deg: Option<Spanned<f64>>,
    pub step_mm: Option<Spanned<f64>>,
    pub offset_deg: Option<Spanned<f64>>,
    pub offset_mm: Option<Spanned<f64>>,
    pub min_deg: Option<Spanned<f64>>,
    pub min_mm: Option<Spanned<f64>>,
    pub max_deg: Option<Spanned<f64>>,
    pub max_mm: Option<Spanned<f64>>,
    pub max_freq_hz: Spanned<i64>,
    pub output: OutputMethod,
    pub max_accel_deg_s2: Option<Spanned<f64>>,
    pub max_accel_mm_s2: Option<Spanned<f64>>,
    pub start_hz: Option<Spanned<f64>>,
    pub max_jerk_deg_s3: Option<Spanned<f64>>,
    pub max_jerk_mm_s3: Option<Spanned<f64>>,
}

/// A joint quantity written in degrees or millimetres.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Quantity {
    Step,
    Offset,
    Min,
    Max,
    MaxAccel,
    MaxJerk,
}

impl Quantity {
    /// The key's stem (`step` in `step_deg`).
    pub(super) fn stem(self) -> &'static str {
        match self {
            Self::Step => "step",
            Self::Offset => "offset",
            Self::Min => "min",
            Self::Max => "max",
            Self::MaxAccel => "max_accel",
            Self::MaxJerk => "max_jerk",
        }
    }

    /// The key in `unit` ("deg" or "mm"): `step_deg`, `max_accel_mm_s2`.
    pub(super) fn key(self, unit: &str) -> String {
        match self {
            Self::MaxAccel => format!("{}_{unit}_s2", self.stem()),
            Self::MaxJerk => format!("{}_{unit}_s3", self.stem()),
            _ => format!("{}_{unit}", self.stem()),
        }
    }
}

impl RawJoint {
    /// The quantity as written in `unit` ("deg" or "mm").
    pub(super) fn get(&self, quantity: Quantity, unit: &str) -> Option<&Spanned<f64>> {
        let deg = unit == "deg";
        let field = match quantity {
            Quantity::Step if deg => &self.step_deg,
            Quantity::Step => &self.step_mm,
            Quantity::Offset if deg => &self.offset_deg,
            Quantity::Offset => &self.offset_mm,
            Quantity::Min if deg => &self.min_deg,
            Quantity::Min => &self.min_mm,
            Quantity::Max if deg => &self.max_deg,
            Quantity::Max => &self.max_mm,
            Quantity::MaxAccel if deg => &self.max_accel_deg_s2,
            Quantity::MaxAccel => &self.max_accel_mm_s2,
            Quantity::MaxJerk if deg => &self.max_jerk_deg_s3,
            Quantity::MaxJerk => &self.max_jerk_mm_s3,
        };
        field.as_ref()
    }
}
