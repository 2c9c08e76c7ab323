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
//! path_accel = "3000mm/s2"       # optional, on a run's first move: its corners' acceleration
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

use serde::Deserialize;

use crate::order::motion::{Table, keys, read_table};
use crate::order::{MoveOrder, OrderMotion};
use serde::de::MapAccess;

/// A cycle program as written.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ProgramDoc {
    /// The number the cell selects it by (1..=255).
    pub number: Option<i64>,
    /// What it does, for people.
    pub description: Option<String>,
    /// Its steps, in order.
    pub step: Vec<StepDoc>,
}

/// One step as written: exactly one action key, and the keys that go with it (as the file
/// writes it; [`super::step::Step`] is the step the check reads).
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct StepDoc {
    /// A name other steps jump to.
    pub label: Option<String>,
    /// A move (a move order's keys).
    #[serde(rename = "move")]
    pub move_: Option<MoveOrder>,
    /// A path: `file` (relative to the program's directory) or `path` (the document), and the
    /// motion keys of a path order.
    pub path: Option<PathStep>,
    /// A condition to wait for.
    pub wait: Option<String>,
    /// How long a wait may take, e.g. `"30s"`.
    pub timeout: Option<String>,
    /// What a wait that times out does: `"fault"` (the default) or a label to go on from.
    pub on_timeout: Option<String>,
    /// Outputs to write: a Y or R bit (or its signal name) = true/false, a DT word = a number.
    pub set: Option<BTreeMap<String, toml::Value>>,
    /// A pause, e.g. `"200ms"`.
    pub dwell: Option<String>,
    /// Another program to run here, by name.
    pub call: Option<String>,
    /// A jump back to a label.
    #[serde(rename = "loop")]
    pub loop_: Option<LoopDoc>,
    /// A move's or path's interlock, enforced by the PLC.
    pub permit: Option<String>,
    /// A move's end passed without stopping, rounded into the next move step within this
    /// distance of it, mm (the moves run as one path: `super::blend`).
    pub blend_mm: Option<f64>,
    /// On the first move of a blended run: the largest acceleration across its path, the
    /// corners' (a path file's `path_accel`, e.g. `"5000mm/s2"`; by default the run's speed over
    /// its acceleration time).
    pub path_accel: Option<serde_json::Value>,
    /// A place at a pallet's current slot.
    pub place: Option<PalletStepDoc>,
    /// A pick from a pallet's current slot (depalletising: the same route, the same counter).
    pub pick: Option<PalletStepDoc>,
    /// A pallet advanced to its next slot (after a place written with `advance = false`).
    pub advance: Option<String>,
}

/// A `place` or `pick` step's table.
#[derive(Debug, Clone, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct PalletStepDoc {
    /// The pallet (a pattern of the robot's `[robots.NAME.pallets.NAME]`).
    pub pallet: String,
    /// The steps run with the robot at the slot (the gripper's `set`, `wait` and `dwell`).
    #[serde(default)]
    pub at_slot: Vec<StepDoc>,
    /// Whether the pallet advances once the at-slot steps ran (default true; `false`: an
    /// `advance` step does it).
    pub advance: Option<bool>,
    /// The speed of the approach and retreat where the pattern gives none, mm/s.
    pub speed_mm_s: Option<f64>,
}

/// A `path` step's table: the path (`file` or `path`) and the motion keys of a path order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PathStep {
    /// A path file, relative to the program's directory.
    pub file: Option<String>,
    /// The path document itself.
    pub path: Option<serde_json::Value>,
    /// The motion keys, as for a path order.
    pub motion: OrderMotion,
}

impl<'de> Deserialize<'de> for PathStep {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        read_table(d)
    }
}

impl Table for PathStep {
    const NAME: &'static str = "PathStep";
    const KEYS: &'static [&'static str] = &keys::<9>(&["file", "path"], &[]);

    fn read<'de, A: MapAccess<'de>>(&mut self, key: &str, map: &mut A) -> Result<(), A::Error> {
        match key {
            "file" => self.file = map.next_value()?,
            "path" => self.path = map.next_value()?,
            motion => self.motion.read(motion, map)?,
        }
        Ok(())
    }
}

/// A `loop` step's table.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct LoopDoc {
    /// The label to jump back to.
    pub to: String,
    /// How many times the steps from `to` to here run in all.
    pub count: Option<i64>,
    /// Jump back until this condition holds (or `"stop"`: until a stop is asked for).
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
