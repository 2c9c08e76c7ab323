//! A pallet pattern as the cycle runs it: its slots in fill order, every pose in world
//! coordinates of the tool centre, each slot with the waypoints that lead to it and away from it.

use thiserror::Error;

use crate::geometry::Pose;

/// A point on the way to or from a slot, and the speed of the stretch that ends there.
#[derive(Debug, Clone, PartialEq)]
pub struct Waypoint {
    /// Where the tool centre passes, world coordinates.
    pub pose: Pose,
    /// The speed of the line that ends here, mm/s; `None`: the step's own speed.
    pub speed_mm_s: Option<f64>,
    /// A blended corner here, mm (a path's `blend`): passed without a stop when the line after
    /// it runs at the same speed; `None`: a stop.
    pub blend_mm: Option<f64>,
}

/// One place on the pallet.
#[derive(Debug, Clone, PartialEq)]
pub struct Slot {
    /// Its place in the fill order, from 0.
    pub index: usize,
    /// Its layer, from 0 (the bottom layer).
    pub layer: usize,
    /// Its row in its layer's grid, from 0 (for a listed layer: its place in the list).
    pub row: usize,
    /// Its column in its layer's grid, from 0 (for a listed layer: 0).
    pub column: usize,
    /// The tool centre when the part is in place, world coordinates (mm, tool angle).
    pub pose: Pose,
    /// The waypoints before the slot, in the order the tool passes them.
    pub approach: Vec<Waypoint>,
    /// The speed of the last line, into the slot, mm/s; `None`: the step's own speed.
    pub slot_speed_mm_s: Option<f64>,
    /// The waypoints after the slot, in the order the tool passes them.
    pub retreat: Vec<Waypoint>,
}

/// What the cell does when the last slot has been filled, in this order; then the counter starts
/// again from slot 0.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WhenFull {
    /// An output (a signal name, a Y or R bit) set true while the pallet is full.
    pub signal: Option<String>,
    /// A condition (cycle condition syntax) that says an empty pallet is in place.
    pub wait_for: Option<String>,
    /// A cycle program to call (a pallet change, a conveyor step).
    pub call: Option<String>,
}

/// Why a pattern cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PatternError {
    /// A pattern with no slot.
    #[error("pallet pattern {name:?} has no slot")]
    Empty {
        /// The pattern's name.
        name: String,
    },
    /// Slots whose indices are not 0, 1, 2, ... in order.
    #[error(
        "pallet pattern {name:?}: slot {at} has index {index}; slots are numbered 0, 1, 2, ... in fill order"
    )]
    OutOfOrder {
        /// The pattern's name.
        name: String,
        /// Its place in the list.
        at: usize,
        /// The index it carries.
        index: usize,
    },
    /// A pose or a speed that is not a finite number (or a speed not above zero).
    #[error("pallet pattern {name:?}, slot {index}: {what} is {value}; it must be a finite number{}", if *.positive { " above 0" } else { "" })]
    NotFinite {
        /// The pattern's name.
        name: String,
        /// The slot.
        index: usize,
        /// What the value is.
        what: &'static str,
        /// The value.
        value: f64,
        /// Whether it must also be above zero.
        positive: bool,
    },
}

/// A checked pattern: slots in fill order (index = place in the list), layers from 0 up.
#[derive(Debug, Clone, PartialEq)]
pub struct Pattern {
    name: String,
    slots: Vec<Slot>,
    /// A cycle program to call between layers (a slip sheet), before the first slot of every
    /// layer but the first.
    pub between_layers: Option<String>,
    /// What happens when the pallet is full.
    pub when_full: WhenFull,
}

impl Pattern {
    /// A pattern from its slots, checked: at least one, numbered in fill order, every pose and
    /// speed finite (speeds above zero).
    ///
    /// # Errors
    /// The first slot that breaks a rule, named.
    pub fn from_slots(name: &str, slots: Vec<Slot>) -> Result<Self, PatternError> {
        if slots.is_empty() {
            return Err(PatternError::Empty {
                name: name.to_owned(),
            });
        }
        for (at, slot) in slots.iter().enumerate() {
            if slot.index != at {
                return Err(PatternError::OutOfOrder {
                    name: name.to_owned(),
                    at,
                    index: slot.index,
                });
            }
            check_slot(name, slot)?;
        }
        Ok(Self {
            name: name.to_owned(),
            slots,
            between_layers: None,
            when_full: WhenFull::default(),
        })
    }

