//! Typed commands (host to PLC): validated values, their `#` text, and back.
//!
//! ```text
//!  HDR ST # R D D sssss eeeee                 read DT s..e
//!  HDR ST # W D D sssss eeeee wwww wwww ...   write DT s..e, 4 hex a word, low byte first
//!  HDR ST # R C S a www b                     read contact a www.b (a = X/Y/R/L, b = hex bit)
//!  HDR ST # W C S a www b v                   write contact (Y/R/L), v = 0/1
//!  HDR ST # R C C a ssss eeee                 read contact words s..e
//!  HDR ST # R T                               PLC status
//!  HDR ST # R M R  /  # R M P                 switch to RUN / PROG
//! ```
//! (PLC.md §1, "Commands linterpd needs"; MEWTOCOL-COM manual, commands RD, WD, RC, WC, RT, RM.)

use bytes::{BufMut, Bytes, BytesMut};

use super::address::{
    Contact, ContactArea, ContactWords, DtRange, parse_contact_words, parse_dt_range,
};
use super::address::{put_contact_words, put_dt_range};
use super::error::MessageError;
use super::frame::{ENVELOPE_LEN, Frame, Header, Station};
use super::words::{WORD_CHARS, expect_len, lossy_head, parse_words, put_words};

/// Characters of `#WDD sssss eeeee` plus the envelope: the cost of a write before its words.
const WRITE_OVERHEAD: usize = ENVELOPE_LEN + 4 + 10;

/// Words one `WD` command frame carries under `header`: 24 for `%`, 507 for `<` (PLC.md §1,
/// "Sizing"). Chunk longer writes into several commands; never send multi-frame commands.
#[must_use]
pub const fn max_write_words(header: Header) -> usize {
    (header.max_frame_len() - WRITE_OVERHEAD) / WORD_CHARS
}

/// RUN or PROG, for `RM`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// `RMR`: run the program.
    Run,
    /// `RMP`: stop, program mode.
    Prog,
}

/// One command the host sends, with validated values.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Command {
    /// `RDD`: read DT words.
    ReadDt(DtRange),
    /// `WDD`: write DT words from `start`; `words` is never empty.
    WriteDt {
        /// First register.
        start: u32,
        /// Words to write, in address order.
        words: Vec<u16>,
    },
    /// `RCS`: read one contact.
    ReadContact(Contact),
    /// `WCS`: write one contact (area Y, R or L).
    WriteContact {
        /// The contact.
        contact: Contact,
        /// On (`1`) or off (`0`).
        on: bool,
    },
    /// `RCC`: read contact words.
    ReadContactWords(ContactWords),
    /// `RT`: read the PLC status.
    Status,
    /// `RM`: switch mode.
    SetMode(Mode),
}

impl Command {
    /// A `WDD` writing `words` from DT `start`, with its range checked.
    pub fn write_dt(start: u32, words: Vec<u16>) -> Result<Self, MessageError> {
        DtRange::from_len(start, words.len())?;
        Ok(Self::WriteDt { start, words })
    }

    /// A `WCS` for `contact`, which must not be an input (X).
    pub fn write_contact(contact: Contact, on: bool) -> Result<Self, MessageError> {
        if contact.area() == ContactArea::X {
            return Err(MessageError::ContactNotWritable { area: 'X' });
        }
        Ok(Self::WriteContact { contact, on })
    }

    /// The command's frame to `station` under `header`; refuses what one frame cannot carry.
    pub fn to_frame(&self, header: Header, station: Station) -> Result<Frame, MessageError> {
        Ok(Frame::new(header, station, self.encode_body(header)?))
    }

    /// The body text, `#` included.
    pub fn encode_body(&self, header: Header) -> Result<Bytes, MessageError> {
        let mut dst = BytesMut::with_capacity(32);
        dst.put_u8(b'#');
        match self {
            Self::ReadDt(range) => put_dt_range(&mut dst, b"RDD", *range),
            Self::WriteDt { start, words } => put_write(&mut dst, header, *start, words)?,
            Self::ReadContact(contact) => {
                dst.put_slice(b"RCS");
                contact.put(&mut dst);
            }
            Self::WriteContact { contact, on } => put_write_contact(&mut dst, *contact, *on)?,
            Self::ReadContactWords(range) => put_contact_words(&mut dst, *range),
            Self::Status => dst.put_slice(b"RT"),
            Self::SetMode(Mode::Run) => dst.put_slice(b"RMR"),
            Self::SetMode(Mode::Prog) => dst.put_slice(b"RMP"),
        }
        Ok(dst.freeze())
    }

