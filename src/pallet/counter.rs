//! PURE. A pallet's counter: the slot to fill next, the slot in progress and how far its place
//! has come, whether the pallet is full, and the parts and pallets done. The daemon keeps one
//! per pallet in its state directory and writes it at every change, before the cycle takes its
//! next step; this module decides what each change is and what a restart means.
//!
//! ```text
//!           begin                arrived               advance
//!   Ready ----------> Moving(i) ----------> AtSlot(i) ----------> Ready (index i+1, parts+1)
//!                        |  begin again (a resumed step: nothing was placed) -> Moving(i)
//!                        |
//!   a restart with a slot in progress, or a new begin while AtSlot(i):
//!                     Unsure(i): the cycle refuses to place on this pallet until the operator
//!                     chooses redo (Ready at i) or go on (Ready at i+1, the part counted)
//! ```
//!
//! The last slot's advance makes the pallet full; the cell's `when_full` runs and
//! [`Counter::restart`] begins the next pallet at slot 0 (a pallet counted).

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// How far the place at the slot in progress has come.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Phase {
    /// The robot is on its way to the slot: nothing has been placed.
    Moving,
    /// The robot reached the slot and the at-slot steps (the gripper) began: the part may be
    /// placed.
    AtSlot,
    /// A restart came, or a place began again, with the slot at the slot: whether the part was
    /// placed is for the operator to say.
    Unsure,
}

/// The slot in progress and its phase.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InProgress {
    /// The slot, in fill order from 0.
    pub slot: usize,
    /// How far its place has come.
    pub phase: Phase,
}

/// One pallet's counter, as kept on disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Counter {
    /// The slot to fill next, in fill order from 0.
    pub index: usize,
    /// The slot whose place began and has not ended done.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub in_progress: Option<InProgress>,
    /// Every slot is filled: the cell's `when_full` runs before the next slot.
    #[serde(default)]
    pub full: bool,
    /// Parts placed (or picked) in all.
    #[serde(default)]
    pub parts: u64,
    /// Pallets completed in all.
    #[serde(default)]
    pub pallets: u64,
}

/// The operator's choice for a slot whose place was interrupted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Choice {
    /// The part was not placed: place at the same slot again.
    Redo,
    /// The part was placed: count it and go on at the next slot.
    GoOn,
}

/// Why a counter refuses a change.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CounterError {
    /// A place begins while the last place's slot waits for the operator's choice.
    #[error(
        "pallet {pallet:?}: the place at slot {slot} was interrupted with the part perhaps at the \
         slot; choose redo (place at slot {slot} again) or go on (slot {slot} is placed, go on at \
         {next}) before the cycle places on it"
    )]
    Unsure {
        /// The pallet.
        pallet: String,
        /// The slot in progress.
        slot: usize,
        /// The slot go on goes on at.
        next: usize,
    },
    /// A place begins on a full pallet.
    #[error("pallet {pallet:?} is full ({len} slots): its when_full runs, or reset it")]
    Full {
        /// The pallet.
        pallet: String,
        /// Its slots.
        len: usize,
    },
    /// A step that needs a slot in progress (arrived, advance) without one.
    #[error("pallet {pallet:?} has no slot in progress to {what}")]
    NoSlot {
        /// The pallet.
        pallet: String,
        /// What was asked.
        what: &'static str,
    },
    /// A choice with no interrupted slot to choose for.
    #[error("pallet {pallet:?} has no interrupted slot to redo or go on from")]
    NothingToChoose {
        /// The pallet.
        pallet: String,
    },
    /// An index set past the pallet's slots.
    #[error(
        "pallet {pallet:?}: index {index} is past its last slot ({last}): 0 to {last} is the \
         slot to fill next, {} marks the pallet full",
        .last + 1
    )]
    PastEnd {
        /// The pallet.
        pallet: String,
        /// The index asked.
        index: usize,
        /// Its last slot.
        last: usize,
    },
}

impl Counter {
    /// The counter as a restart finds it: a slot in progress becomes unsure (the robot may have
    /// placed the part before the power went), whatever phase was written.
    #[must_use]
    pub fn restored(self) -> Self {
        let in_progress = self.in_progress.map(|p| InProgress {
            slot: p.slot,
            phase: Phase::Unsure,
        });
        Self {
            in_progress,
            ..self
        }
    }

    /// Whether a place may begin, and if so the slot: refused while a slot is unsure, or the
    /// pallet full.
    ///
    /// # Errors
    /// [`CounterError::Unsure`] or [`CounterError::Full`].
    pub fn begin(&mut self, pallet: &str, len: usize) -> Result<usize, CounterError> {
        if self.full || self.index >= len {
            return Err(CounterError::Full {
                pallet: pallet.to_owned(),
                len,
            });
        }
        match self.in_progress {
            Some(p) if p.phase != Phase::Moving => {
                self.in_progress = Some(InProgress {
                    slot: p.slot,
                    phase: Phase::Unsure,
                });
                Err(unsure(pallet, p.slot, len))
            }
            _ => {
                self.in_progress = Some(InProgress {
                    slot: self.index,
                    phase: Phase::Moving,
                });
                Ok(self.index)
            }
        }
    }

