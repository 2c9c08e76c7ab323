//! PURE. The register contract between linterpd and the PLC program, version 1
//! (`../shared/spec/CONTRACT.md`): where the blocks and table areas sit in DT memory, and the
//! status and command blocks as typed values with their word images. The mock PLC and the PLC
//! clients both use these, so they cannot disagree.
//!
//! ```text
//! status block   (PLC -> linterpd), default DT1000, 20 words
//!   +0 magic 0x4C49  +1 version  +2 heartbeat  +3 state  +4 seq  +5 fault  +6 busy  +7 ready
//!   +8..+15 elapsed[0..3] DINT (low word first)   +16..+19 segment[0..3]
//! command block  (linterpd -> PLC), default DT1032, 8 words
//!   +0 command  +1 seq  +2 mask  +3 bank  +4..+7 segments[0..3]
//! table areas    DT2000 + bank * 8000 + channel * 2000, 2000 words each
//! ```

mod blocks;
mod layout;

pub use blocks::{
    COMMAND_WORDS, Command, CommandBlock, Fault, STATUS_WORDS, State, StatusBlock, UnknownValue,
};
pub use layout::{Layout, LayoutError};

/// `magic` once the PLC program runs ("LI").
pub const MAGIC: u16 = 0x4C49;
/// The contract version this build speaks.
pub const VERSION: u16 = 1;
/// Pulse channels of an FP-X C60T.
pub const CHANNELS: usize = 4;
/// Table banks.
pub const BANKS: u16 = 2;
/// The last DT word of an FP-X C30/C60 (PLC.md §3, "Special registers").
pub const DT_LAST: u16 = 32_764;