    /// The command a frame body (`#` included) spells.
    pub fn parse(body: &[u8]) -> Result<Self, MessageError> {
        let Some((b'#', text)) = body.split_first() else {
            let found = body.first().map(|&b| char::from(b));
            return Err(MessageError::BadMarker {
                found,
                expected: "#",
            });
        };
        match text {
            [b'R', b'D', b'D', rest @ ..] => parse_dt_range(rest).map(Self::ReadDt),
            [b'W', b'D', b'D', rest @ ..] => parse_write(rest),
            [b'R', b'C', b'S', rest @ ..] => Contact::parse(rest).map(Self::ReadContact),
            [b'W', b'C', b'S', rest @ ..] => parse_write_contact(rest),
            [b'R', b'C', b'C', rest @ ..] => parse_contact_words(rest).map(Self::ReadContactWords),
            b"RT" => Ok(Self::Status),
            b"RMR" => Ok(Self::SetMode(Mode::Run)),
            b"RMP" => Ok(Self::SetMode(Mode::Prog)),
            _ => Err(MessageError::UnknownCommand {
                text: lossy_head(text),
            }),
        }
    }

    /// Characters of this command's successful reply body (`$`, code and data): with
    /// [`super::reply_wire`], the reply's frames and their characters on the wire.
    #[must_use]
    pub fn reply_body_len(&self) -> usize {
        let data = match self {
            Self::ReadDt(range) => range.len() * WORD_CHARS,
            Self::ReadContactWords(range) => range.len() * WORD_CHARS,
            Self::ReadContact(_) => 1,
            // CPU type, version, program size, mode, link, error flag, self-diagnostic.
            Self::Status => 16,
            Self::WriteDt { .. } | Self::WriteContact { .. } | Self::SetMode(_) => 0,
        };
        3 + data
    }

    /// The two letters a successful reply to this command starts with (after `$`).
    #[must_use]
    pub fn reply_code(&self) -> [u8; 2] {
        match self {
            Self::ReadDt(_) => *b"RD",
            Self::WriteDt { .. } => *b"WD",
            Self::ReadContact(_) | Self::ReadContactWords(_) => *b"RC",
            Self::WriteContact { .. } => *b"WC",
            Self::Status => *b"RT",
            Self::SetMode(_) => *b"RM",
        }
    }
}

fn put_write(
    dst: &mut BytesMut,
    header: Header,
    start: u32,
    words: &[u16],
) -> Result<(), MessageError> {
    let max = max_write_words(header);
    if words.len() > max {
        return Err(MessageError::TooManyWords {
            words: words.len(),
            max,
            header,
        });
    }
    put_dt_range(dst, b"WDD", DtRange::from_len(start, words.len())?);
    put_words(dst, words);
    Ok(())
}

fn put_write_contact(dst: &mut BytesMut, contact: Contact, on: bool) -> Result<(), MessageError> {
    if contact.area() == ContactArea::X {
        return Err(MessageError::ContactNotWritable { area: 'X' });
    }
    dst.put_slice(b"WCS");
    contact.put(dst);
    dst.put_u8(if on { b'1' } else { b'0' });
    Ok(())
}

fn parse_write(text: &[u8]) -> Result<Command, MessageError> {
    let range = parse_dt_range(text.get(..10).unwrap_or(text))?;
    let words = parse_words("write data", &text[10..])?;
    if words.len() != range.len() {
        return Err(MessageError::WordCount {
            expected: range.len(),
            found: words.len(),
        });
    }
    Ok(Command::WriteDt {
        start: range.start(),
        words,
    })
}

