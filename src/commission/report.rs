//! PURE. The commission's report: every check with what it checks, what it saw, its verdict and
//! a hint; the figures measured; the config lines to paste; the counts found and left. Plain
//! data, serialized as the `--json` report (docs/COMMISSION.md, "The report").

use serde::{Deserialize, Serialize};

use super::judge::{RateFit, ScanRate, Spread};

/// The four steps, as `deploy/plc/README.md` names them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Step {
    /// The link: headers, request sizes, round trip, scan time, RUN/PROG.
    Link,
    /// The contract's status block and host word.
    Contract,
    /// The cell's input words copied into the status block (contract version 3).
    Inputs,
    /// Tiny pulse tables, one channel at a time.
    Pulses,
}

impl Step {
    /// The step's name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Link => "link",
            Self::Contract => "contract",
            Self::Inputs => "inputs",
            Self::Pulses => "pulses",
        }
    }
}

/// A check's outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    /// What was checked holds.
    Pass,
    /// It does not.
    Fail,
    /// Not run (the procedure stopped before it, or it does not apply).
    Skip,
}

impl Verdict {
    /// The tag printed before a check.
    #[must_use]
    pub fn tag(self) -> &'static str {
        match self {
            Self::Pass => "pass",
            Self::Fail => "FAIL",
            Self::Skip => "skip",
        }
    }
}

/// One check: `step: check`, on a channel for the pulses step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckReport {
    /// The step.
    pub step: Step,
    /// The check, in `deploy/plc/README.md`'s words (`busy on then off`).
    pub check: String,
    /// The pulse channel (pulses step only).
    pub channel: Option<u8>,
    /// What the check looks at.
    pub checks: String,
    /// What it saw.
    pub saw: String,
    /// Pass, fail or skip.
    pub verdict: Verdict,
    /// What to do about a failure (or a note on a pass).
    pub hint: Option<String>,
    /// Whether this failure stopped the procedure (false: only the config must change, and the
    /// procedure went on).
    pub stopped: bool,
}

impl CheckReport {
    /// `step: check`, with ` (channel c)` for a channel's check.
    #[must_use]
    pub fn title(&self) -> String {
        match self.channel {
            Some(c) => format!("{}: {} (channel {c})", self.step.name(), self.check),
            None => format!("{}: {}", self.step.name(), self.check),
        }
    }
}

/// What one MEWTOCOL-COM header got when tried.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeaderProbe {
    /// `%` or `<`.
    pub header: String,
    /// Whether a 1-word read with it was answered.
    pub answered: bool,
    /// What happened, in words (`answered in 3.1 ms`, `no reply within 300 ms`).
    pub outcome: String,
}

/// The largest read and write one request may hold, as measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RequestSizes {
    /// `%`, `<`, or `modbus`.
    pub framing: String,
    /// Most words one read returned.
    pub read_words: usize,
    /// The smallest read refused, if any was.
    pub read_refused: Option<usize>,
    /// Most words one write carried.
    pub write_words: usize,
    /// The smallest write refused, if any was.
    pub write_refused: Option<usize>,
    /// The longest MEWTOCOL-COM frame exchanged (command or reply), characters.
    pub largest_frame_chars: Option<usize>,
}

/// One channel's counts before and after the commission.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ChannelCounts {
    /// Pulse channel.
    pub channel: u8,
    /// The count found before the pulses step.
    pub found: i32,
    /// The count it was left at (`None` if it could not be read at the end).
    pub left: Option<i32>,
}

/// One channel's timing run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ChannelRate {
    /// Pulse channel.
    pub channel: u8,
    /// The fit.
    pub rate: RateFit,
}

/// The status block's `inputs` as the inputs step found them.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InputsFound {
    /// The input words the config names, in the block's order (`WX0`, `WR10`).
    pub words: Vec<String>,
    /// `inputs[0..3]` as first read.
    pub values: Vec<u16>,
    /// The index of the first R word among them: the one whose relays the checks switch.
    pub relay_word: Option<usize>,
    /// Whether a relay of that word, switched over the link, showed in `inputs[relay_word]`
    /// and went back (`None`: not tried, no R word).
    pub copied: Option<bool>,
}

/// Every figure the commission measured.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Findings {
    /// MEWTOCOL-COM headers tried.
    pub headers: Vec<HeaderProbe>,
    /// The header the commission went on with (MEWTOCOL-COM).
    pub header_used: Option<String>,
    /// Request sizes, per header (MEWTOCOL-COM) or for Modbus.
    pub sizes: Vec<RequestSizes>,
    /// Whether the PLC answered a MEWTOCOL-COM `%` read longer than one frame in several
    /// frames (`None`: not tried, `<` or Modbus).
    #[serde(default)]
    pub multi_frame_reads: Option<bool>,
    /// Round trip of a 1-word read.
    pub round_trip_word: Option<Spread>,
    /// Round trip of a status-block read.
    pub round_trip_status: Option<Spread>,
    /// The heartbeat's rate.
    pub scan: Option<ScanRate>,
    /// The mode read (`RUN` or `PROG`).
    pub mode: Option<String>,
    /// The host word the commission wrote.
    pub host: Option<u16>,
    /// The ready word read.
    pub ready: Option<u16>,
    /// The status block's `inputs` (contract version 3).
    #[serde(default)]
    pub inputs: Option<InputsFound>,
    /// Timing runs, per channel.
    pub rates: Vec<ChannelRate>,
    /// Counts before and after, per channel tested.
    pub counts: Vec<ChannelCounts>,
}

/// The whole commission.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The robot.
    pub robot: String,
    /// The link, in words (`mewtocol over /dev/ttyUSB0, station 1`).
    pub link: String,
    /// Every check, in the order run (skipped ones where they would have run).
    pub checks: Vec<CheckReport>,
    /// The figures.
    pub findings: Findings,
    /// Lines to paste into `linterpd.toml`, with their table headers and comments.
    pub config_lines: Vec<String>,
    /// Why the procedure stopped before its end, if it did.
    pub stopped: Option<String>,
    /// Whether the final stop (`command = 2`) was written and every channel read idle after it.
    pub all_stopped: bool,
    /// Whether every check passed (skips for checks that do not apply aside).
    pub passed: bool,
}

impl Report {
    /// The failed checks.
    pub fn failures(&self) -> impl Iterator<Item = &CheckReport> {
        self.checks.iter().filter(|c| c.verdict == Verdict::Fail)
    }
}
