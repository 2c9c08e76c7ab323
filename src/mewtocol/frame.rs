//! One MEWTOCOL-COM frame as bytes on the link: header, station, body text, BCC, terminator.
//!
//! This layer owns the envelope only; what the body means (command, reply, error) is the message
//! layer's business ([`super::command`], [`super::reply`]).
//!
//! ```text
//!  +--------+---------+----------------------+-------+-----+----+
//!  | HEADER | STATION | BODY                 | BCC   | [&] | CR |
//!  | % or < | 2 chars | #TEXT / $CMD2DATA /  | 2 hex |     |    |
//!  |        | 01..99  | !ERR2 / DATA / empty | or ** |     |    |
//!  |        | FF, EE  |                      |       |     |    |
//!  +--------+---------+----------------------+-------+-----+----+
//!  BCC = XOR of every byte from HEADER to the last BODY byte (PLC.md §1, "Frames").
//!  `&` marks a frame of a multi-frame reply that is not the last; `%01**&` asks for the next one.
//! ```

use bytes::{BufMut, Bytes, BytesMut};

use thiserror::Error;

/// Carriage return, the frame terminator (PLC.md §1; MEWTOCOL-COM manual, "Command and response").
pub const CR: u8 = b'\r';
/// Marks a frame of a multi-frame reply after which more frames follow (PLC.md §1, multi-frame).
pub const MORE: u8 = b'&';
/// The two characters that stand for "no BCC check" (PLC.md §1, "Frames").
pub const NO_CHECK: [u8; 2] = *b"**";
/// Bytes of a frame that carry no body: header, station (2), BCC (2) and CR.
pub(super) const ENVELOPE_LEN: usize = 6;

/// The frame header, which also fixes the longest frame a peer accepts (PLC.md §1, "Frames").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Header {
    /// `%`: frames of at most 118 characters, header to CR included.
    Percent,
    /// `<`: frames of at most 2048 characters (FP-X without "H": unverified, PLC.md §1).
    Angle,
}

impl Header {
    /// The header's byte on the link.
    #[must_use]
    pub const fn byte(self) -> u8 {
        match self {
            Self::Percent => b'%',
            Self::Angle => b'<',
        }
    }

    /// The header that `byte` stands for, if any.
    #[must_use]
    pub const fn from_byte(byte: u8) -> Option<Self> {
        match byte {
            b'%' => Some(Self::Percent),
            b'<' => Some(Self::Angle),
            _ => None,
        }
    }

    /// Longest frame under this header, header to CR (and `&`) included: 118 for `%`, 2048 for
    /// `<` (PLC.md §1; MEWTOCOL-COM manual, "Frame length").
    #[must_use]
    pub const fn max_frame_len(self) -> usize {
        match self {
            Self::Percent => 118,
            Self::Angle => 2048,
        }
    }

    /// Longest body (text between station and BCC) of a frame under this header.
    #[must_use]
    pub const fn max_body_len(self, more: bool) -> usize {
        self.max_frame_len() - ENVELOPE_LEN - more as usize
    }
}

/// Whom a frame is for: one station `01`..`99`, every station (`FF`), or whichever answers (`EE`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Station(u8);

impl Station {
    /// `FF`: every station; nobody answers (PLC.md §1, \[doc\]).
    pub const BROADCAST: Self = Self(0xFF);
    /// `EE`: answered by the PLC whatever its station number (PLC.md §1, \[practice\]).
    pub const ANY: Self = Self(0xEE);
    /// Highest station number (PLC.md §1: `01`-`99`).
    pub const MAX_NUMBER: u8 = 99;

    /// Station `number`, which must be 1..=99.
    pub fn new(number: u8) -> Result<Self, FrameError> {
        if (1..=Self::MAX_NUMBER).contains(&number) {
            Ok(Self(number))
        } else {
            Err(FrameError::StationOutOfRange {
                number,
                max: Self::MAX_NUMBER,
            })
        }
    }

    /// The station number, or `None` for `FF` and `EE`.
    #[must_use]
    pub fn number(self) -> Option<u8> {
        (self.0 <= Self::MAX_NUMBER).then_some(self.0)
    }

    /// Whether this is the broadcast station `FF`, which never gets a reply.
    #[must_use]
    pub fn is_broadcast(self) -> bool {
        self == Self::BROADCAST
    }

    /// The two characters on the link.
    #[must_use]
    pub fn to_ascii(self) -> [u8; 2] {
        match self.0 {
            0xFF => *b"FF",
            0xEE => *b"EE",
            n => [b'0' + n / 10, b'0' + n % 10],
        }
    }

