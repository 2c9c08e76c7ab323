//! Typed replies (PLC to host): `$` success with its data, or `!` refusal with its code.
//!
//! ```text
//!  HDR ST $ R D wwww wwww ...   DT words, 4 hex each, low byte first
//!  HDR ST $ W D                 write done
//!  HDR ST $ R C v               one contact, v = 0/1          (answers RCS)
//!  HDR ST $ R C wwww ...        contact words                 (answers RCC)
//!  HDR ST $ W C                 contact written
//!  HDR ST $ R T cc vv pp mm ll ee dddd   status (see PlcStatus)
//!  HDR ST $ R M                 mode switched
//!  HDR ST ! e e                 refused: 2 decimal digits (see PlcErrorCode)
//! ```
//! (PLC.md §1, "Frames", "Commands linterpd needs", "Error codes"; MEWTOCOL-COM manual.)

use bytes::{BufMut, Bytes, BytesMut};

use super::command::Command;
use super::error::{MessageError, PlcError, PlcErrorCode};
use super::frame::{ENVELOPE_LEN, Header, hex_byte};
use super::words::{WORD_CHARS, expect_len, lossy_head, parse_byte, parse_decimal, parse_words};
use super::words::{put_word, put_words};

/// A reply as the host sees it: data, or the PLC's refusal.
pub type Response = Result<Reply, PlcError>;

/// Characters of `$RD` plus the envelope: the cost of a read reply before its words.
const READ_REPLY_OVERHEAD: usize = ENVELOPE_LEN + 3;

/// Words a single-frame `RD` reply carries under `header`: 27 for `%`, 509 for `<` (PLC.md §1,
/// "Sizing"). A longer read comes back as a multi-frame reply.
#[must_use]
pub const fn max_read_reply_words(header: Header) -> usize {
    (header.max_frame_len() - READ_REPLY_OVERHEAD) / WORD_CHARS
}

/// The `RT` status data (PLC.md §1: 2+2+2+2+2+2+4 characters).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct PlcStatus {
    /// CPU type code.
    pub cpu_type: u8,
    /// CPU version.
    pub version: u8,
    /// Program size code.
    pub program_size: u8,
    /// Mode flags; bit 0 = RUN.
    pub mode_flags: u8,
    /// Link information.
    pub link_info: u8,
    /// Error flags.
    pub error_flags: u8,
    /// Self-diagnostic error code (a word, low byte first as every word \[practice\]).
    pub self_diagnostic: u16,
}

impl PlcStatus {
    /// Characters of the status data.
    pub const CHARS: usize = 16;

    /// Whether the PLC is in RUN mode (mode flags bit 0).
    #[must_use]
    pub fn is_running(self) -> bool {
        self.mode_flags & 1 != 0
    }

    fn put(self, dst: &mut BytesMut) {
        let bytes = [
            self.cpu_type,
            self.version,
            self.program_size,
            self.mode_flags,
            self.link_info,
            self.error_flags,
        ];
        for byte in bytes {
            dst.put_slice(&hex_byte(byte));
        }
        put_word(dst, self.self_diagnostic);
    }

    fn parse(text: &[u8]) -> Result<Self, MessageError> {
        expect_len("status data", text, Self::CHARS)?;
        let byte = |i: usize| parse_byte("status data", [text[2 * i], text[2 * i + 1]]);
        Ok(Self {
            cpu_type: byte(0)?,
            version: byte(1)?,
            program_size: byte(2)?,
            mode_flags: byte(3)?,
            link_info: byte(4)?,
            error_flags: byte(5)?,
            self_diagnostic: parse_words("status data", &text[12..])?[0],
        })
    }
}

/// A successful reply, with the data its command asked for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// `RD`: the DT words read.
    ReadDt(Vec<u16>),
    /// `WD`: DT written.
    WriteDt,
    /// `RC` with one character: the contact's state.
    ReadContact(bool),
    /// `RC` with words: the contact words read.
    ReadContactWords(Vec<u16>),
    /// `WC`: contact written.
    WriteContact,
    /// `RT`: the PLC status.
    Status(PlcStatus),
    /// `RM`: mode switched.
    SetMode,
}

