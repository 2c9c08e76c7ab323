//! PURE. Palletising: a pallet pattern's slots in the order they are filled, each with its
//! approach and retreat, and what a cell does between layers and when the pallet is full.
//!
//! - [`pattern`]: the checked pattern as the cycle runs it ([`Pattern`], [`Slot`], [`Waypoint`]).
//! - [`counter`]: which slot is next, the slot in progress, and what a restart means ([`Counter`]).
//! - [`frame`]: a user frame taught from three points or given as numbers ([`Frame`]).
//! - [`doc`]: the `[robots.NAME.pallets.NAME]` and `[robots.NAME.frames.NAME]` tables as
//!   written (serde).
//! - [`layout`]: a pallet table checked and laid out in a frame: grid, layer kinds, fill order,
//!   approach and retreat ([`Layout`]).
//! - [`set`]: a robot's frames and pallets ([`RobotPallets`]), turned into patterns once the
//!   taught positions are known, every slot checked against the robot's reach.
//! - [`taught`]: taught positions kept in a frame, carried by it to the world.
//! - [`error`], why a pallet or a frame cannot be used ([`PalletError`]).

pub mod counter;
pub mod doc;
pub mod error;
pub mod frame;
pub mod layout;
pub mod pattern;
pub mod set;
pub mod taught;

pub use counter::{Choice, Counter, CounterError};
pub use error::{PalletError, SlotAt};
pub use frame::{Frame, FrameError};
pub use layout::Layout;
pub use pattern::{Pattern, PatternError, Slot, Waypoint, WhenFull};
pub use set::{FrameSpec, RobotPallets};

use crate::geometry::Pose;

#[cfg(test)]
mod tests;
