//! PLC addresses as commands name them: DT register ranges and contacts, validated, with their text.
//!
//! ```text
//!  DT range        sssss eeeee      5 decimal digits each: DT0..=DT32764 (or DT90000..)
//!  contact         a www b          area X/Y/R/L, 3 decimal digits word, 1 hex digit bit
//!                                   (R1 = "R0001": word 0, bit 1)
//!  contact words   a ssss eeee      area, 4 decimal digits each
//! ```
//! (PLC.md §1, "Commands linterpd needs"; MEWTOCOL-COM manual, commands RD, WD, RCS, WCS, RCC.)

use bytes::{BufMut, BytesMut};

use super::error::MessageError;
use super::frame::hex_digit;
use super::words::{expect_len, parse_decimal, put_decimal};

/// Highest data register of an FP-X C30/C60 (PLC.md §1 and §3: DT0-DT32764).
pub const DT_MAX: u32 = 32_764;
/// Special data registers DT90000.. (FP-X user manual, "Special data registers"; PLC.md §3 uses
/// DT90052). The block's true end differs per CPU \[unverified\]; this module accepts up to DT90999.
pub const SPECIAL_DT: std::ops::RangeInclusive<u32> = 90_000..=90_999;
/// Highest contact word in `RCS`/`WCS` (3 decimal digits).
pub const CONTACT_WORD_MAX: u16 = 999;
/// Highest contact word in `RCC` (4 decimal digits).
pub const CONTACT_WORDS_MAX: u16 = 9_999;
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

/// Refuses `address` of `area` past `max`.
fn at_most(area: &'static str, address: u16, max: u16) -> Result<(), MessageError> {
    if address > max {
        return Err(MessageError::AddressOutOfRange {
            area,
            address: address.into(),
            max: max.into(),
        });
    }
    Ok(())
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
        at_most(area.name(), word, CONTACT_WORD_MAX)?;
        at_most("bit", bit.into(), 15)?;
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

    /// Appends area letter, 3-digit word and hex bit.
    pub(super) fn put(self, dst: &mut BytesMut) {
        dst.put_u8(self.area.letter());
        put_decimal(dst, self.word.into(), 3);
        dst.put_u8(b"0123456789ABCDEF"[usize::from(self.bit)]);
    }

    /// The contact 5 characters (area, 3-digit word, hex bit) spell.
    pub(super) fn parse(text: &[u8]) -> Result<Self, MessageError> {
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
        at_most(area.name(), end, CONTACT_WORDS_MAX)?;
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

    /// The first word.
    #[must_use]
    pub fn start(self) -> u16 {
        self.start
    }

    /// Number of words.
    #[must_use]
    #[allow(clippy::len_without_is_empty)] // never empty
    pub fn len(self) -> usize {
        usize::from(self.end - self.start) + 1
    }
}

/// Appends `code` and the range as two 5-digit decimal addresses.
pub(super) fn put_dt_range(dst: &mut BytesMut, code: &[u8], range: DtRange) {
    dst.put_slice(code);
    put_decimal(dst, range.start(), 5);
    put_decimal(dst, range.end(), 5);
}

/// Appends `RCC`, the area letter and the range as two 4-digit decimal words.
pub(super) fn put_contact_words(dst: &mut BytesMut, range: ContactWords) {
    dst.put_slice(b"RCC");
    dst.put_u8(range.area.letter());
    put_decimal(dst, range.start.into(), 4);
    put_decimal(dst, range.end.into(), 4);
}

/// The range two 5-digit decimal addresses spell.
pub(super) fn parse_dt_range(text: &[u8]) -> Result<DtRange, MessageError> {
    expect_len("dt range", text, 10)?;
    let start = parse_decimal("dt start", &text[..5])?;
    let end = parse_decimal("dt end", &text[5..])?;
    DtRange::new(start, end)
}

/// The range an area letter and two 4-digit decimal words spell.
pub(super) fn parse_contact_words(text: &[u8]) -> Result<ContactWords, MessageError> {
    expect_len("contact words", text, 9)?;
    let area = ContactArea::from_letter(text[0])?;
    let start = parse_decimal("contact start", &text[1..5])? as u16;
    let end = parse_decimal("contact end", &text[5..9])? as u16;
    ContactWords::new(area, start, end)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mewtocol::command::Command;

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
    fn special_registers_are_accepted_but_not_mixed_with_data_registers() {
        assert!(DtRange::new(90_052, 90_052).is_ok());
        assert!(DtRange::new(32_764, 90_000).is_err());
        assert!(DtRange::new(91_000, 91_000).is_err());
    }

    #[test]
    fn address_fields_round_trip_through_their_text() {
        let mut dst = BytesMut::new();
        put_dt_range(&mut dst, b"", DtRange::new(100, 107).unwrap());
        assert_eq!(&dst[..], b"0010000107");
        assert_eq!(parse_dt_range(&dst), DtRange::new(100, 107));
        let words = ContactWords::new(ContactArea::Y, 0, 12).unwrap();
        let mut dst = BytesMut::new();
        put_contact_words(&mut dst, words);
        assert_eq!(&dst[..], b"RCCY00000012");
        assert_eq!(parse_contact_words(&dst[3..]), Ok(words));
    }
}
