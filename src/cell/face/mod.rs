//! The cell face: a block of 23 registers through which the line's PLC or HMI drives the robot
//! with no PC code of its own, in the manner of KUKA's Automatic External interface and FANUC's
//! UOP signals. The line writes the command words and reads the status words; the daemon serves
//! the block on the gateway's Modbus TCP face (from register `registers`), or mirrors it in the
//! robot PLC's own DT area (from `plc`), polled, for a press PLC wired to the robot's PLC.
//!
//! ```text
//!  +0  program    the program's number, 1..=255 (a program's `number`)        written by the line
//!  +1  check      the program number's complement: program XOR 0xFFFF
//!  +2  commands   bit 0 strobe     select the program: on its rising edge, with the check
//!                 bit 1 start      run the selected program (or resume a paused or faulted cycle)
//!                 bit 2 stop       stop the cycle at the end of its current step
//!                 bit 3 pause      pause the cycle at the end of its current step
//!                 bit 4 reset      clear the robot's fault (a faulted cycle then resumes on start)
//!                 bit 5 home       move to the `home` position (no cycle running)
//!                 bit 6 enable     move-enable, a level: motion only while it is on; when it
//!                                  drops, the robot stops at once and the cycle pauses
//!                 bit 7 stop-now   stop the robot at once and end the cycle
//!                 bit 8 pallet-redo   the shown pallet's interrupted slot was not placed:
//!                                  place at it again
//!                 bit 9 pallet-go-on  it was placed: count it, go on at the next slot
//!  +3  count      cycles a start runs (0: until stopped)
//!  +4..+7         reserved: read 0, not writable
//!  +8  status     bit 0 ready      remote, enabled, linked, homed, no fault, no cycle: a start runs
//!                 bit 1 running    a cycle runs a step        bit 2 paused   bit 3 waiting
//!                 bit 4 fault      (+11 says which)           bit 5 in-home (at `home`)
//!                 bit 6 remote     bit 7 selected (+9 echoes the program acknowledged)
//!                 bit 8 moving     bit 9 linked               bit 10 refused (+12 says why)
//!                 bit 11 enabled   (move-enable as taken)
//!  +9  program    the acknowledged program's number (0: none)                 read by the line
//!  +10 step       the cycle's step number (from 1; 0: none)
//!  +11 fault      0 none; 1..=99 the PLC's fault word; 100 the cycle faulted (+10: the step);
//!                 101 no link to the PLC; 102 the PLC's heartbeat stands still (stalled, PROG)
//!  +12 refused    why the last command was refused ([`Refusal`]; 0: taken)
//!  +13 heartbeat  the daemon's status reads of the PLC, wrapping: stands still when it stalls
//!  +14 done       cycles done, low word         +15  high word
//!  +16 position   the taught position the robot stands at, its place in `positions` from 1 (0: none)
//!  +17 commands   the command word as the face last took it
//!  +18 pallet     the pallet the face shows (`pallet`); 0 in all five words without one
//!                 bit 0 shown      its count is known        bit 1 full
//!                 bit 2 unsure     a slot was interrupted: redo or go on (+22 says which)
//!                 bit 3 lost       its count was lost with the pallets file: set it
//!  +19 index      the slot to fill next, from 0 (the slots filled; +20 when full)
//!  +20 slots      its slots                  +21 layer   the next slot's layer, from 0
//!  +22 unsure     the interrupted slot, from 0 (with bit 2)
//! ```
//! Words +18..+22 came after the first 18 (issue 48): no earlier address moved. A face that
//! shows no pallet is mirrored in the PLC as 18 words, as before.
//! Commands act on edges, so a line that writes its whole command block every scan starts one
//! cycle per rising edge, not one per write. The first write after the daemon starts, or after
//! the mode changes, only sets the baseline: a bit already on in it is not an edge (drop it and
//! raise it again), so a restart never starts a cycle by itself.

mod machine;
mod status;

pub use machine::{Action, Face, Refusal};
pub use status::{CyclePhase, CycleView, Link, PalletView, View, status_words};

/// Command words (+0..+3).
pub const COMMAND_WORDS: usize = 4;
/// The status words' offset in the block.
pub const STATUS_AT: usize = 8;
/// Status words (+8..+22).
pub const STATUS_WORDS: usize = 15;
/// The block's words.
pub const BLOCK_WORDS: usize = STATUS_AT + STATUS_WORDS;
/// The block's words before the pallet's (+0..+17): all a face showing no pallet mirrors.
pub const BLOCK_WORDS_NO_PALLET: usize = 18;

/// Command word offsets.
pub mod command {
    /// The program number.
    pub const PROGRAM: usize = 0;
    /// Its complement.
    pub const CHECK: usize = 1;
    /// The command bits.
    pub const BITS: usize = 2;
    /// Cycles to run (0: until stopped).
    pub const COUNT: usize = 3;
}