fn parse_write_contact(text: &[u8]) -> Result<Command, MessageError> {
    expect_len("contact write", text, 6)?;
    let contact = Contact::parse(&text[..5])?;
    let on = match text[5] {
        b'0' => false,
        b'1' => true,
        other => {
            let found = char::from(other);
            return Err(MessageError::BadDigit {
                field: "contact value",
                found,
                expected: "0 or 1",
            });
        }
    };
    Command::write_contact(contact, on)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame_bytes(command: &Command, header: Header) -> Vec<u8> {
        command
            .to_frame(header, Station::new(1).unwrap())
            .unwrap()
            .to_bytes()
            .unwrap()
    }

    fn round_trip(command: &Command) {
        let body = command.encode_body(Header::Angle).unwrap();
        assert_eq!(&Command::parse(&body).unwrap(), command, "{body:?}");
    }

    #[test]
    fn read_contact_golden_frame() {
        let x0 = Contact::new(ContactArea::X, 0, 0).unwrap();
        // % | 01 station | # | RCS | X area | 000 word | 0 bit | 1D bcc
        assert_eq!(
            frame_bytes(&Command::ReadContact(x0), Header::Percent),
            b"%01#RCSX00001D\r"
        );
    }

    #[test]
    fn write_contact_golden_frame() {
        let y6 = Contact::new(ContactArea::Y, 0, 6).unwrap();
        let command = Command::write_contact(y6, true).unwrap();
        // % | 01 | # | WCS | Y | 000 | 6 | 1 = on | 2E
        assert_eq!(frame_bytes(&command, Header::Percent), b"%01#WCSY000612E\r");
    }

    #[test]
    fn status_and_read_dt_golden_frames() {
        assert_eq!(
            frame_bytes(&Command::Status, Header::Percent),
            b"%01#RT01\r"
        );
        let special = Command::ReadDt(DtRange::new(90_052, 90_052).unwrap());
        // % | 01 | # | RDD | 90052 start | 90052 end | 55
        assert_eq!(
            frame_bytes(&special, Header::Percent),
            b"%01#RDD900529005255\r"
        );
        let first = Command::ReadDt(DtRange::new(0, 1).unwrap());
        assert_eq!(frame_bytes(&first, Header::Angle), b"<01#RDD00000000014D\r");
    }

    #[test]
    fn write_of_an_eight_word_table_golden_frame() {
        // control code 0x00000100, frequency 1000, target 5000, end 0: low word first.
        let words = vec![0x0100, 0, 1000, 0, 5000, 0, 0, 0];
        let command = Command::write_dt(100, words).unwrap();
        let expected = b"%01#WDD001000010700010000E803000088130000000000002A\r";
        assert_eq!(frame_bytes(&command, Header::Percent), expected);
    }

    #[test]
    fn every_command_round_trips_through_its_text() {
        let r1 = Contact::new(ContactArea::R, 0, 1).unwrap();
        let commands = [
            Command::ReadDt(DtRange::new(100, 107).unwrap()),
            Command::write_dt(32_760, vec![1, 2, 3, 0xFFFF, 0x1234]).unwrap(),
            Command::ReadContact(r1),
            Command::write_contact(r1, false).unwrap(),
            Command::ReadContactWords(ContactWords::new(ContactArea::L, 10, 12).unwrap()),
            Command::Status,
            Command::SetMode(Mode::Run),
            Command::SetMode(Mode::Prog),
        ];
        for command in &commands {
            round_trip(command);
        }
    }

    #[test]
    fn contact_r1_is_word_0_bit_1() {
        let body = Command::ReadContact(Contact::new(ContactArea::R, 0, 1).unwrap())
            .encode_body(Header::Percent)
            .unwrap();
        assert_eq!(&body[..], b"#RCSR0001");
        let rf = Contact::new(ContactArea::R, 12, 15).unwrap();
        assert_eq!(
            &Command::ReadContact(rf)
                .encode_body(Header::Percent)
                .unwrap()[..],
            b"#RCSR012F"
        );
    }

    #[test]
    fn write_limits_are_24_words_for_percent_and_507_for_angle() {
        assert_eq!(max_write_words(Header::Percent), 24);
        assert_eq!(max_write_words(Header::Angle), 507);
        let fits = Command::write_dt(0, vec![0; 24]).unwrap();
        assert_eq!(frame_bytes(&fits, Header::Percent).len(), 116);
        let too_many = Command::write_dt(0, vec![0; 25]).unwrap();
        let err = too_many
            .to_frame(Header::Percent, Station::ANY)
            .unwrap_err();
        assert_eq!(
            err,
            MessageError::TooManyWords {
                words: 25,
                max: 24,
                header: Header::Percent
            }
        );
        assert!(too_many.to_frame(Header::Angle, Station::ANY).is_ok());
        let angle_max = Command::write_dt(0, vec![0; 507]).unwrap();
        let bytes = angle_max
            .to_frame(Header::Angle, Station::ANY)
            .unwrap()
            .to_bytes()
            .unwrap();
        assert_eq!(bytes.len(), 2048);
    }

    #[test]
    fn parse_rejects_bad_commands_with_typed_errors() {
        assert!(matches!(
            Command::parse(b"#XX"),
            Err(MessageError::UnknownCommand { .. })
        ));
        assert!(matches!(
            Command::parse(b"$RT"),
            Err(MessageError::BadMarker { .. })
        ));
        assert!(matches!(
            Command::parse(b""),
            Err(MessageError::BadMarker { found: None, .. })
        ));
        assert!(matches!(
            Command::parse(b"#RDD00001"),
            Err(MessageError::BadLength { .. })
        ));
        assert!(matches!(
            Command::parse(b"#RDD0000A00001"),
            Err(MessageError::BadDigit { .. })
        ));
        let short_write = Command::parse(b"#WDD0000000001E803");
        assert_eq!(
            short_write,
            Err(MessageError::WordCount {
                expected: 2,
                found: 1
            })
        );
        assert!(matches!(
            Command::parse(b"#WCSX00001"),
            Err(MessageError::ContactNotWritable { .. })
        ));
        assert!(matches!(
            Command::parse(b"#RCSQ0000"),
            Err(MessageError::BadDigit { .. })
        ));
    }

    #[test]
    fn parse_errors_map_to_plc_codes() {
        use crate::mewtocol::PlcErrorCode;
        let code = |body: &[u8]| Command::parse(body).unwrap_err().plc_code();
        assert_eq!(code(b"#XX"), PlcErrorCode::NotSupported);
        assert_eq!(code(b"#RDD3276532765"), PlcErrorCode::AddressError);
        assert_eq!(code(b"#RDD0000500001"), PlcErrorCode::DataError);
        assert_eq!(code(b"#WDD0000000000ZZ00"), PlcErrorCode::DataError);
        assert_eq!(code(b"#RDD0"), PlcErrorCode::FormatError);
    }
}