    /// The robot is at the slot in progress: the at-slot steps begin.
    ///
    /// # Errors
    /// [`CounterError::NoSlot`] when no place is under way.
    pub fn arrived(&mut self, pallet: &str) -> Result<usize, CounterError> {
        match &mut self.in_progress {
            Some(p) if p.phase == Phase::Moving => {
                p.phase = Phase::AtSlot;
                Ok(p.slot)
            }
            _ => Err(CounterError::NoSlot {
                pallet: pallet.to_owned(),
                what: "arrive at",
            }),
        }
    }

    /// The place at the slot in progress ended done (or, `in_progress` none, an explicit
    /// advance of the next slot): the index moves on, the part is counted, the pallet is full
    /// after its last slot. Returns the slot that was filled.
    pub fn advance(&mut self, len: usize) -> usize {
        let slot = self.in_progress.take().map_or(self.index, |p| p.slot);
        self.index = (slot + 1).min(len);
        self.parts += 1;
        self.full = self.index >= len;
        slot
    }

    /// A place step's own advance: [`Self::advance`], only from the slot the robot reached
    /// since the place began (`AtSlot`). Refused while the slot is unsure (a restart of the PC or
    /// the PLC came: whether the part is there is the operator's to say), or with no slot reached
    /// (the place resumed after the operator chose: the part it held was placed or let go, and a
    /// new one is picked by a fresh run). Returns the slot filled.
    ///
    /// # Errors
    /// [`CounterError::Unsure`], or [`CounterError::NoSlot`] with no slot reached.
    pub fn slot_done(&mut self, pallet: &str, len: usize) -> Result<usize, CounterError> {
        match self.in_progress {
            Some(p) if p.phase == Phase::AtSlot => Ok(self.advance(len)),
            Some(p) if p.phase == Phase::Unsure => Err(unsure(pallet, p.slot, len)),
            _ => Err(CounterError::NoSlot {
                pallet: pallet.to_owned(),
                what: "count as placed (none was reached since its place began)",
            }),
        }
    }

    /// An `advance` step's: [`Self::advance`], refused while the slot in progress is unsure.
    ///
    /// # Errors
    /// [`CounterError::Unsure`].
    pub fn advance_step(&mut self, pallet: &str, len: usize) -> Result<usize, CounterError> {
        match self.needs_choice() {
            Some(slot) => Err(unsure(pallet, slot, len)),
            None => Ok(self.advance(len)),
        }
    }

    /// The operator's choice for the unsure slot.
    ///
    /// # Errors
    /// [`CounterError::NothingToChoose`] when no slot is in progress.
    pub fn choose(&mut self, pallet: &str, choice: Choice, len: usize) -> Result<(), CounterError> {
        if self.in_progress.is_none() {
            return Err(CounterError::NothingToChoose {
                pallet: pallet.to_owned(),
            });
        }
        match choice {
            Choice::Redo => {
                let slot = self.in_progress.take().map_or(self.index, |p| p.slot);
                self.index = slot;
                self.full = false;
            }
            Choice::GoOn => {
                self.advance(len);
            }
        }
        Ok(())
    }

    /// The full pallet was changed: the next begins at slot 0, a pallet counted.
    pub fn restart(&mut self) {
        if self.full {
            self.pallets += 1;
        }
        *self = Self {
            pallets: self.pallets,
            parts: self.parts,
            ..Self::default()
        };
    }

    /// The operator sets the next slot (a pallet changed by hand, a partly built pallet put
    /// in): the slot in progress is forgotten; the counts stay.
    ///
    /// # Errors
    /// [`CounterError::PastEnd`] past the last slot (`len` is the pallet full).
    pub fn set(&mut self, pallet: &str, index: usize, len: usize) -> Result<(), CounterError> {
        if index > len {
            return Err(CounterError::PastEnd {
                pallet: pallet.to_owned(),
                index,
                last: len.saturating_sub(1),
            });
        }
        self.index = index;
        self.in_progress = None;
        self.full = index == len;
        Ok(())
    }

    /// The layer of the slot to fill next, from 0, given each slot's layer.
    #[must_use]
    pub fn layer(&self, layers: &[usize]) -> usize {
        layers
            .get(self.index)
            .or(layers.last())
            .copied()
            .unwrap_or(0)
    }

    /// Whether a place may begin without the operator.
    #[must_use]
    pub fn needs_choice(&self) -> Option<usize> {
        self.in_progress
            .filter(|p| p.phase == Phase::Unsure)
            .map(|p| p.slot)
    }
}

