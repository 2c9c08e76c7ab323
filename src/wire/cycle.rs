//! What a cycle shows: its state, where it stands, what it waits for and since when, how many
//! cycles it has done and how long they took. The API writes it and the CLI reads it.

use serde::{Deserialize, Serialize};

/// Where a cycle stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CycleState {
    /// Running a step.
    Running,
    /// Waiting on the cell's inputs (a `wait` step).
    Waiting,
    /// Paused: by request (at the end of a step), or held by the PLC (a permit dropped).
    Paused,
    /// Faulted: the robot stopped; it resumes only after `clear-fault` and `resume`.
    Faulted,
    /// Stopped by request.
    Stopped,
    /// Every cycle asked for is done.
    Done,
}

impl CycleState {
    /// Whether the cycle has ended (a fresh `run` may start another).
    #[must_use]
    pub fn is_final(self) -> bool {
        matches!(self, Self::Stopped | Self::Done)
    }
}

/// One step as the status names it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct StepAt {
    /// The program the step is in (the one run, or one it calls).
    pub program: String,
    /// The step's number in that program, from 1.
    pub step: usize,
    /// Its label, if it has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub label: Option<String>,
    /// What the step does, in a few words (`move to @in-press`, `wait for press_open (X5)`).
    pub does: String,
    /// Where it was called from (`main step 2`), outermost first, when in a called program.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub called_from: Vec<String>,
}

/// A cycle's status.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CycleStatus {
    /// The program run.
    pub program: String,
    /// Its state.
    pub state: CycleState,
    /// The step running, waiting, paused or faulted in (`None` before the first, after the last).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub step: Option<StepAt>,
    /// Cycles done.
    pub done: u64,
    /// Cycles asked for (`None`: until stopped).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u64>,
    /// What it waits for, while waiting.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waiting_for: Option<String>,
    /// For how long it has waited, s, while waiting.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waiting_s: Option<f64>,
    /// Why it is paused, faulted or stopped.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// The last cycle's time, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_cycle_s: Option<f64>,
    /// Of it, the time its waits waited, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_cycle_waiting_s: Option<f64>,
    /// The moves this cycle started, the last few (the newest last).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub moves: Vec<u64>,
    /// A stop asked for, to take effect at the end of the current step.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub stopping: bool,
}

impl CycleStatus {
    /// A cycle of `program` about to run its first step.
    #[must_use]
    pub fn starting(program: &str, count: Option<u64>) -> Self {
        Self {
            program: program.to_owned(),
            state: CycleState::Running,
            step: None,
            done: 0,
            count,
            waiting_for: None,
            waiting_s: None,
            reason: None,
            last_cycle_s: None,
            last_cycle_waiting_s: None,
            moves: Vec::new(),
            stopping: false,
        }
    }
}