/// Declares the command bits, each with its bit number and what it acts on: its rising edge
/// (`edge`) or its level (`level`); and [`bit::EDGES`], the bits that act on their edge.
macro_rules! command_bits {
    ($($(#[$doc:meta])* $acts_on:ident $name:ident = $bit:literal;)*) => {
        $($(#[$doc])* pub const $name: u16 = 1 << $bit;)*
        /// The commands that act on their rising edge (all but the levels).
        pub const EDGES: u16 = 0 $(| command_bits!(@$acts_on $name))*;
    };
    (@edge $name:ident) => { $name };
    (@level $name:ident) => { 0 };
}

/// Command bits (+2).
pub mod bit {
    command_bits! {
        /// Select the program (rising edge).
        edge STROBE = 0;
        /// Run the selected program, or resume (rising edge).
        edge START = 1;
        /// Stop the cycle at the end of its step (rising edge).
        edge STOP = 2;
        /// Pause the cycle at the end of its step (rising edge).
        edge PAUSE = 3;
        /// Clear the robot's fault (rising edge).
        edge RESET = 4;
        /// Move to the home position (rising edge).
        edge HOME = 5;
        /// Move-enable (a level).
        level ENABLE = 6;
        /// Stop the robot now and end the cycle (rising edge).
        edge STOP_NOW = 7;
        /// The shown pallet's interrupted slot was not placed: place at it again (rising edge).
        edge PALLET_REDO = 8;
        /// The shown pallet's interrupted slot was placed: go on at the next (rising edge).
        edge PALLET_GO_ON = 9;
    }
}

/// Status bits (+8).
pub mod status_bit {
    /// A start would run the selected program.
    pub const READY: u16 = 1 << 0;
    /// A cycle runs a step.
    pub const RUNNING: u16 = 1 << 1;
    /// The cycle is paused (by request, a hold, or move-enable dropping).
    pub const PAUSED: u16 = 1 << 2;
    /// The cycle waits on the cell's inputs.
    pub const WAITING: u16 = 1 << 3;
    /// A fault (the fault word says which).
    pub const FAULT: u16 = 1 << 4;
    /// The robot stands at the home position.
    pub const IN_HOME: u16 = 1 << 5;
    /// The mode is remote.
    pub const REMOTE: u16 = 1 << 6;
    /// A program is selected (its number is echoed).
    pub const SELECTED: u16 = 1 << 7;
    /// A move is queued or running.
    pub const MOVING: u16 = 1 << 8;
    /// The PLC link is up.
    pub const LINKED: u16 = 1 << 9;
    /// The last command was refused (the refusal word says why).
    pub const REFUSED: u16 = 1 << 10;
    /// Move-enable is on, as the face took it.
    pub const ENABLED: u16 = 1 << 11;
}

/// Status word offsets within the status words (add [`STATUS_AT`] for the block).
pub mod status_word {
    /// The status bits.
    pub const BITS: usize = 0;
    /// The acknowledged program's number.
    pub const PROGRAM: usize = 1;
    /// The step number.
    pub const STEP: usize = 2;
    /// The fault code.
    pub const FAULT: usize = 3;
    /// The refusal code.
    pub const REFUSED: usize = 4;
    /// The heartbeat.
    pub const HEARTBEAT: usize = 5;
    /// Cycles done, low word.
    pub const DONE_LOW: usize = 6;
    /// Cycles done, high word.
    pub const DONE_HIGH: usize = 7;
    /// The taught position the robot stands at.
    pub const POSITION: usize = 8;
    /// The command word as taken.
    pub const COMMANDS: usize = 9;
    /// The shown pallet's bits ([`super::pallet_bit`]).
    pub const PALLET: usize = 10;
    /// The shown pallet's slot to fill next.
    pub const PALLET_INDEX: usize = 11;
    /// The shown pallet's slots.
    pub const PALLET_SLOTS: usize = 12;
    /// The shown pallet's next slot's layer.
    pub const PALLET_LAYER: usize = 13;
    /// The shown pallet's interrupted slot.
    pub const PALLET_UNSURE: usize = 14;
}

/// The shown pallet's bits (+18).
pub mod pallet_bit {
    /// A pallet is shown and its count is known.
    pub const SHOWN: u16 = 1 << 0;
    /// Every slot is filled.
    pub const FULL: u16 = 1 << 1;
    /// A slot was interrupted: the cycle places on the pallet only after redo or go on.
    pub const UNSURE: u16 = 1 << 2;
    /// Its count was lost with the pallets file: set it (CLI, API) before the cycle places.
    pub const LOST: u16 = 1 << 3;
}

/// Fault codes (+11) beyond the PLC's own fault word (1..=99).
pub mod fault {
    /// The cycle faulted in the step +10 names.
    pub const CYCLE: u16 = 100;
    /// No link to the PLC.
    pub const LINK_DOWN: u16 = 101;
    /// The PLC's heartbeat stands still (stalled, or in PROG mode).
    pub const STALLED: u16 = 102;
}

/// The check word a program number needs.
#[must_use]
pub fn check_of(program: u16) -> u16 {
    program ^ 0xFFFF
}