fn unsure(pallet: &str, slot: usize, len: usize) -> CounterError {
    CounterError::Unsure {
        pallet: pallet.to_owned(),
        slot,
        next: (slot + 1).min(len),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_place_done_advances_and_the_last_slot_makes_the_pallet_full() {
        let mut c = Counter::default();
        for slot in 0..3 {
            assert_eq!(c.begin("out", 3), Ok(slot));
            assert_eq!(c.arrived("out"), Ok(slot));
            assert_eq!(c.advance(3), slot);
        }
        assert!(c.full && c.index == 3 && c.parts == 3 && c.in_progress.is_none());
        assert!(matches!(c.begin("out", 3), Err(CounterError::Full { .. })));
        c.restart();
        assert_eq!((c.index, c.full, c.parts, c.pallets), (0, false, 3, 1));
    }

    #[test]
    fn a_place_begun_again_before_the_slot_is_redone_without_asking() {
        let mut c = Counter::default();
        c.begin("out", 3).unwrap();
        // The step faulted on its way and was resumed: nothing was placed.
        assert_eq!(c.begin("out", 3), Ok(0));
        assert_eq!(c.parts, 0);
    }

    #[test]
    fn a_place_begun_again_after_the_slot_asks_the_operator() {
        let mut c = Counter::default();
        c.begin("out", 3).unwrap();
        c.arrived("out").unwrap();
        let e = c.begin("out", 3).unwrap_err();
        assert_eq!(
            e,
            CounterError::Unsure {
                pallet: "out".into(),
                slot: 0,
                next: 1
            }
        );
        assert!(e.to_string().contains("choose redo"), "{e}");
        assert_eq!(c.needs_choice(), Some(0));
        // It stays refused until the operator chooses.
        assert!(c.begin("out", 3).is_err());
        c.choose("out", Choice::GoOn, 3).unwrap();
        assert_eq!((c.index, c.parts, c.needs_choice()), (1, 1, None));
        assert_eq!(c.begin("out", 3), Ok(1));
    }

    #[test]
    fn a_restart_with_a_slot_in_progress_is_unsure_whatever_its_phase() {
        for phase in [Phase::Moving, Phase::AtSlot] {
            let c = Counter {
                index: 4,
                in_progress: Some(InProgress { slot: 4, phase }),
                ..Counter::default()
            }
            .restored();
            assert_eq!(c.needs_choice(), Some(4));
            let mut redo = c;
            assert!(redo.begin("out", 24).is_err());
            redo.choose("out", Choice::Redo, 24).unwrap();
            assert_eq!((redo.index, redo.parts), (4, 0));
            assert_eq!(redo.begin("out", 24), Ok(4));
        }
        // Nothing in progress: nothing to ask.
        let c = Counter {
            index: 4,
            ..Counter::default()
        }
        .restored();
        assert_eq!(c.needs_choice(), None);
    }

    /// A place's own advance counts only a slot the robot reached since its place began: not
    /// one unsure (a restart came), not one the operator chose for (the place resumed after the
    /// choice holds no part), not one still on its way.
    #[test]
    fn a_places_advance_counts_only_a_slot_reached_and_never_one_unsure_or_chosen_for() {
        let mut c = Counter::default();
        c.begin("out", 3).unwrap();
        assert!(matches!(
            c.slot_done("out", 3),
            Err(CounterError::NoSlot { .. })
        ));
        c.arrived("out").unwrap();
        let mut unsure = c.restored();
        assert!(matches!(
            unsure.slot_done("out", 3),
            Err(CounterError::Unsure { slot: 0, .. })
        ));
        assert!(unsure.advance_step("out", 3).is_err());
        unsure.choose("out", Choice::GoOn, 3).unwrap();
        assert!(unsure.slot_done("out", 3).is_err());
        assert_eq!((unsure.index, unsure.parts), (1, 1));
        assert_eq!(c.slot_done("out", 3), Ok(0));
        assert_eq!((c.index, c.parts, c.in_progress), (1, 1, None));
    }

    #[test]
    fn going_on_from_the_last_slot_makes_the_pallet_full() {
        let mut c = Counter {
            index: 2,
            in_progress: Some(InProgress {
                slot: 2,
                phase: Phase::Unsure,
            }),
            ..Counter::default()
        };
        c.choose("out", Choice::GoOn, 3).unwrap();
        assert!(c.full);
        assert!(c.choose("out", Choice::Redo, 3).is_err());
    }

    #[test]
    fn set_refuses_past_the_end_and_forgets_the_slot_in_progress() {
        let mut c = Counter::default();
        c.begin("out", 24).unwrap();
        assert!(matches!(
            c.set("out", 25, 24),
            Err(CounterError::PastEnd {
                index: 25,
                last: 23,
                ..
            })
        ));
        c.set("out", 24, 24).unwrap();
        assert!(c.full && c.in_progress.is_none());
        c.set("out", 5, 24).unwrap();
        assert_eq!((c.index, c.full), (5, false));
    }

    #[test]
    fn the_file_form_round_trips() {
        let c = Counter {
            index: 7,
            in_progress: Some(InProgress {
                slot: 7,
                phase: Phase::AtSlot,
            }),
            full: false,
            parts: 31,
            pallets: 1,
        };
        let text = serde_json::to_string(&c).unwrap();
        assert!(text.contains("\"at-slot\""), "{text}");
        assert_eq!(serde_json::from_str::<Counter>(&text).unwrap(), c);
    }
}
