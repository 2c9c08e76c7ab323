//! PURE. The cell's journal as the daemon writes it and the CLI reads it: one [`Entry`] per
//! thing the cell did (a fault and its reason, a cycle's start and end, a hold, a mode change,
//! a command and who sent it, a pallet's slot placed or the pallet full, a config reload, the
//! daemon's start and stop), one JSON line each (the export format, docs/API.md, "The journal"):
//!
//! ```text
//! {"seq":41,"at":"2026-11-29T08:48:01.123Z","robot":"press-loader","kind":"fault","code":3,
//!  "reason":"stopped from outside (e-stop input)"}
//! ```
//! `seq` counts on across restarts; `at` is the wall time (UTC) the daemon saw it.
//!
//! ```text
//! mod.rs      Entry, Kind (with its data), Source, CycleOutcome; which kinds are made durable
//! time.rs     wall time <-> RFC 3339, spans (`10m`, `8h`)
//! changes.rs  what changed between two states of a robot, as entries (the daemon's follower)
//! counts.rs   production counts (cycles, parts, pallets) per shift
//! ```

mod changes;
mod counts;
mod time;

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::cell::Mode;

pub use changes::{Follow, changes};
pub use counts::{ShiftCounts, per_shift};
pub use time::{TimeError, format_rfc3339, parse_rfc3339, parse_span_ms};

/// One thing the cell did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// Its number: one more than the entry before, across restarts.
    pub seq: u64,
    /// When the daemon saw it: ms since the Unix epoch (written as RFC 3339, UTC).
    #[serde(rename = "at", with = "time::as_rfc3339")]
    pub at_ms: u64,
    /// The robot it is about (`None`: the daemon's own).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot: Option<String>,
    /// What happened.
    #[serde(flatten)]
    pub kind: Kind,
}

/// Who sent a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Source {
    /// The cell face (the line's PLC or HMI).
    Face,
    /// `linterpd`'s command line (on the Unix socket).
    Cli,
    /// Another client of the HTTP API.
    Api,
    /// The operator's console (a logged-in user).
    Console,
}

impl Source {
    /// Its name as the journal writes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Face => "face",
            Self::Cli => "cli",
            Self::Api => "api",
            Self::Console => "console",
        }
    }
}

/// How a cycle ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CycleOutcome {
    /// It ran to its last step.
    Done,
    /// It was stopped before its last step.
    Stopped,
}

/// What happened, with its data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Kind {
    /// The daemon started.
    DaemonStarted {
        /// Its version.
        version: String,
    },
    /// The daemon is stopping.
    DaemonStopping,
    /// A fault: the PLC's fault word (`code`) or a cycle's.
    Fault {
        /// The PLC's fault word, when the PLC latched one.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        code: Option<u16>,
        /// What it means, or why the cycle faulted.
        reason: String,
    },
    /// The PLC's fault word went back to 0.
    FaultCleared {
        /// The word it had.
        code: u16,
    },
    /// The PLC link was lost.
    LinkLost {
        /// The link's or the contract's error.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        error: Option<String>,
    },
    /// The PLC link is up again.
    LinkRestored,
    /// A cycle of a program started.
    CycleStarted {
        /// The program.
        program: String,
        /// Which cycle of the run (from 1).
        cycle: u64,
    },
    /// A cycle ended.
    CycleEnded {
        /// The program.
        program: String,
        /// Which cycle of the run (from 1).
        cycle: u64,
        /// How it ended.
        outcome: CycleOutcome,
        /// How long it took, s (a cycle run to its end).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        cycle_s: Option<f64>,
    },
    /// A cycle was held (paused by request, or a permit dropped).
    Hold {
        /// Why.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reason: Option<String>,
    },
    /// A held cycle goes on.
    Resume,
    /// Who drives the robot changed.
    ModeChanged {
        /// The mode now.
        mode: Mode,
    },
    /// A command, and who sent it where known.
    Command {
        /// Through what.
        source: Source,
        /// Who: `uid 1000` on the Unix socket, the console's user, a TCP client's address.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        who: Option<String>,
        /// What it asked (`POST stop`, `start program 3`).
        action: String,
        /// The HTTP status it was answered with.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        status: Option<u16>,
        /// Why it was refused, when it was.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        refused: Option<String>,
    },
    /// A part placed on a pallet's slot.
    PalletPlaced {
        /// The pallet.
        pallet: String,
        /// The slot, from 1 in fill order.
        slot: u32,
        /// Its layer, from 1.
        layer: u32,
    },
    /// A pallet is full.
    PalletFull {
        /// The pallet.
        pallet: String,
        /// The parts on it.
        parts: u32,
    },
    /// The config was read again and applied (what needs a restart is named too).
    ConfigReloaded {
        /// What changed and took effect (`[section] key, key`).
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        applied: Vec<String>,
        /// What changed and waits for a restart.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        needs_restart: Vec<String>,
    },
    /// The config was read again and refused: the running one is kept.
    ConfigRefused {
        /// Why.
        error: String,
    },
    /// Entries the journal could not take (its queue was full) since the last such entry.
    Dropped {
        /// How many.
        entries: u64,
    },
    /// A torn line (a power cut in the middle of a write) found at the journal's end and
    /// skipped.
    TornLine {
        /// The file.
        file: String,
        /// Its length, bytes.
        bytes: u64,
    },
}