    /// Its name.
    #[must_use]
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Slots in a full pallet.
    #[must_use]
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Never true: a pattern has at least one slot.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// The slot at `index` in fill order.
    #[must_use]
    pub fn slot(&self, index: usize) -> Option<&Slot> {
        self.slots.get(index)
    }

    /// Every slot in fill order.
    #[must_use]
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }

    /// Layers in a full pallet.
    #[must_use]
    pub fn layers(&self) -> usize {
        self.slots.iter().map(|s| s.layer + 1).max().unwrap_or(0)
    }
}

fn check_slot(name: &str, slot: &Slot) -> Result<(), PatternError> {
    let bad = |what: &'static str, value: f64, positive: bool| PatternError::NotFinite {
        name: name.to_owned(),
        index: slot.index,
        what,
        value,
        positive,
    };
    let poses = std::iter::once(("the slot's pose", &slot.pose))
        .chain(
            slot.approach
                .iter()
                .map(|w| ("an approach waypoint", &w.pose)),
        )
        .chain(slot.retreat.iter().map(|w| ("a retreat waypoint", &w.pose)));
    for (what, pose) in poses {
        for value in pose.position_mm.iter().copied().chain([pose.a_rad]) {
            if !value.is_finite() {
                return Err(bad(what, value, false));
            }
        }
    }
    let speeds = std::iter::once(slot.slot_speed_mm_s)
        .chain(slot.approach.iter().map(|w| w.speed_mm_s))
        .chain(slot.retreat.iter().map(|w| w.speed_mm_s))
        .flatten();
    for speed in speeds {
        if !(speed.is_finite() && speed > 0.0) {
            return Err(bad("a speed", speed, true));
        }
    }
    let blends = slot
        .approach
        .iter()
        .chain(&slot.retreat)
        .filter_map(|w| w.blend_mm);
    for blend in blends {
        if !(blend.is_finite() && blend > 0.0) {
            return Err(bad("a blend", blend, true));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slot(index: usize, layer: usize) -> Slot {
        Slot {
            index,
            layer,
            row: 0,
            column: index,
            pose: Pose::from_mm_deg(100.0 * index as f64, 0.0, 100.0 * layer as f64, 0.0),
            approach: vec![],
            slot_speed_mm_s: Some(50.0),
            retreat: vec![],
        }
    }

    #[test]
    fn slots_are_kept_in_fill_order_and_layers_counted() {
        let p = Pattern::from_slots("out", vec![slot(0, 0), slot(1, 0), slot(2, 1)]).unwrap();
        assert_eq!((p.len(), p.layers(), p.name()), (3, 2, "out"));
        assert_eq!(p.slot(2).unwrap().layer, 1);
        assert!(p.slot(3).is_none());
    }

    #[test]
    fn an_empty_pattern_a_misnumbered_slot_and_a_bad_speed_are_refused() {
        assert!(matches!(
            Pattern::from_slots("e", vec![]),
            Err(PatternError::Empty { .. })
        ));
        let e = Pattern::from_slots("o", vec![slot(0, 0), slot(2, 0)]).unwrap_err();
        assert_eq!(
            e,
            PatternError::OutOfOrder {
                name: "o".into(),
                at: 1,
                index: 2
            }
        );
        let mut s = slot(0, 0);
        s.slot_speed_mm_s = Some(0.0);
        let e = Pattern::from_slots("s", vec![s]).unwrap_err().to_string();
        assert!(e.contains("slot 0") && e.contains("above 0"), "{e}");
        let mut s = slot(0, 0);
        s.approach.push(Waypoint {
            pose: Pose::from_mm_deg(f64::NAN, 0.0, 0.0, 0.0),
            speed_mm_s: None,
            blend_mm: None,
        });
        assert!(
            Pattern::from_slots("n", vec![s])
                .unwrap_err()
                .to_string()
                .contains("approach")
        );
    }
}
