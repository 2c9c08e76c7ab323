//! A robot's pallets as the operator sees them (`GET /v1/robots/{name}/pallets`, `linterpd
//! pallet status`, the cell face's pallet words): each pallet's slots and layers, the slot to
//! fill next, the slot in progress and whether the operator must choose, full, and the parts
//! and pallets done.
//!
//! ```json
//! {"pallets": [{"name": "out", "slots": 96, "layers": 4, "index": 7, "layer": 0,
//!               "in_progress": {"slot": 7, "phase": "unsure", "unsure": true},
//!               "full": false, "parts": 31, "pallets": 1, "known": true}],
//!  "warning": "the pallets file ... is corrupt: ...; it was kept aside as ..."}
//! ```

use serde::{Deserialize, Serialize};

use crate::pallet::Counter;
use crate::pallet::counter::Phase;

/// The slot whose place began and has not ended done.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SlotInProgress {
    /// The slot, in fill order from 0.
    pub slot: usize,
    /// How far its place came: `moving`, `at-slot`, or `unsure`.
    pub phase: Phase,
    /// The cycle will not place on this pallet until the operator chooses redo or go on.
    pub unsure: bool,
}

/// One pallet's count.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PalletStatus {
    /// The pallet (`[robots.ROBOT.pallets.NAME]`).
    pub name: String,
    /// Its slots.
    pub slots: usize,
    /// Its layers.
    pub layers: usize,
    /// The slot to fill next, in fill order from 0: also the slots filled (`slots` when full).
    pub index: usize,
    /// The layer of the slot to fill next, from 0.
    pub layer: usize,
    /// The slot in progress, if a place began and has not ended done.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub in_progress: Option<SlotInProgress>,
    /// Every slot is filled.
    pub full: bool,
    /// Parts placed (or picked) in all.
    pub parts: u64,
    /// Pallets completed in all.
    pub pallets: u64,
    /// `false` when its count was lost with the pallets file (`warning` says how): the cycle
    /// does not place on it until the operator sets it.
    pub known: bool,
}

impl PalletStatus {
    /// Pallet `name`'s status from its counter and each slot's layer (in fill order).
    #[must_use]
    pub fn new(name: &str, counter: &Counter, slot_layers: &[usize], known: bool) -> Self {
        Self {
            name: name.to_owned(),
            slots: slot_layers.len(),
            layers: slot_layers.iter().max().map_or(0, |l| l + 1),
            index: counter.index,
            layer: counter.layer(slot_layers),
            in_progress: counter.in_progress.map(|p| SlotInProgress {
                slot: p.slot,
                phase: p.phase,
                unsure: p.phase == Phase::Unsure,
            }),
            full: counter.full,
            parts: counter.parts,
            pallets: counter.pallets,
            known,
        }
    }

    /// The slot waiting for the operator's choice (redo or go on), if one is.
    #[must_use]
    pub fn unsure(&self) -> Option<usize> {
        self.in_progress.filter(|p| p.unsure).map(|p| p.slot)
    }
}

/// Every pallet of a robot (`GET .../pallets`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PalletList {
    /// The pallets, by name.
    pub pallets: Vec<PalletStatus>,
    /// What went wrong with the pallets file at start, if anything did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pallet::counter::InProgress;

    #[test]
    fn a_status_comes_from_the_counter_and_the_slots_layers() {
        let counter = Counter {
            index: 7,
            in_progress: Some(InProgress {
                slot: 7,
                phase: Phase::Unsure,
            }),
            full: false,
            parts: 31,
            pallets: 1,
        };
        let layers: Vec<usize> = (0..12).map(|i| i / 6).collect();
        let s = PalletStatus::new("out", &counter, &layers, true);
        assert_eq!((s.slots, s.layers, s.index, s.layer), (12, 2, 7, 1));
        assert_eq!(s.unsure(), Some(7));
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(
            json,
            r#"{"name":"out","slots":12,"layers":2,"index":7,"layer":1,"in_progress":{"slot":7,"phase":"unsure","unsure":true},"full":false,"parts":31,"pallets":1,"known":true}"#
        );
        assert_eq!(serde_json::from_str::<PalletStatus>(&json).unwrap(), s);
        // A place under way is not unsure; a full pallet's layer is its last.
        let moving = Counter {
            index: 12,
            in_progress: Some(InProgress {
                slot: 3,
                phase: Phase::Moving,
            }),
            full: true,
            ..Counter::default()
        };
        let s = PalletStatus::new("out", &moving, &layers, true);
        assert_eq!((s.unsure(), s.layer, s.full), (None, 1, true));
    }
}
