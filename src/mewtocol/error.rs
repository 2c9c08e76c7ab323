//! The errors of each MEWTOCOL-COM layer, and the PLC's own `!` refusals.
//!
//! ```text
//! FrameError    (in frame.rs, beside the frame) the bytes are not a well-formed frame (BCC,
//!               length, station, terminator)
//! MessageError  a well-formed frame whose text is not a valid command or reply, or a command
//!               whose values cannot be sent (address range, word count)
//! PlcError      a well-formed `!` reply: the PLC understood and said no (PLC.md §1, error codes)
//! CodecError    what the tokio-util codecs return: any of the above but PlcError, or IO
//! ```

use std::fmt;

use thiserror::Error;

use super::frame::{FrameError, Header};

/// A well-formed frame whose text is not a valid command or reply, or a command that cannot be sent.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum MessageError {
    /// The text names no command (or reply) this module knows.
    #[error("unknown command {text:?}")]
    UnknownCommand {
        /// The start of the text, lossily decoded.
        text: String,
    },
    /// The body does not start with `#`, `$` or `!` where one is required.
    #[error("body starts with {found:?}, expected {expected:?}")]
    BadMarker {
        /// The first body byte (`None`: empty body).
        found: Option<char>,
        /// What was expected.
        expected: &'static str,
    },
    /// A field has the wrong length.
    #[error("{field} has {len} characters, expected {expected}")]
    BadLength {
        /// Which field.
        field: &'static str,
        /// Characters found.
        len: usize,
        /// Characters expected (a number or a rule).
        expected: String,
    },
    /// A field holds a character that is not allowed there.
    #[error("{field} holds {found:?}, expected {expected}")]
    BadDigit {
        /// Which field.
        field: &'static str,
        /// The offending character.
        found: char,
        /// What is allowed.
        expected: &'static str,
    },
    /// An address beyond its area's limit.
    #[error("{area} address {address} is out of range 0..={max}")]
    AddressOutOfRange {
        /// `DT`, `X`, `Y`, `R`, `L` or `bit`.
        area: &'static str,
        /// The address given.
        address: u32,
        /// Highest address.
        max: u32,
    },
    /// A range whose start lies after its end.
    #[error("start {start} is after end {end}")]
    StartAfterEnd {
        /// First address.
        start: u32,
        /// Last address.
        end: u32,
    },
    /// More words than one frame under this header carries.
    #[error("{words} words do not fit one {header:?} frame, which carries at most {max}")]
    TooManyWords {
        /// Words given.
        words: usize,
        /// Words one frame carries.
        max: usize,
        /// The frame's header.
        header: Header,
    },
    /// A write with no words, or a reply's word count that does not match the request.
    #[error("expected {expected} words, got {found}")]
    WordCount {
        /// Words expected.
        expected: usize,
        /// Words found.
        found: usize,
    },
    /// Contacts of area X are inputs and cannot be written.
    #[error("contact area {area} cannot be written; only Y, R and L can")]
    ContactNotWritable {
        /// The area given.
        area: char,
    },
    /// A multi-frame reply broke its sequence (a continuation without a start, or too much data).
    #[error("multi-frame reply broken: {reason}")]
    MultiFrame {
        /// What went wrong.
        reason: &'static str,
    },
}

impl MessageError {
    /// The `!` code a PLC would answer a command with this error (for the mock PLC): 42 for an
    /// unknown command, 66 for an address error, 61 for data errors, 41 for format errors.
    #[must_use]
    pub fn plc_code(&self) -> PlcErrorCode {
        match self {
            Self::UnknownCommand { .. } => PlcErrorCode::NotSupported,
            Self::AddressOutOfRange { .. } | Self::ContactNotWritable { .. } => {
                PlcErrorCode::AddressError
            }
            Self::StartAfterEnd { .. } | Self::WordCount { .. } | Self::TooManyWords { .. } => {
                PlcErrorCode::DataError
            }
            Self::BadDigit { expected, .. } if expected.contains("hex") => PlcErrorCode::DataError,
            Self::MultiFrame { .. } => PlcErrorCode::MultiFrameBusy,
            _ => PlcErrorCode::FormatError,
        }
    }
}

