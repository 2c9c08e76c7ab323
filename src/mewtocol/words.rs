//! Data fields of MEWTOCOL-COM text: 16-bit words as hex, decimal addresses.
//!
//! ```text
//!  word 0x1234  ->  "3412"       low byte first, each byte two upper-case hex digits
//!  DINT -5000   ->  "78EC" "FFFF" 0xFFFFEC78, low word first (at the lower DT address)
//!  DT 100       ->  "00100"      addresses: fixed-width decimal
//! ```
//! (PLC.md §1, "Word data"; MEWTOCOL-COM manual, "Data format".)

use bytes::{BufMut, BytesMut};

use super::error::MessageError;
use super::frame::{hex_byte, parse_hex_byte};

/// Hex characters one word takes on the link.
pub(super) const WORD_CHARS: usize = 4;

/// Appends `word` as four hex digits, low byte first (100 -> `6400`).
pub(super) fn put_word(dst: &mut BytesMut, word: u16) {
    let [low, high] = word.to_le_bytes();
    dst.put_slice(&hex_byte(low));
    dst.put_slice(&hex_byte(high));
}

/// Appends every word of `words`.
pub(super) fn put_words(dst: &mut BytesMut, words: &[u16]) {
    for &word in words {
        put_word(dst, word);
    }
}

/// The words that `text` spells, four hex digits each, low byte first.
pub(super) fn parse_words(field: &'static str, text: &[u8]) -> Result<Vec<u16>, MessageError> {
    if !text.len().is_multiple_of(WORD_CHARS) {
        return Err(MessageError::BadLength {
            field,
            len: text.len(),
            expected: "a multiple of 4".into(),
        });
    }
    text.chunks_exact(WORD_CHARS)
        .map(|chunk| parse_word(field, chunk))
        .collect()
}

fn parse_word(field: &'static str, chunk: &[u8]) -> Result<u16, MessageError> {
    let low = parse_byte(field, [chunk[0], chunk[1]])?;
    let high = parse_byte(field, [chunk[2], chunk[3]])?;
    Ok(u16::from_le_bytes([low, high]))
}

/// The byte two hex digits spell.
pub(super) fn parse_byte(field: &'static str, chars: [u8; 2]) -> Result<u8, MessageError> {
    parse_hex_byte(chars).ok_or_else(|| bad_digit(field, chars, "hex digits"))
}

fn bad_digit(field: &'static str, chars: [u8; 2], expected: &'static str) -> MessageError {
    let found = if parse_hex_byte([chars[0], b'0']).is_none() {
        chars[0]
    } else {
        chars[1]
    };
    MessageError::BadDigit {
        field,
        found: char::from(found),
        expected,
    }
}

/// A signed 32-bit value as the two words it occupies, low word first.
#[must_use]
pub fn dint_to_words(value: i32) -> [u16; 2] {
    let bits = value as u32;
    [(bits & 0xFFFF) as u16, (bits >> 16) as u16]
}

/// The signed 32-bit value two words (low word first) hold.
#[must_use]
pub fn words_to_dint(words: [u16; 2]) -> i32 {
    (u32::from(words[1]) << 16 | u32::from(words[0])) as i32
}

/// Appends `value` as exactly `width` decimal digits; the caller has checked it fits.
pub(super) fn put_decimal(dst: &mut BytesMut, value: u32, width: usize) {
    let text = format!("{value:0width$}");
    dst.put_slice(text.as_bytes());
}

/// The value of `text`, which must be all decimal digits.
pub(super) fn parse_decimal(field: &'static str, text: &[u8]) -> Result<u32, MessageError> {
    text.iter().try_fold(0u32, |acc, &c| match c {
        b'0'..=b'9' => Ok(acc.saturating_mul(10).saturating_add(u32::from(c - b'0'))),
        _ => Err(MessageError::BadDigit {
            field,
            found: char::from(c),
            expected: "decimal digits",
        }),
    })
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

    fn words_text(words: &[u16]) -> String {
        let mut dst = BytesMut::new();
        put_words(&mut dst, words);
        String::from_utf8(dst.to_vec()).unwrap()
    }

    #[test]
    fn words_go_low_byte_first() {
        assert_eq!(words_text(&[100]), "6400");
        assert_eq!(words_text(&[0x1234]), "3412");
        assert_eq!(parse_words("data", b"3412").unwrap(), vec![0x1234]);
    }

    #[test]
    fn dint_is_two_words_low_word_first() {
        let words = dint_to_words(-5000);
        assert_eq!(words, [0xEC78, 0xFFFF]);
        assert_eq!(words_text(&words), "78ECFFFF");
        assert_eq!(words_to_dint(words), -5000);
    }

    #[test]
    fn parse_words_accepts_lower_case_and_rejects_non_hex() {
        assert_eq!(parse_words("data", b"e803").unwrap(), vec![1000]);
        let err = parse_words("data", b"E8G3").unwrap_err();
        assert!(
            matches!(err, MessageError::BadDigit { found: 'G', .. }),
            "{err:?}"
        );
        assert!(matches!(
            parse_words("data", b"E80"),
            Err(MessageError::BadLength { len: 3, .. })
        ));
    }

    #[test]
    fn decimal_fields_round_trip_and_reject_letters() {
        let mut dst = BytesMut::new();
        put_decimal(&mut dst, 100, 5);
        assert_eq!(&dst[..], b"00100");
        assert_eq!(parse_decimal("start", b"00100"), Ok(100));
        assert!(parse_decimal("start", b"0010A").is_err());
    }
}