impl Reply {
    /// Whether this reply is the kind (and size) `command` asks for.
    #[must_use]
    pub fn answers(&self, command: &Command) -> bool {
        match (self, command) {
            (Self::ReadDt(words), Command::ReadDt(range)) => words.len() == range.len(),
            (Self::ReadContactWords(words), Command::ReadContactWords(range)) => {
                words.len() == range.len()
            }
            (Self::WriteDt, Command::WriteDt { .. })
            | (Self::ReadContact(_), Command::ReadContact(_))
            | (Self::WriteContact, Command::WriteContact { .. })
            | (Self::Status(_), Command::Status)
            | (Self::SetMode, Command::SetMode(_)) => true,
            _ => false,
        }
    }

    /// The body text, `$` included.
    #[must_use]
    pub fn encode_body(&self) -> Bytes {
        let mut dst = BytesMut::with_capacity(16);
        dst.put_u8(b'$');
        match self {
            Self::ReadDt(words) => put_code_words(&mut dst, b"RD", words),
            Self::WriteDt => dst.put_slice(b"WD"),
            Self::ReadContact(on) => dst.put_slice(if *on { b"RC1" } else { b"RC0" }),
            Self::ReadContactWords(words) => put_code_words(&mut dst, b"RC", words),
            Self::WriteContact => dst.put_slice(b"WC"),
            Self::Status(status) => {
                dst.put_slice(b"RT");
                status.put(&mut dst);
            }
            Self::SetMode => dst.put_slice(b"RM"),
        }
        dst.freeze()
    }

    /// The reply that `$` text (`$` excluded: code and data) spells.
    fn parse_ok(text: &[u8]) -> Result<Self, MessageError> {
        match text {
            [b'R', b'D', data @ ..] => parse_words("read data", data).map(Self::ReadDt),
            b"WD" => Ok(Self::WriteDt),
            b"RC0" => Ok(Self::ReadContact(false)),
            b"RC1" => Ok(Self::ReadContact(true)),
            [b'R', b'C', data @ ..] if !data.is_empty() => {
                parse_words("contact words", data).map(Self::ReadContactWords)
            }
            b"WC" => Ok(Self::WriteContact),
            [b'R', b'T', data @ ..] => PlcStatus::parse(data).map(Self::Status),
            b"RM" => Ok(Self::SetMode),
            _ => Err(MessageError::UnknownCommand {
                text: lossy_head(text),
            }),
        }
    }
}

fn put_code_words(dst: &mut BytesMut, code: &[u8], words: &[u16]) {
    dst.put_slice(code);
    put_words(dst, words);
}

/// The body text of a response: `$...` or `!ee`.
#[must_use]
pub fn encode_response(response: &Response) -> Bytes {
    match response {
        Ok(reply) => reply.encode_body(),
        Err(refusal) => {
            let number = refusal.code.number() % 100;
            Bytes::from(vec![b'!', b'0' + number / 10, b'0' + number % 10])
        }
    }
}

