//! The status and command blocks as typed values, and their word images.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::{CHANNELS, INPUT_WORDS, Permit};

/// Words in the status block.
pub const STATUS_WORDS: usize = 26;
/// Words in the command block.
pub const COMMAND_WORDS: usize = 25;
/// Offset of the command block's `host` word.
pub const COMMAND_HOST_OFFSET: u16 = 16;
/// Offset of the command block's `permit_mask[0]` (then `permit_value[0..3]` from +21).
pub const COMMAND_PERMIT_OFFSET: u16 = 17;
/// Offset of the status block's `inputs[0]`.
pub const STATUS_INPUTS_OFFSET: u16 = 22;
/// Offset of the status block's `heartbeat` word.
pub const STATUS_HEARTBEAT_OFFSET: u16 = 2;

/// `ready` bit 0: the channels are homed (set by the program's home routine, cleared at power-up).
pub const READY_HOMED: u16 = 0b001;
/// `ready` bit 1: the drives are ready (wired by the integrator).
pub const READY_DRIVES: u16 = 0b010;
/// `ready` bit 2: the e-stop circuit is closed (wired by the integrator).
pub const READY_ESTOP_CLEAR: u16 = 0b100;

/// A word that holds no value the contract defines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("{field} = {value} is not a value contract version 3 defines")]
pub struct UnknownValue {
    /// Which field.
    pub field: &'static str,
    /// The word read.
    pub value: u16,
}

/// The PLC program's state (status block +3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum State {
    /// Nothing started since power-up or clear fault.
    Idle,
    /// A start is running.
    Running,
    /// The last start finished.
    Done,
    /// The last start was stopped.
    Stopped,
    /// A fault is latched (see [`Fault`]).
    Fault,
    /// The integrator's home routine runs (command 4).
    Homing,
}

impl State {
    /// The word value.
    #[must_use]
    pub fn word(self) -> u16 {
        match self {
            Self::Idle => 0,
            Self::Running => 1,
            Self::Done => 2,
            Self::Stopped => 3,
            Self::Fault => 4,
            Self::Homing => 5,
        }
    }

    /// The state for a word.
    pub fn from_word(value: u16) -> Result<Self, UnknownValue> {
        Ok(match value {
            0 => Self::Idle,
            1 => Self::Running,
            2 => Self::Done,
            3 => Self::Stopped,
            4 => Self::Fault,
            5 => Self::Homing,
            _ => {
                return Err(UnknownValue {
                    field: "state",
                    value,
                });
            }
        })
    }

    /// Lower-case name for messages, as the API writes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Idle => "idle",
            Self::Running => "running",
            Self::Done => "done",
            Self::Stopped => "stopped",
            Self::Fault => "fault",
            Self::Homing => "homing",
        }
    }
}

/// Why the PLC program latched a fault (status block +5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// No fault.
    None,
    /// The command block was out of bounds.
    BadTableHeader,
    /// A channel in the mask was busy at start.
    ChannelBusy,
    /// Stopped from outside (e-stop input).
    StoppedFromOutside,
    /// A pulse instruction error (e.g. first frequency out of range).
    PulseInstruction,
    /// A channel's count differed from the start's `from` when the start was acted on.
    NotAtStart,
    /// A start while the homed bit is clear.
    NotHomed,
    /// The home routine failed (timeout, limit switch, e-stop).
    HomingFailed,
    /// The start's permit did not hold on the inputs of the scan that acted on it (version 3).
    PermitNotMet,
    /// The running move's permit stopped holding: every channel stopped (version 3).
    PermitDropped,
}

impl Fault {
    /// The word value.
    #[must_use]
    pub fn word(self) -> u16 {
        match self {
            Self::None => 0,
            Self::BadTableHeader => 1,
            Self::ChannelBusy => 2,
            Self::StoppedFromOutside => 3,
            Self::PulseInstruction => 4,
            Self::NotAtStart => 5,
            Self::NotHomed => 6,
            Self::HomingFailed => 7,
            Self::PermitNotMet => 8,
            Self::PermitDropped => 9,
        }
    }

    /// The fault for a word.
    pub fn from_word(value: u16) -> Result<Self, UnknownValue> {
        Ok(match value {
            0 => Self::None,
            1 => Self::BadTableHeader,
            2 => Self::ChannelBusy,
            3 => Self::StoppedFromOutside,
            4 => Self::PulseInstruction,
            5 => Self::NotAtStart,
            6 => Self::NotHomed,
            7 => Self::HomingFailed,
            8 => Self::PermitNotMet,
            9 => Self::PermitDropped,
            _ => {
                return Err(UnknownValue {
                    field: "fault",
                    value,
                });
            }
        })
    }