/// Error codes of `!` replies (PLC.md §1 "Error codes"; MEWTOCOL-COM manual, "Error codes").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PlcErrorCode {
    /// 26: command not usable with station FF.
    BroadcastNotAllowed,
    /// 40: BCC error.
    BccError,
    /// 41: format error.
    FormatError,
    /// 42: command not supported.
    NotSupported,
    /// 43: another command during a multi-frame exchange.
    MultiFrameBusy,
    /// 60: parameter error.
    ParameterError,
    /// 61: data error (range, start > end, non-hex data).
    DataError,
    /// 62: registration over / not registered.
    RegistrationError,
    /// 63: PLC mode error (not possible in RUN).
    ModeError,
    /// 65: protect error.
    ProtectError,
    /// 66: address error (format, over or under range).
    AddressError,
    /// 67: no program / no data.
    NoData,
    /// 71: exclusive control (another command in progress).
    ExclusiveControl,
    /// Any other code, kept as its number (0..=99).
    Other(u8),
}

/// Every known code with its number and meaning (PLC.md §1, "Error codes in `!` replies").
const CODES: [(PlcErrorCode, u8, &str); 13] = [
    (
        PlcErrorCode::BroadcastNotAllowed,
        26,
        "command not usable with station FF",
    ),
    (PlcErrorCode::BccError, 40, "bcc error"),
    (PlcErrorCode::FormatError, 41, "format error"),
    (PlcErrorCode::NotSupported, 42, "command not supported"),
    (
        PlcErrorCode::MultiFrameBusy,
        43,
        "another command during a multi-frame exchange",
    ),
    (PlcErrorCode::ParameterError, 60, "parameter error"),
    (
        PlcErrorCode::DataError,
        61,
        "data error (range, start > end, non-hex data)",
    ),
    (
        PlcErrorCode::RegistrationError,
        62,
        "registration over or not registered",
    ),
    (
        PlcErrorCode::ModeError,
        63,
        "plc mode error (not possible in run)",
    ),
    (PlcErrorCode::ProtectError, 65, "protect error"),
    (
        PlcErrorCode::AddressError,
        66,
        "address error (format, over or under range)",
    ),
    (PlcErrorCode::NoData, 67, "no program or no data"),
    (
        PlcErrorCode::ExclusiveControl,
        71,
        "exclusive control (another command in progress)",
    ),
];

impl PlcErrorCode {
    /// The code for number `code`.
    #[must_use]
    pub fn from_number(code: u8) -> Self {
        CODES
            .iter()
            .find(|(_, n, _)| *n == code)
            .map_or(Self::Other(code), |(c, _, _)| *c)
    }

    /// The code's number as sent after `!`.
    #[must_use]
    pub fn number(self) -> u8 {
        match self {
            Self::Other(n) => n,
            known => CODES
                .iter()
                .find(|(c, _, _)| *c == known)
                .map_or(0, |(_, n, _)| *n),
        }
    }

    /// The manual's meaning of the code, or "unknown error code".
    #[must_use]
    pub fn meaning(self) -> &'static str {
        CODES
            .iter()
            .find(|(c, _, _)| *c == self)
            .map_or("unknown error code", |(_, _, m)| m)
    }
}

impl fmt::Display for PlcErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02} ({})", self.number(), self.meaning())
    }
}

/// The PLC answered with `!`: it understood the frame and refused the command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
#[error("plc refused the command with error {code}")]
pub struct PlcError {
    /// The refusal's code.
    pub code: PlcErrorCode,
}

/// What the tokio-util codecs return: a bad frame, a bad message, or IO.
#[derive(Debug, Error)]
pub enum CodecError {
    /// The bytes are not a well-formed frame.
    #[error(transparent)]
    Frame(#[from] FrameError),
    /// A well-formed frame with a bad message.
    #[error(transparent)]
    Message(#[from] MessageError),
    /// The transport failed.
    #[error("io: {0}")]
    Io(#[from] std::io::Error),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_documented_code_round_trips_with_its_meaning() {
        for number in [26, 40, 41, 42, 43, 60, 61, 62, 63, 65, 66, 67, 71] {
            let code = PlcErrorCode::from_number(number);
            assert!(!matches!(code, PlcErrorCode::Other(_)), "{number}");
            assert_eq!(code.number(), number);
            assert_ne!(code.meaning(), "unknown error code");
        }
    }

    #[test]
    fn unknown_code_is_kept_as_its_number() {
        let code = PlcErrorCode::from_number(50);
        assert_eq!(code, PlcErrorCode::Other(50));
        assert_eq!(code.number(), 50);
        assert_eq!(
            PlcError { code }.to_string(),
            "plc refused the command with error 50 (unknown error code)"
        );
    }

    #[test]
    fn plc_error_message_names_code_and_meaning() {
        let err = PlcError {
            code: PlcErrorCode::from_number(61),
        };
        assert_eq!(
            err.to_string(),
            "plc refused the command with error 61 (data error (range, start > end, non-hex data))"
        );
    }
}