/// The response a whole reply body (`$` or `!` included) spells.
pub fn parse_response(body: &[u8]) -> Result<Response, MessageError> {
    match body.split_first() {
        Some((b'$', text)) => Reply::parse_ok(text).map(Ok),
        Some((b'!', code)) => {
            expect_len("error code", code, 2)?;
            let number = parse_decimal("error code", code)? as u8;
            Ok(Err(PlcError {
                code: PlcErrorCode::from_number(number),
            }))
        }
        other => Err(MessageError::BadMarker {
            found: other.map(|(&b, _)| char::from(b)),
            expected: "$ or !",
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mewtocol::address::DtRange;
    use crate::mewtocol::frame::{Frame, Station};

    fn reply_bytes(response: &Response) -> Vec<u8> {
        let station = Station::new(1).unwrap();
        Frame::new(Header::Percent, station, encode_response(response))
            .to_bytes()
            .unwrap()
    }

    #[test]
    fn ok_replies_golden_frames() {
        // % | 01 | $ | RC | 0 = off | 21
        assert_eq!(reply_bytes(&Ok(Reply::ReadContact(false))), b"%01$RC021\r");
        assert_eq!(reply_bytes(&Ok(Reply::WriteContact)), b"%01$WC14\r");
        assert_eq!(reply_bytes(&Ok(Reply::WriteDt)), b"%01$WD13\r");
    }

    #[test]
    fn read_reply_words_are_low_byte_first() {
        let body = Reply::ReadDt(vec![100, 0x1234]).encode_body();
        assert_eq!(&body[..], b"$RD64003412");
        assert_eq!(
            parse_response(&body),
            Ok(Ok(Reply::ReadDt(vec![100, 0x1234])))
        );
    }

    #[test]
    fn read_reply_limits_are_27_words_for_percent_and_509_for_angle() {
        assert_eq!(max_read_reply_words(Header::Percent), 27);
        assert_eq!(max_read_reply_words(Header::Angle), 509);
        let fits = reply_bytes(&Ok(Reply::ReadDt(vec![0; 27])));
        assert!(fits.len() <= Header::Percent.max_frame_len());
        let body = encode_response(&Ok(Reply::ReadDt(vec![0; 28])));
        assert!(body.len() > Header::Percent.max_body_len(false));
    }

    #[test]
    fn error_reply_becomes_a_typed_plc_error() {
        let response = parse_response(b"!61").unwrap();
        assert_eq!(
            response,
            Err(PlcError {
                code: PlcErrorCode::DataError
            })
        );
        assert_eq!(
            parse_response(b"!99"),
            Ok(Err(PlcError {
                code: PlcErrorCode::Other(99)
            }))
        );
        assert_eq!(
            &encode_response(&Err(PlcError {
                code: PlcErrorCode::AddressError
            }))[..],
            b"!66"
        );
        assert!(matches!(
            parse_response(b"!6"),
            Err(MessageError::BadLength { .. })
        ));
    }

    #[test]
    fn status_reply_round_trips_and_reads_run_flag() {
        let status = PlcStatus {
            cpu_type: 0x72,
            version: 0x12,
            program_size: 0x32,
            mode_flags: 0x81,
            link_info: 0,
            error_flags: 0,
            self_diagnostic: 0x0102,
        };
        let body = Reply::Status(status).encode_body();
        assert_eq!(&body[..], b"$RT7212328100000201");
        let Ok(Ok(Reply::Status(back))) = parse_response(&body) else {
            panic!("{body:?}")
        };
        assert_eq!(back, status);
        assert!(back.is_running());
        assert!(
            !PlcStatus {
                mode_flags: 0x80,
                ..status
            }
            .is_running()
        );
    }

    #[test]
    fn contact_reply_is_told_from_contact_words_by_length() {
        assert_eq!(parse_response(b"$RC1"), Ok(Ok(Reply::ReadContact(true))));
        assert_eq!(
            parse_response(b"$RC0100"),
            Ok(Ok(Reply::ReadContactWords(vec![1])))
        );
        assert!(parse_response(b"$RC2").is_err());
    }

    #[test]
    fn malformed_replies_are_message_errors() {
        assert!(matches!(
            parse_response(b""),
            Err(MessageError::BadMarker { .. })
        ));
        assert!(matches!(
            parse_response(b"#RT"),
            Err(MessageError::BadMarker { .. })
        ));
        assert!(matches!(
            parse_response(b"$ZZ"),
            Err(MessageError::UnknownCommand { .. })
        ));
        assert!(matches!(
            parse_response(b"$RD640"),
            Err(MessageError::BadLength { .. })
        ));
        assert!(matches!(
            parse_response(b"$RT00"),
            Err(MessageError::BadLength { .. })
        ));
    }

    #[test]
    fn reply_answers_its_command_only() {
        let read = Command::ReadDt(DtRange::new(0, 1).unwrap());
        assert!(Reply::ReadDt(vec![1, 2]).answers(&read));
        assert!(!Reply::ReadDt(vec![1]).answers(&read));
        assert!(!Reply::WriteDt.answers(&read));
        assert!(Reply::Status(PlcStatus::default()).answers(&Command::Status));
    }
}
