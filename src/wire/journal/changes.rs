//! What changed between two states of a robot, as journal entries: the daemon's follower feeds
//! [`Follow`] every state the robot publishes and journals what comes out. Pure: no clock, no
//! IO; each test is a list of states.
//!
//! ```text
//!  link    up -> down: link-lost (its error); down -> up after a loss: link-restored
//!  fault   the PLC's fault word, compared while the link is up: 0 -> n fault (its meaning),
//!          n -> 0 fault-cleared, n -> m fault
//!  cycle   a new run: cycle-started 1; each cycle done: cycle-ended n (done, its time) and,
//!          unless the run is done, cycle-started n + 1; stopped: cycle-ended (stopped);
//!          paused: hold (why); paused -> running or waiting: resume; faulted: fault (why)
//!  mode    changed: mode-changed
//!  face    a command bit's rising edge (enable: either edge): command from the face
//! ```

use super::{CycleOutcome, Kind, Source};
use crate::cell::Mode;
use crate::cell::face::bit;
use crate::contract::Fault;
use crate::wire::{CycleState, CycleStatus, FaceState, RobotState};

/// What the follower remembers of the states it has seen.
#[derive(Debug, Clone, Default)]
pub struct Follow {
    /// Whether the link was up, once seen.
    link_up: Option<bool>,
    /// Whether the link was lost since it was first up.
    lost: bool,
    /// The fault word as last read with the link up (0: none), once read.
    fault: Option<u16>,
    /// The cycle as last seen.
    cycle: Option<CycleStatus>,
    /// The mode, once seen.
    mode: Option<Mode>,
    /// The face's command word as last taken, and its refusal.
    face: Option<FaceState>,
}

/// The entries between `before` and `after` for a follower that saw only these two states.
#[must_use]
pub fn changes(before: &RobotState, after: &RobotState) -> Vec<Kind> {
    let mut follow = Follow::default();
    let _ = follow.observe(before);
    follow.observe(after)
}

impl Follow {
    /// Takes the next state; returns what changed since the last, in order.
    pub fn observe(&mut self, state: &RobotState) -> Vec<Kind> {
        let mut out = Vec::new();
        self.link(state, &mut out);
        self.fault(state, &mut out);
        self.mode(state.mode, &mut out);
        self.face(state.face.as_ref(), &mut out);
        if let Some(after) = &state.cycle {
            cycle(self.cycle.as_ref(), after, &mut out);
        }
        self.cycle.clone_from(&state.cycle);
        out
    }

    fn link(&mut self, state: &RobotState, out: &mut Vec<Kind>) {
        let up = state.link.connected;
        match (self.link_up, up) {
            (Some(true), false) => {
                self.lost = true;
                out.push(Kind::LinkLost {
                    error: state.link.error.clone(),
                });
            }
            (Some(false), true) if self.lost => out.push(Kind::LinkRestored),
            _ => {}
        }
        self.link_up = Some(up);
    }

    fn fault(&mut self, state: &RobotState, out: &mut Vec<Kind>) {
        if !state.link.connected || state.state.is_none() {
            return;
        }
        let now = state.fault.unwrap_or(0);
        let before = self.fault.replace(now).unwrap_or(0);
        if now == before {
            return;
        }
        if now == 0 {
            out.push(Kind::FaultCleared { code: before });
        } else {
            out.push(Kind::Fault {
                code: Some(now),
                reason: Fault::from_word(now).map_or_else(
                    |_| format!("fault word {now}, unknown to contract version 3"),
                    |f| f.meaning().to_owned(),
                ),
            });
        }
    }

    fn mode(&mut self, mode: Mode, out: &mut Vec<Kind>) {
        if self.mode.replace(mode).is_some_and(|m| m != mode) {
            out.push(Kind::ModeChanged { mode });
        }
    }