    /// The station that two link characters name.
    pub fn from_ascii(chars: [u8; 2]) -> Result<Self, FrameError> {
        match &chars {
            b"FF" => Ok(Self::BROADCAST),
            b"EE" => Ok(Self::ANY),
            [t @ b'0'..=b'9', u @ b'0'..=b'9'] if chars != *b"00" => {
                Ok(Self((t - b'0') * 10 + (u - b'0')))
            }
            _ => Err(FrameError::BadStation { found: chars }),
        }
    }
}

/// How a frame's BCC field is (or was) filled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BccMode {
    /// Two upper-case hex digits of the XOR.
    Checked,
    /// `**`: the receiver does not check.
    Unchecked,
}

/// XOR of `bytes`: the BCC of a frame is that of everything from the header to the last body byte.
#[must_use]
pub fn bcc(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |acc, b| acc ^ b)
}

/// One frame: everything that is not the envelope is `body`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Frame {
    /// `%` or `<`.
    pub header: Header,
    /// Addressed (command) or answering (reply) station.
    pub station: Station,
    /// Text between the station and the BCC, e.g. `#RDD0010000101` or `$WD`; may be empty.
    pub body: Bytes,
    /// Whether the BCC field is the XOR or `**`.
    pub bcc: BccMode,
    /// Whether `&` follows the BCC: more frames of this reply follow.
    pub more: bool,
}

impl Frame {
    /// A single, checked frame with `body`.
    #[must_use]
    pub fn new(header: Header, station: Station, body: impl Into<Bytes>) -> Self {
        Self {
            header,
            station,
            body: body.into(),
            bcc: BccMode::Checked,
            more: false,
        }
    }

    /// `HDR STATION ** & CR`: the host's request for the next frame of a multi-frame reply.
    #[must_use]
    pub fn next_frame_request(header: Header, station: Station) -> Self {
        Self {
            header,
            station,
            body: Bytes::new(),
            bcc: BccMode::Unchecked,
            more: true,
        }
    }

    /// Whether this is the host's request for the next frame of a multi-frame reply.
    #[must_use]
    pub fn is_next_frame_request(&self) -> bool {
        self.body.is_empty() && self.more
    }

    /// Length on the link, header to CR included.
    #[must_use]
    pub fn encoded_len(&self) -> usize {
        ENVELOPE_LEN + self.body.len() + usize::from(self.more)
    }

    /// Appends the frame to `dst`; refuses one longer than its header allows.
    pub fn encode(&self, dst: &mut BytesMut) -> Result<(), FrameError> {
        let len = self.encoded_len();
        let max = self.header.max_frame_len();
        if len > max {
            return Err(FrameError::FrameTooLong { len, max });
        }
        dst.reserve(len);
        let start = dst.len();
        dst.put_u8(self.header.byte());
        dst.put_slice(&self.station.to_ascii());
        dst.put_slice(&self.body);
        let check = match self.bcc {
            BccMode::Checked => hex_byte(bcc(&dst[start..])),
            BccMode::Unchecked => NO_CHECK,
        };
        dst.put_slice(&check);
        if self.more {
            dst.put_u8(MORE);
        }
        dst.put_u8(CR);
        Ok(())
    }

    /// The frame as a fresh byte vector.
    pub fn to_bytes(&self) -> Result<Vec<u8>, FrameError> {
        let mut dst = BytesMut::new();
        self.encode(&mut dst)?;
        Ok(dst.to_vec())
    }
}

/// `byte` as two upper-case hex digits.
#[must_use]
pub(super) fn hex_byte(byte: u8) -> [u8; 2] {
    const DIGITS: &[u8; 16] = b"0123456789ABCDEF";
    [
        DIGITS[usize::from(byte >> 4)],
        DIGITS[usize::from(byte & 0x0F)],
    ]
}

/// The value of one hex digit (either case).
#[must_use]
pub(super) fn hex_digit(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'A'..=b'F' => Some(c - b'A' + 10),
        b'a'..=b'f' => Some(c - b'a' + 10),
        _ => None,
    }
}

/// The byte two hex digits stand for.
#[must_use]
pub(super) fn parse_hex_byte(chars: [u8; 2]) -> Option<u8> {
    Some(hex_digit(chars[0])? << 4 | hex_digit(chars[1])?)
}

