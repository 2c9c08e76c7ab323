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

use super::error::MessageError;
use super::frame::{ENVELOPE_LEN, Frame, Header, Station, hex_digit};
use super::words::{WORD_CHARS, parse_decimal, parse_words, put_decimal, put_words};

/// Highest data register of an FP-X C30/C60 (PLC.md §1 and §3: DT0-DT32764).
pub const DT_MAX: u32 = 32_764;
/// Special data registers DT90000.. (FP-X user manual, "Special data registers"; PLC.md §3 uses
/// DT90052). The block's true end differs per CPU [unverified]; this module accepts up to DT90999.
pub const SPECIAL_DT: std::ops::RangeInclusive<u32> = 90_000..=90_999;
/// Highest contact word in `RCS`/`WCS` (3 decimal digits).
pub const CONTACT_WORD_MAX: u16 = 999;
/// Highest contact word in `RCC` (4 decimal digits).
pub const CONTACT_WORDS_MAX: u16 = 9_999;
/// Characters of `#WDD sssss eeeee` plus the envelope: the cost of a write before its words.
const WRITE_OVERHEAD: usize = ENVELOPE_LEN + 4 + 10;

/// Words one `WD` command frame carries under `header`: 24 for `%`, 507 for `<` (PLC.md §1,
/// "Sizing"). Chunk longer writes into several commands; never send multi-frame commands.
#[must_use]
pub const fn max_write_words(header: Header) -> usize {
    (header.max_frame_len() - WRITE_OVERHEAD) / WORD_CHARS
}

/// An inclusive range of DT registers, within DT0..=DT32764 or within the special block.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DtRange {
    start: u32,
    end: u32,
}

impl DtRange {
    /// DT `start` ..= DT `end`.
    pub fn new(start: u32, end: u32) -> Result<Self, MessageError> {
        check_dt(start)?;
        check_dt(end)?;
        if start > end {
            return Err(MessageError::StartAfterEnd { start, end });
        }
        if SPECIAL_DT.contains(&start) != SPECIAL_DT.contains(&end) {
            return Err(MessageError::AddressOutOfRange {
                area: "DT",
                address: end,
                max: DT_MAX,
            });
        }
        Ok(Self { start, end })
    }

    /// `len` (at least 1) registers from DT `start`.
    pub fn from_len(start: u32, len: usize) -> Result<Self, MessageError> {
        let last = u32::try_from(len)
            .ok()
            .and_then(|n| start.checked_add(n.checked_sub(1)?));
        let end = last.ok_or(MessageError::WordCount {
            expected: 1,
            found: len,
        })?;
        Self::new(start, end)
    }

    /// First register.
    #[must_use]
    pub fn start(self) -> u32 {
        self.start
    }

    /// Last register (inclusive).
    #[must_use]
    pub fn end(self) -> u32 {
        self.end
    }

    /// Number of registers.
    #[must_use]
    #[allow(clippy::len_without_is_empty)] // never empty
    pub fn len(self) -> usize {
        (self.end - self.start) as usize + 1
    }
}

fn check_dt(address: u32) -> Result<(), MessageError> {
    if address <= DT_MAX || SPECIAL_DT.contains(&address) {
        Ok(())
    } else {
        Err(MessageError::AddressOutOfRange {
            area: "DT",
            address,
            max: DT_MAX,
        })
    }
}

/// A contact area that `RCS`/`WCS`/`RCC` name with one letter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ContactArea {
    /// External inputs (read only).
    X,
    /// External outputs.
    Y,
    /// Internal relays.
    R,
    /// Link relays.
    L,
}

impl ContactArea {
    /// The area's letter on the link.
    #[must_use]
    pub fn letter(self) -> u8 {
        match self {
            Self::X => b'X',
            Self::Y => b'Y',
            Self::R => b'R',
            Self::L => b'L',
        }
    }

    /// The area a letter names.
    pub fn from_letter(letter: u8) -> Result<Self, MessageError> {
        match letter {
            b'X' => Ok(Self::X),
            b'Y' => Ok(Self::Y),
            b'R' => Ok(Self::R),
            b'L' => Ok(Self::L),
            _ => Err(MessageError::BadDigit {
                field: "contact area",
                found: char::from(letter),
                expected: "X, Y, R or L",
            }),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::X => "X",
            Self::Y => "Y",
            Self::R => "R",
            Self::L => "L",
        }
    }
}

/// One contact: area, word 0..=999 and bit 0..=15 (`R1` = word 0, bit 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Contact {
    area: ContactArea,
    word: u16,
    bit: u8,
}

impl Contact {
    /// Contact `area` `word`.`bit`.
    pub fn new(area: ContactArea, word: u16, bit: u8) -> Result<Self, MessageError> {
        let max = u32::from(CONTACT_WORD_MAX);
        if word > CONTACT_WORD_MAX {
            return Err(MessageError::AddressOutOfRange {
                area: area.name(),
                address: word.into(),
                max,
            });
        }
        if bit > 15 {
            return Err(MessageError::AddressOutOfRange {
                area: "bit",
                address: bit.into(),
                max: 15,
            });
        }
        Ok(Self { area, word, bit })
    }

    /// The contact's area.
    #[must_use]
    pub fn area(self) -> ContactArea {
        self.area
    }

