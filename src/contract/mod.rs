//! PURE. The register contract between linterpd and the PLC program, version 3
//! (`docs/CONTRACT.md`): where the blocks and table areas sit in DT memory, the status and
//! command blocks as typed values with their word images, and the host's side of the contract as
//! a state machine over the status block ([`machine`]). The mock PLC and the PLC clients both use
//! these, so they cannot disagree.
//!
//! ```text
//! status block   (PLC -> linterpd), default DT1000, 26 words
//!   +0 magic 0x4C49  +1 version 3  +2 heartbeat  +3 state  +4 seq  +5 fault  +6 busy  +7 ready
//!   +8..+15 elapsed[0..3] DINT (low word first)   +16..+19 segment[0..3]   +20 host  +21 waiting
//!   +22..+25 inputs[0..3]: the cell's input words (inputs.rs)
//! command block  (linterpd -> PLC), default DT1032, 25 words
//!   +0 command  +1 seq  +2 mask  +3 bank  +4..+7 segments[0..3]  +8..+15 from[0..3] DINT
//!   +16 host  +17..+20 permit_mask[0..3]  +21..+24 permit_value[0..3]
//! table areas    DT2000 + bank * 8000 + channel * 2000, 2000 words each
//! ```

mod blocks;
mod inputs;
mod layout;
pub mod machine;

pub use blocks::{
    COMMAND_HOST_OFFSET, COMMAND_PERMIT_OFFSET, COMMAND_WORDS, Command, CommandBlock, Fault,
    READY_DRIVES, READY_ESTOP_CLEAR, READY_HOMED, STATUS_HEARTBEAT_OFFSET, STATUS_INPUTS_OFFSET,
    STATUS_WORDS, State, StatusBlock, UnknownValue,
};
pub use inputs::{
    INPUT_WORDS, InputArea, InputWord, InputWordError, Permit, PermitBit, bit_name, describe_unmet,
};
pub use layout::{Layout, LayoutError};

/// `magic` once the PLC program runs ("LI").
pub const MAGIC: u16 = 0x4C49;
/// The contract version this build speaks.
pub const VERSION: u16 = 3;
/// Pulse channels of an FP-X C60T.
pub const CHANNELS: usize = 4;
/// Table banks.
pub const BANKS: u16 = 2;
/// The last DT word of an FP-X C30/C60 (PLC.md §3, "Special registers").
pub const DT_LAST: u16 = 32_764;

/// RUN or PROG (`run`, `prog` in the daemon's API): whether the PLC runs its program, the
/// contract's with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PlcMode {
    /// The program runs.
    Run,
    /// Programming mode: the program does not run.
    Prog,
}