    /// What the fault means, for messages.
    #[must_use]
    pub fn meaning(self) -> &'static str {
        match self {
            Self::None => "no fault",
            Self::BadTableHeader => "bad table header",
            Self::ChannelBusy => "channel busy at start",
            Self::StoppedFromOutside => "stopped from outside (e-stop input)",
            Self::PulseInstruction => "pulse instruction error",
            Self::NotAtStart => "not at the table's start: a count differed from `from`",
            Self::NotHomed => "not homed",
            Self::HomingFailed => "homing failed",
            Self::PermitNotMet => "permit not met at start",
            Self::PermitDropped => "permit dropped while moving",
        }
    }
}

/// The command word (command block +0).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// Nothing to do.
    None,
    /// Start the described move.
    Start,
    /// Stop every channel.
    Stop,
    /// Clear a latched fault.
    ClearFault,
    /// Run the home routine for the channels in `mask`, presetting each count to `from`.
    Home,
}

impl Command {
    /// The word value.
    #[must_use]
    pub fn word(self) -> u16 {
        match self {
            Self::None => 0,
            Self::Start => 1,
            Self::Stop => 2,
            Self::ClearFault => 3,
            Self::Home => 4,
        }
    }

    /// The command for a word.
    pub fn from_word(value: u16) -> Result<Self, UnknownValue> {
        Ok(match value {
            0 => Self::None,
            1 => Self::Start,
            2 => Self::Stop,
            3 => Self::ClearFault,
            4 => Self::Home,
            _ => {
                return Err(UnknownValue {
                    field: "command",
                    value,
                });
            }
        })
    }
}

/// The status block as read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StatusBlock {
    /// [`super::MAGIC`] once the program runs.
    pub magic: u16,
    /// Contract version.
    pub version: u16,
    /// +1 every scan.
    pub heartbeat: u16,
    /// Raw state word (see [`State::from_word`]).
    pub state: u16,
    /// Sequence number of the last accepted start.
    pub seq: u16,
    /// Raw fault word (see [`Fault::from_word`]).
    pub fault: u16,
    /// Bit c: channel c is outputting pulses.
    pub busy: u16,
    /// Bit 0 homed, bit 1 drives ready, bit 2 e-stop clear.
    pub ready: u16,
    /// Absolute pulse count per channel.
    pub elapsed: [i32; CHANNELS],
    /// Index of the segment each channel runs.
    pub segment: [u16; CHANNELS],
    /// Copy of the command block's `host` word (0 after the program's first scan).
    pub host: u16,
    /// Sequence number of a start waiting behind the running move, 0 when none.
    pub waiting: u16,
    /// The cell's input words, copied every scan (version 3).
    pub inputs: [u16; INPUT_WORDS],
}

fn dint(words: &[u16], at: usize) -> i32 {
    (u32::from(words[at]) | (u32::from(words[at + 1]) << 16)) as i32
}

fn push_dint(words: &mut Vec<u16>, value: i32) {
    let v = value as u32;
    words.push((v & 0xFFFF) as u16);
    words.push((v >> 16) as u16);
}

impl StatusBlock {
    /// The word image.
    #[must_use]
    pub fn to_words(&self) -> Vec<u16> {
        let mut w = vec![
            self.magic,
            self.version,
            self.heartbeat,
            self.state,
            self.seq,
            self.fault,
            self.busy,
            self.ready,
        ];
        for e in self.elapsed {
            push_dint(&mut w, e);
        }
        w.extend(self.segment);
        w.push(self.host);
        w.push(self.waiting);
        w.extend(self.inputs);
        w
    }

    /// Reads a word image of at least [`STATUS_WORDS`] words; `None` if it is shorter.
    #[must_use]
    pub fn from_words(words: &[u16]) -> Option<Self> {
        if words.len() < STATUS_WORDS {
            return None;
        }
        Some(Self {
            magic: words[0],
            version: words[1],
            heartbeat: words[usize::from(STATUS_HEARTBEAT_OFFSET)],
            state: words[3],
            seq: words[4],
            fault: words[5],
            busy: words[6],
            ready: words[7],
            elapsed: std::array::from_fn(|c| dint(words, 8 + 2 * c)),
            segment: std::array::from_fn(|c| words[16 + c]),
            host: words[20],
            waiting: words[21],
            inputs: std::array::from_fn(|i| words[usize::from(STATUS_INPUTS_OFFSET) + i]),
        })
    }
}