    fn face(&mut self, face: Option<&FaceState>, out: &mut Vec<Kind>) {
        let Some(after) = face else {
            return;
        };
        // The first word seen is the baseline, as it is for the face itself.
        let Some(before) = self.face.replace(after.clone()) else {
            return;
        };
        let (was, refused_before) = (before.commands, before.refused);
        let refused = after
            .refused
            .as_ref()
            .filter(|r| Some(*r) != refused_before.as_ref())
            .map(|r| format!("{} ({})", r.meaning, r.code));
        let actions = face_actions(was, after);
        let last = actions.len().saturating_sub(1);
        for (i, action) in actions.into_iter().enumerate() {
            out.push(Kind::Command {
                source: Source::Face,
                who: None,
                action,
                status: None,
                refused: if i == last { refused.clone() } else { None },
            });
        }
    }
}

/// The face's commands between two command words: rising edges (enable: either edge).
fn face_actions(was: u16, after: &FaceState) -> Vec<String> {
    const EDGES: [(u16, &str); 7] = [
        (bit::STROBE, "select"),
        (bit::START, "start"),
        (bit::STOP, "stop"),
        (bit::PAUSE, "pause"),
        (bit::RESET, "reset"),
        (bit::HOME, "home"),
        (bit::STOP_NOW, "stop-now"),
    ];
    let now = after.commands;
    let rising = now & !was;
    let program = match &after.program_name {
        Some(name) => format!(" program {} ({name})", after.program),
        None => format!(" program {}", after.program),
    };
    let mut actions: Vec<String> = EDGES
        .iter()
        .filter(|(b, _)| rising & b != 0)
        .map(|(b, name)| {
            let with_program = *b == bit::STROBE || *b == bit::START;
            format!("{name}{}", if with_program { program.as_str() } else { "" })
        })
        .collect();
    if (now ^ was) & bit::ENABLE != 0 {
        let level = if now & bit::ENABLE != 0 { "on" } else { "off" };
        actions.push(format!("enable {level}"));
    }
    actions
}

/// Whether `after` is another run than `before`.
fn new_run(before: Option<&CycleStatus>, after: &CycleStatus) -> bool {
    before.is_none_or(|b| {
        b.state.is_final() && b != after || b.program != after.program || after.done < b.done
    })
}

/// A cycle's entries between two of its statuses.
fn cycle(before: Option<&CycleStatus>, after: &CycleStatus, out: &mut Vec<Kind>) {
    let fresh = new_run(before, after);
    let program = &after.program;
    let started = |cycle| Kind::CycleStarted {
        program: program.clone(),
        cycle,
    };
    let base = if fresh {
        out.push(started(1));
        0
    } else {
        before.map_or(0, |b| b.done)
    };
    for n in base + 1..=after.done {
        out.push(Kind::CycleEnded {
            program: program.clone(),
            cycle: n,
            outcome: CycleOutcome::Done,
            cycle_s: (n == after.done).then_some(after.last_cycle_s).flatten(),
        });
        if n < after.done || after.state != CycleState::Done {
            out.push(started(n + 1));
        }
    }
    let was = if fresh { None } else { before.map(|b| b.state) };
    state_entries(was, after, out);
}

/// Hold, resume, fault and stop: a change of the cycle's state.
fn state_entries(was: Option<CycleState>, after: &CycleStatus, out: &mut Vec<Kind>) {
    if was == Some(after.state) {
        return;
    }
    match after.state {
        CycleState::Paused => out.push(Kind::Hold {
            reason: after.reason.clone(),
        }),
        CycleState::Running | CycleState::Waiting if was == Some(CycleState::Paused) => {
            out.push(Kind::Resume);
        }
        CycleState::Faulted => out.push(Kind::Fault {
            code: None,
            reason: cycle_fault(after),
        }),
        CycleState::Stopped => out.push(Kind::CycleEnded {
            program: after.program.clone(),
            cycle: after.done + 1,
            outcome: CycleOutcome::Stopped,
            cycle_s: None,
        }),
        CycleState::Running | CycleState::Waiting | CycleState::Done => {}
    }
}

/// Why a cycle faulted, with where: `cycle main step 3 (move to @in-press): ...`.
fn cycle_fault(status: &CycleStatus) -> String {
    let at = status
        .step
        .as_ref()
        .map_or_else(String::new, |s| format!(" step {} ({})", s.step, s.does));
    let why = status.reason.as_deref().unwrap_or("no reason given");
    format!("cycle {}{at}: {why}", status.program)
}

#[cfg(test)]
mod tests;
