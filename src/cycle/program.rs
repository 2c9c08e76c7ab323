//! The cycle program document, as a TOML file (and the same keys as JSON): an optional program
//! number, a description, and its steps in order. Every key is known (unknown ones are refused,
//! naming them); each step's shape (one action, the keys that go with it) is checked once as it
//! becomes a [`super::step::Step`], what it means by [`super::check`].
//!
//! ```toml
//! number = 1                     # 1..=255: the number the press line selects it by
//! description = "load one blank into the press"
//! [[step]]
//! label = "pick"
//! move = { position = "above-stack", speed_mm_s = 300 }
//! [[step]]
//! wait = "part_present"
//! timeout = "30s"
//! on_timeout = "fault"           # or a label to go on from
//! [[step]]
//! move = { position = "in-press" }
//! permit = "press_open & !press_moving"
//! [[step]]
//! move = { position = "above-stack" }
//! blend_mm = 20                  # not stopped here: rounded into the next move, one path
//! [[step]]
//! move = { position = "above-press" }
//! [[step]]
//! path = { file = "load.toml", speed_mm_s = 200 }   # or path = { path = { ...document... } }
//! [[step]]
//! set = { press_go = true, DT100 = 7 }
//! [[step]]
//! dwell = "200ms"
//! [[step]]
//! call = "eject"
//! [[step]]
//! loop = { to = "pick", count = 3 }   # or until = "<condition>", or until = "stop"
//! [[step]]
//! place = { pallet = "out", at_slot = [{ set = { gripper = false } }, { dwell = "150ms" }] }
//! [[step]]
//! advance = "out"                # a pallet's next slot (after a place with advance = false)
//! ```
//!
//! A `place` (or `pick`) at the pallet's current slot runs: the pallet's `between_layers`
//! program before the first slot of every layer but the first; the slot marked in progress;
//! from where the robot is through the slot's approach waypoints into the slot as one blended
//! path; the `at_slot` steps with the robot at the slot; the pallet advanced (on disk before the
//! next step); the retreat path; and when that filled the pallet, its `when_full`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::order::MoveOrder;

/// A cycle program as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ProgramDoc {
    /// The number the cell selects it by (1..=255).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub number: Option<i64>,
    /// What it does, for people.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Its steps, in order.
    #[serde(default)]
    pub step: Vec<StepDoc>,
}

/// One step as written: exactly one action key, and the keys that go with it (as the file
/// writes it; [`super::step::Step`] is the step the check reads).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct StepDoc {
    /// A name other steps jump to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// A move (a move order's keys).
    #[serde(default, rename = "move", skip_serializing_if = "Option::is_none")]
    pub move_: Option<MoveOrder>,
    /// A path: `file` (relative to the program's directory) or `path` (the document), and the
    /// motion keys of a path order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<PathStep>,
    /// A condition to wait for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wait: Option<String>,
    /// How long a wait may take, e.g. `"30s"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timeout: Option<String>,
    /// What a wait that times out does: `"fault"` (the default) or a label to go on from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub on_timeout: Option<String>,
    /// Outputs to write: a Y or R bit (or its signal name) = true/false, a DT word = a number.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub set: Option<BTreeMap<String, toml::Value>>,
    /// A pause, e.g. `"200ms"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dwell: Option<String>,
    /// Another program to run here, by name.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub call: Option<String>,
    /// A jump back to a label.
    #[serde(default, rename = "loop", skip_serializing_if = "Option::is_none")]
    pub loop_: Option<LoopDoc>,
    /// A move's or path's interlock, enforced by the PLC.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub permit: Option<String>,
    /// A move's end passed without stopping, rounded into the next move step within this
    /// distance of it, mm (the moves run as one path: `super::blend`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blend_mm: Option<f64>,
    /// A place at a pallet's current slot.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub place: Option<PalletStepDoc>,
    /// A pick from a pallet's current slot (depalletising: the same route, the same counter).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pick: Option<PalletStepDoc>,
    /// A pallet advanced to its next slot (after a place written with `advance = false`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub advance: Option<String>,
}

/// A `place` or `pick` step's table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct PalletStepDoc {
    /// The pallet (a pattern of the robot's `[robots.NAME.pallets.NAME]`).
    pub pallet: String,
    /// The steps run with the robot at the slot (the gripper's `set`, `wait` and `dwell`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub at_slot: Vec<StepDoc>,
    /// Whether the pallet advances once the at-slot steps ran (default true; `false`: an
    /// `advance` step does it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub advance: Option<bool>,
    /// The speed of the approach and retreat where the pattern gives none, mm/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mm_s: Option<f64>,
}

/// A `path` step's table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct PathStep {
    /// A path file, relative to the program's directory.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// The path document itself.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub path: Option<serde_json::Value>,
    /// Speed along the path, mm/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mm_s: Option<f64>,
    /// Acceleration time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_time: Option<String>,
    /// `"constant-period"` or `"bounded-error"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Interpolation period.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period: Option<String>,
    /// Path tolerance, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance_mm: Option<f64>,
    /// The ramps' shape: `"trapezoid"` or `"s-curve"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub profile: Option<String>,
    /// The path's jerk of an S-curve, mm/s^3.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jerk_mm_s3: Option<f64>,
}

/// A `loop` step's table.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct LoopDoc {
    /// The label to jump back to.
    pub to: String,
    /// How many times the steps from `to` to here run in all.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<i64>,
    /// Jump back until this condition holds (or `"stop"`: until a stop is asked for).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub until: Option<String>,
}

impl ProgramDoc {
    /// Reads a program file's text.
    ///
    /// # Errors
    /// The TOML error, with its line.
    pub fn from_toml(text: &str) -> Result<Self, toml::de::Error> {
        toml::from_str(text)
    }
}
