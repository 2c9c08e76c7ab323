//! PURE. Palletising: a pallet pattern's slots in the order they are filled, each with its
//! approach and retreat, and what a cell does between layers and when the pallet is full.
//!
//! - [`pattern`]: the checked pattern as the cycle runs it ([`Pattern`], [`Slot`], [`Waypoint`]).
//! - [`counter`]: which slot is next, the slot in progress, and what a restart means ([`Counter`]).
//!
//! How a pattern is written (rows x columns x layers, per-layer variants, frames) and how the
//! counter that says which slot is next survives a restart are built on these types.

pub mod counter;
pub mod pattern;

pub use counter::{Choice, Counter, CounterError};
pub use pattern::{Pattern, PatternError, Slot, Waypoint, WhenFull};
