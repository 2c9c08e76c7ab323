//! The status and command blocks as typed values, and their word images.

use thiserror::Error;

use super::CHANNELS;

/// Words in the status block.
pub const STATUS_WORDS: usize = 20;
/// Words in the command block.
pub const COMMAND_WORDS: usize = 8;

/// A word that holds no value the contract defines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("{field} = {value} is not a value contract version 1 defines")]
pub struct UnknownValue {
    /// Which field.
    pub field: &'static str,
    /// The word read.
    pub value: u16,
}

/// The PLC program's state (status block +3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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
            _ => {
                return Err(UnknownValue {
                    field: "state",
                    value,
                });
            }
        })
    }

    /// Lower-case name for messages.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Idle => "idle",
            Self::Running => "running",
            Self::Done => "done",
            Self::Stopped => "stopped",
            Self::Fault => "fault",
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
        }
    }

    /// The command for a word.
    pub fn from_word(value: u16) -> Result<Self, UnknownValue> {
        Ok(match value {
            0 => Self::None,
            1 => Self::Start,
            2 => Self::Stop,
            3 => Self::ClearFault,
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
            heartbeat: words[2],
            state: words[3],
            seq: words[4],
            fault: words[5],
            busy: words[6],
            ready: words[7],
            elapsed: std::array::from_fn(|c| dint(words, 8 + 2 * c)),
            segment: std::array::from_fn(|c| words[16 + c]),
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
}

impl CommandBlock {
    /// The word image.
    #[must_use]
    pub fn to_words(&self) -> Vec<u16> {
        let mut w = vec![self.command, self.seq, self.mask, self.bank];
        w.extend(self.segments);
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
        };
        let w = s.to_words();
        assert_eq!(w.len(), STATUS_WORDS);
        assert_eq!(&w[8..10], &[0xEC78, 0xFFFF]);
        assert_eq!(StatusBlock::from_words(&w), Some(s));
        assert_eq!(StatusBlock::from_words(&w[..19]), None);
    }

    #[test]
    fn command_block_round_trips() {
        let c = CommandBlock {
            command: 1,
            seq: 9,
            mask: 0b1011,
            bank: 1,
            segments: [1, 2, 0, 8],
        };
        assert_eq!(CommandBlock::from_words(&c.to_words()), Some(c));
    }

    #[test]
    fn unknown_state_is_named() {
        assert_eq!(
            State::from_word(9).unwrap_err().to_string(),
            "state = 9 is not a value contract version 1 defines"
        );
        assert_eq!(Fault::from_word(4), Ok(Fault::PulseInstruction));
        assert_eq!(Command::from_word(2), Ok(Command::Stop));
    }
}