/// The command block as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CommandBlock {
    /// Raw command word (see [`Command`]).
    pub command: u16,
    /// Sequence number of this start.
    pub seq: u16,
    /// Bit c: start channel c.
    pub mask: u16,
    /// Which table bank (0 or 1).
    pub bank: u16,
    /// Segments per channel (0-8).
    pub segments: [u16; CHANNELS],
    /// Start: the count every channel must show when the start is acted on. Home: the count each
    /// homed channel is set to.
    pub from: [i32; CHANNELS],
    /// The host's word (see [`StatusBlock::host`]).
    pub host: u16,
    /// The start's permit (all 0: none).
    pub permit: Permit,
}

impl CommandBlock {
    /// The word image.
    #[must_use]
    pub fn to_words(&self) -> Vec<u16> {
        let mut w = vec![self.command, self.seq, self.mask, self.bank];
        w.extend(self.segments);
        for f in self.from {
            push_dint(&mut w, f);
        }
        w.push(self.host);
        w.extend(self.permit.mask);
        w.extend(self.permit.value);
        w
    }

    /// Reads a word image of at least [`COMMAND_WORDS`] words; `None` if it is shorter.
    #[must_use]
    pub fn from_words(words: &[u16]) -> Option<Self> {
        if words.len() < COMMAND_WORDS {
            return None;
        }
        Some(Self {
            command: words[0],
            seq: words[1],
            mask: words[2],
            bank: words[3],
            segments: std::array::from_fn(|c| words[4 + c]),
            from: std::array::from_fn(|c| dint(words, 8 + 2 * c)),
            host: words[16],
            permit: Permit {
                mask: std::array::from_fn(|i| words[17 + i]),
                value: std::array::from_fn(|i| words[21 + i]),
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_block_round_trips_with_negative_counts_low_word_first() {
        let s = StatusBlock {
            magic: super::super::MAGIC,
            version: 1,
            heartbeat: 7,
            state: State::Running.word(),
            seq: 3,
            fault: 0,
            busy: 0b0101,
            ready: 0b111,
            elapsed: [-5_000, 1, 70_000, 0],
            segment: [1, 0, 2, 0],
            host: 0xBEEF,
            waiting: 4,
            inputs: [0x20, 0, 0xFFFF, 1],
        };
        let w = s.to_words();
        assert_eq!(w.len(), STATUS_WORDS);
        assert_eq!(&w[8..10], &[0xEC78, 0xFFFF]);
        assert_eq!(&w[20..22], &[0xBEEF, 4]);
        assert_eq!(&w[22..26], &[0x20, 0, 0xFFFF, 1]);
        assert_eq!(StatusBlock::from_words(&w), Some(s));
        assert_eq!(StatusBlock::from_words(&w[..25]), None);
    }

    #[test]
    fn command_block_round_trips() {
        let c = CommandBlock {
            command: 1,
            seq: 9,
            mask: 0b1011,
            bank: 1,
            segments: [1, 2, 0, 8],
            from: [-5_000, 70_000, 0, 1],
            host: 0x1234,
            permit: Permit {
                mask: [0x60, 0, 1, 0],
                value: [0x20, 0, 1, 0],
            },
        };
        let w = c.to_words();
        assert_eq!(w.len(), COMMAND_WORDS);
        assert_eq!(&w[8..10], &[0xEC78, 0xFFFF]);
        assert_eq!(w[usize::from(COMMAND_HOST_OFFSET)], 0x1234);
        assert_eq!(&w[17..25], &[0x60, 0, 1, 0, 0x20, 0, 1, 0]);
        assert_eq!(CommandBlock::from_words(&w), Some(c));
        assert_eq!(CommandBlock::from_words(&w[..24]), None);
    }

    #[test]
    fn unknown_state_is_named() {
        assert_eq!(
            State::from_word(9).unwrap_err().to_string(),
            "state = 9 is not a value contract version 3 defines"
        );
        assert_eq!(State::from_word(5), Ok(State::Homing));
        assert_eq!(Fault::from_word(4), Ok(Fault::PulseInstruction));
        assert_eq!(Fault::from_word(5), Ok(Fault::NotAtStart));
        assert_eq!(Fault::from_word(7), Ok(Fault::HomingFailed));
        assert_eq!(Fault::from_word(8), Ok(Fault::PermitNotMet));
        assert_eq!(Fault::from_word(9), Ok(Fault::PermitDropped));
        assert!(Fault::from_word(10).is_err());
        assert_eq!(Command::from_word(2), Ok(Command::Stop));
        assert_eq!(Command::from_word(4), Ok(Command::Home));
    }
}