/// A frame that is malformed on the link: the link, not the PLC, failed.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum FrameError {
    /// The BCC field does not match the XOR of the frame.
    #[error("bad bcc: frame computes to {expected:02X}, field says {found:02X}")]
    BadBcc {
        /// XOR computed over the received frame.
        expected: u8,
        /// Value in the frame's BCC field.
        found: u8,
    },
    /// The BCC field is neither two hex digits nor `**`.
    #[error("bad bcc field {:?}: expected two hex digits or \"**\"", String::from_utf8_lossy(.found))]
    BadBccDigits {
        /// The two characters found.
        found: [u8; 2],
    },
    /// No CR within the header's frame length limit, or a frame too long to encode.
    #[error("frame of {len} bytes or more has no cr within its header's limit of {max} bytes")]
    FrameTooLong {
        /// Bytes seen (or to be encoded).
        len: usize,
        /// The header's limit, CR included.
        max: usize,
    },
    /// A frame shorter than header, station, BCC and CR.
    #[error("frame of {len} bytes is shorter than the minimum of {min}")]
    FrameTooShort {
        /// Length from header to CR.
        len: usize,
        /// Shortest possible frame.
        min: usize,
    },
    /// A new header arrived before the current frame's CR.
    #[error("frame cut off after {len} bytes by a new header")]
    Truncated {
        /// Bytes of the cut-off frame, header included.
        len: usize,
    },
    /// The station field is not `01`..`99`, `EE` or `FF`.
    #[error("bad station {:?}: expected 01..99, EE or FF", String::from_utf8_lossy(.found))]
    BadStation {
        /// The two characters found.
        found: [u8; 2],
    },
    /// A station number outside 1..=99.
    #[error("station {number} is out of range 1..={max}")]
    StationOutOfRange {
        /// The number given.
        number: u8,
        /// Highest station number.
        max: u8,
    },
}

#[cfg(test)]
mod tests {
    use super::*;

    fn st(n: u8) -> Station {
        Station::new(n).unwrap()
    }

    /// Every golden frame of PLC.md §1 with its BCC.
    #[test]
    fn golden_frames_have_the_documented_bcc() {
        let golden: [(&[u8], &str); 10] = [
            (b"%01#RCSX0000", "1D"),
            (b"%01$RC0", "21"),
            (b"%01#WCSY00061", "2E"),
            (b"%01$WC", "14"),
            (b"%01$WD", "13"),
            (b"%01#RT", "01"),
            (b"%EE#RT", "00"),
            (b"%01#RDD9005290052", "55"),
            (b"<01#RDD0000000001", "4D"),
            (b"%01#WDD001000010700010000E803000088130000000000", "2A"),
        ];
        for (text, expected) in golden {
            assert_eq!(
                hex_byte(bcc(text)),
                expected.as_bytes(),
                "{}",
                String::from_utf8_lossy(text)
            );
        }
    }

    #[test]
    fn encode_appends_bcc_and_cr() {
        let frame = Frame::new(Header::Percent, st(1), &b"#RT"[..]);
        assert_eq!(frame.to_bytes().unwrap(), b"%01#RT01\r");
    }

    #[test]
    fn encode_any_station_ee() {
        let frame = Frame::new(Header::Percent, Station::ANY, &b"#RT"[..]);
        assert_eq!(frame.to_bytes().unwrap(), b"%EE#RT00\r");
    }

    #[test]
    fn encode_broadcast_station_ff() {
        let frame = Frame::new(Header::Percent, Station::BROADCAST, &b"#RT"[..]);
        // '%' ^ 'F' ^ 'F' ^ '#' ^ 'R' ^ 'T' = 0x25 ^ 0x23 ^ 0x52 ^ 0x54 = 0x00
        assert_eq!(frame.to_bytes().unwrap(), b"%FF#RT00\r");
        assert!(Station::BROADCAST.is_broadcast());
        assert_eq!(Station::BROADCAST.number(), None);
    }

    #[test]
    fn next_frame_request_is_unchecked_with_more_marker() {
        let frame = Frame::next_frame_request(Header::Percent, st(1));
        assert_eq!(frame.to_bytes().unwrap(), b"%01**&\r");
        assert!(frame.is_next_frame_request());
    }

    #[test]
    fn encode_refuses_a_frame_longer_than_its_header_allows() {
        let body = vec![b'0'; Header::Percent.max_body_len(false) + 1];
        let err = Frame::new(Header::Percent, st(1), body)
            .to_bytes()
            .unwrap_err();
        assert_eq!(err, FrameError::FrameTooLong { len: 119, max: 118 });
    }

    #[test]
    fn station_parses_numbers_ee_and_ff_and_rejects_00() {
        assert_eq!(Station::from_ascii(*b"07"), Ok(st(7)));
        assert_eq!(Station::from_ascii(*b"EE"), Ok(Station::ANY));
        assert_eq!(Station::from_ascii(*b"FF"), Ok(Station::BROADCAST));
        assert!(Station::from_ascii(*b"00").is_err());
        assert!(Station::from_ascii(*b"1A").is_err());
        assert!(Station::new(100).is_err());
        assert_eq!(st(42).to_ascii(), *b"42");
    }
}