    /// The contact's word.
    #[must_use]
    pub fn word(self) -> u16 {
        self.word
    }

    /// The contact's bit in its word.
    #[must_use]
    pub fn bit(self) -> u8 {
        self.bit
    }

    fn put(self, dst: &mut BytesMut) {
        dst.put_u8(self.area.letter());
        put_decimal(dst, self.word.into(), 3);
        dst.put_u8(b"0123456789ABCDEF"[usize::from(self.bit)]);
    }

    fn parse(text: &[u8]) -> Result<Self, MessageError> {
        expect_len("contact", text, 5)?;
        let area = ContactArea::from_letter(text[0])?;
        let word = parse_decimal("contact word", &text[1..4])? as u16;
        let bit = hex_digit(text[4]).ok_or(MessageError::BadDigit {
            field: "contact bit",
            found: char::from(text[4]),
            expected: "a hex digit",
        })?;
        Self::new(area, word, bit)
    }
}

/// An inclusive range of contact words in one area, for `RCC`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ContactWords {
    area: ContactArea,
    start: u16,
    end: u16,
}

impl ContactWords {
    /// Words `start` ..= `end` of `area`.
    pub fn new(area: ContactArea, start: u16, end: u16) -> Result<Self, MessageError> {
        let max = u32::from(CONTACT_WORDS_MAX);
        if end > CONTACT_WORDS_MAX {
            return Err(MessageError::AddressOutOfRange {
                area: area.name(),
                address: end.into(),
                max,
            });
        }
        if start > end {
            return Err(MessageError::StartAfterEnd {
                start: start.into(),
                end: end.into(),
            });
        }
        Ok(Self { area, start, end })
    }

    /// The area.
    #[must_use]
    pub fn area(self) -> ContactArea {
        self.area
    }

    /// Number of words.
    #[must_use]
    #[allow(clippy::len_without_is_empty)] // never empty
    pub fn len(self) -> usize {
        usize::from(self.end - self.start) + 1
    }
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
        if contact.area == ContactArea::X {
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

fn put_dt_range(dst: &mut BytesMut, code: &[u8], range: DtRange) {
    dst.put_slice(code);
    put_decimal(dst, range.start, 5);
    put_decimal(dst, range.end, 5);
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
    if contact.area == ContactArea::X {
        return Err(MessageError::ContactNotWritable { area: 'X' });
    }
    dst.put_slice(b"WCS");
    contact.put(dst);
    dst.put_u8(if on { b'1' } else { b'0' });
    Ok(())
}

fn put_contact_words(dst: &mut BytesMut, range: ContactWords) {
    dst.put_slice(b"RCC");
    dst.put_u8(range.area.letter());
    put_decimal(dst, range.start.into(), 4);
    put_decimal(dst, range.end.into(), 4);
}

fn parse_dt_range(text: &[u8]) -> Result<DtRange, MessageError> {
    expect_len("dt range", text, 10)?;
    let start = parse_decimal("dt start", &text[..5])?;
    let end = parse_decimal("dt end", &text[5..])?;
    DtRange::new(start, end)
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
        start: range.start,
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

fn parse_contact_words(text: &[u8]) -> Result<ContactWords, MessageError> {
    expect_len("contact words", text, 9)?;
    let area = ContactArea::from_letter(text[0])?;
    let start = parse_decimal("contact start", &text[1..5])? as u16;
    let end = parse_decimal("contact end", &text[5..9])? as u16;
    ContactWords::new(area, start, end)
}

/// Refuses `text` unless it is `len` characters long.
pub(super) fn expect_len(field: &'static str, text: &[u8], len: usize) -> Result<(), MessageError> {
    if text.len() == len {
        Ok(())
    } else {
        Err(MessageError::BadLength {
            field,
            len: text.len(),
            expected: len.to_string(),
        })
    }
}

/// The first few characters of `text`, for error messages.
pub(super) fn lossy_head(text: &[u8]) -> String {
    String::from_utf8_lossy(&text[..text.len().min(8)]).into_owned()
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
    fn dt_addresses_beyond_32764_are_refused_with_the_limit() {
        let err = DtRange::new(32_764, 32_765).unwrap_err();
        assert_eq!(
            err,
            MessageError::AddressOutOfRange {
                area: "DT",
                address: 32_765,
                max: 32_764
            }
        );
        assert_eq!(
            err.to_string(),
            "DT address 32765 is out of range 0..=32764"
        );
        assert!(Command::write_dt(32_764, vec![1, 2]).is_err());
        assert!(Command::write_dt(0, vec![]).is_err());
        assert_eq!(
            DtRange::new(5, 4),
            Err(MessageError::StartAfterEnd { start: 5, end: 4 })
        );
        assert_eq!(DtRange::from_len(10, 3).unwrap().end(), 12);
    }

    #[test]
    fn contact_values_are_range_checked() {
        assert!(Contact::new(ContactArea::R, 1000, 0).is_err());
        assert!(Contact::new(ContactArea::R, 0, 16).is_err());
        assert!(ContactWords::new(ContactArea::R, 3, 2).is_err());
        let x = Contact::new(ContactArea::X, 0, 0).unwrap();
        assert_eq!(
            Command::write_contact(x, true),
            Err(MessageError::ContactNotWritable { area: 'X' })
        );
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