impl Kind {
    /// Its name as the journal writes it (`kind`).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::DaemonStarted { .. } => "daemon-started",
            Self::DaemonStopping => "daemon-stopping",
            Self::Fault { .. } => "fault",
            Self::FaultCleared { .. } => "fault-cleared",
            Self::LinkLost { .. } => "link-lost",
            Self::LinkRestored => "link-restored",
            Self::CycleStarted { .. } => "cycle-started",
            Self::CycleEnded { .. } => "cycle-ended",
            Self::Hold { .. } => "hold",
            Self::Resume => "resume",
            Self::ModeChanged { .. } => "mode-changed",
            Self::Command { .. } => "command",
            Self::PalletPlaced { .. } => "pallet-placed",
            Self::PalletFull { .. } => "pallet-full",
            Self::ConfigReloaded { .. } => "config-reloaded",
            Self::ConfigRefused { .. } => "config-refused",
            Self::Dropped { .. } => "dropped",
            Self::TornLine { .. } => "torn-line",
        }
    }

    /// Whether the journal makes it durable (fsync) at once: faults, cycle ends, pallets, mode
    /// changes, reloads, the daemon's start and stop, the journal's own losses. The others are
    /// written with the next durable one, or within a second.
    #[must_use]
    pub fn durable(&self) -> bool {
        !matches!(
            self,
            Self::CycleStarted { .. }
                | Self::Hold { .. }
                | Self::Resume
                | Self::Command { .. }
                | Self::LinkLost { .. }
                | Self::LinkRestored
        )
    }
}

impl Entry {
    /// The entry as one JSON line (no line break).
    #[must_use]
    pub fn to_line(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// An entry from one line of the journal.
    pub fn from_line(line: &str) -> Result<Self, serde_json::Error> {
        serde_json::from_str(line)
    }
}

/// The entry as a person reads it: `2026-11-29T08:48:01.123Z #41 press-loader fault 3: ...`.
impl fmt::Display for Entry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} #{}", format_rfc3339(self.at_ms), self.seq)?;
        if let Some(robot) = &self.robot {
            write!(f, " {robot}")?;
        }
        write!(f, " {}", self.kind.name())?;
        let detail = self.kind.detail();
        if detail.is_empty() {
            Ok(())
        } else {
            write!(f, ": {detail}")
        }
    }
}

impl Kind {
    /// Its data in a few words, for the human line.
    fn detail(&self) -> String {
        match self {
            Self::DaemonStarted { version } => format!("version {version}"),
            Self::Fault { code, reason } => match code {
                Some(code) => format!("code {code}, {reason}"),
                None => reason.clone(),
            },
            Self::FaultCleared { code } => format!("code {code}"),
            Self::LinkLost { error } => error.clone().unwrap_or_default(),
            Self::CycleStarted { program, cycle } => format!("{program} cycle {cycle}"),
            Self::CycleEnded {
                program,
                cycle,
                outcome,
                cycle_s,
            } => ended(program, *cycle, *outcome, *cycle_s),
            Self::Hold { reason } => reason.clone().unwrap_or_default(),
            Self::ModeChanged { mode } => mode.to_string(),
            Self::Command { .. } => self.command_detail(),
            Self::PalletPlaced {
                pallet,
                slot,
                layer,
            } => format!("{pallet} slot {slot}, layer {layer}"),
            Self::PalletFull { pallet, parts } => format!("{pallet}, {parts} parts"),
            Self::ConfigReloaded {
                applied,
                needs_restart,
            } => reloaded(applied, needs_restart),
            Self::ConfigRefused { error } => error.clone(),
            Self::Dropped { entries } => format!("{entries} entries lost (queue full)"),
            Self::TornLine { file, bytes } => format!("{bytes} bytes at the end of {file}"),
            Self::DaemonStopping | Self::LinkRestored | Self::Resume => String::new(),
        }
    }

    fn command_detail(&self) -> String {
        let Self::Command {
            source,
            who,
            action,
            status,
            refused,
        } = self
        else {
            return String::new();
        };
        let mut text = format!("{action} from {}", source.name());
        if let Some(who) = who {
            text.push_str(&format!(" ({who})"));
        }
        if let Some(status) = status {
            text.push_str(&format!(" -> {status}"));
        }
        if let Some(refused) = refused {
            text.push_str(&format!(", refused: {refused}"));
        }
        text
    }
}

fn ended(program: &str, cycle: u64, outcome: CycleOutcome, cycle_s: Option<f64>) -> String {
    let outcome = match outcome {
        CycleOutcome::Done => "done",
        CycleOutcome::Stopped => "stopped",
    };
    match cycle_s {
        Some(s) => format!("{program} cycle {cycle} {outcome} in {s:.2} s"),
        None => format!("{program} cycle {cycle} {outcome}"),
    }
}

fn reloaded(applied: &[String], needs_restart: &[String]) -> String {
    let mut parts = Vec::new();
    if !applied.is_empty() {
        parts.push(format!("applied {}", applied.join("; ")));
    }
    if !needs_restart.is_empty() {
        parts.push(format!("needs a restart: {}", needs_restart.join("; ")));
    }
    if parts.is_empty() {
        "nothing changed".to_owned()
    } else {
        parts.join("; ")
    }
}

#[cfg(test)]
mod tests;
