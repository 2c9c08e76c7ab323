//! The cycle's status as its driver writes it, one method per thing that happens: a step
//! begins, a wait waits, a cycle ends done, the cycle pauses, faults or ends. Anyone reads it
//! as it is published ([`CycleOut`]).

use crate::daemon::shared::CycleOut;
use crate::wire::{CycleState, CycleStatus, StepAt};

/// Moves kept in the status, the newest last.
const MOVES_SHOWN: usize = 10;

/// The status a cycle's driver writes.
pub(super) struct Status(pub(super) CycleOut);

impl Status {
    fn set(&self, f: impl FnOnce(&mut CycleStatus)) {
        self.0.send_modify(|s| {
            if let Some(s) = s.as_mut() {
                f(s);
            }
        });
    }

    /// The cycle runs at step `at`.
    pub(super) fn step(&self, at: StepAt) {
        self.set(|s| {
            s.state = CycleState::Running;
            s.step = Some(at);
            s.reason = None;
            s.stopping = false;
        });
    }

    /// The cycle waits for `until`, `waited_s` so far (`None`: it waits no more).
    pub(super) fn waiting(&self, until: Option<String>, waited_s: Option<f64>) {
        self.set(|s| {
            if until.is_some() {
                s.state = CycleState::Waiting;
            }
            s.waiting_for = until;
            s.waiting_s = waited_s;
        });
    }

    /// The wait has waited `waited_s` so far.
    pub(super) fn waited(&self, waited_s: f64) {
        self.set(|s| s.waiting_s = Some(waited_s));
    }

    /// Cycle `done` ended, after `took_s` of which its waits waited `waited_s`.
    pub(super) fn cycle_done(&self, done: u64, took_s: f64, waited_s: f64) {
        self.set(|s| {
            s.done = done;
            s.last_cycle_s = Some(took_s);
            s.last_cycle_waiting_s = Some(waited_s);
        });
    }

    /// The cycle stands paused, `why`.
    pub(super) fn paused(&self, why: String) {
        self.set(|s| {
            s.state = CycleState::Paused;
            s.reason = Some(why);
        });
    }

    /// The cycle ended, or stands faulted (`state`), `why`.
    pub(super) fn ended(&self, state: CycleState, why: Option<String>) {
        self.set(|s| {
            s.state = state;
            s.reason = why;
            s.waiting_for = None;
            s.waiting_s = None;
            s.stopping = false;
        });
    }

    /// Moves `ids` were started.
    pub(super) fn moves(&self, ids: &[u64]) {
        self.set(|s| {
            s.moves.extend_from_slice(ids);
            let extra = s.moves.len().saturating_sub(MOVES_SHOWN);
            s.moves.drain(..extra);
        });
    }
}
