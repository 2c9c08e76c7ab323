//! The DT word image of one channel's table area (CONTRACT.md, "Table areas"), and its decoder.
//!
//! DINT values are two words, low word first (PLC.md §1, "Word data").

use thiserror::Error;

use super::{ChannelTable, ControlCode, DIRECTORY_WORDS, MAX_SEGMENTS, Row, Segment, ValidTable};

/// Words the encoded image of `table` takes: the directory plus every segment.
#[must_use]
pub fn encoded_words(table: &ChannelTable) -> usize {
    DIRECTORY_WORDS + table.segments.iter().map(Segment::words).sum::<usize>()
}

fn push_dint(words: &mut Vec<u16>, value: u32) {
    words.push((value & 0xFFFF) as u16);
    words.push((value >> 16) as u16);
}

/// The words to write at the start of the channel's table area.
#[must_use]
pub fn encode(table: &ValidTable) -> Vec<u16> {
    let (directory, segments) = encode_at(table, DIRECTORY_WORDS);
    let mut words = directory.to_vec();
    words.extend(segments);
    words
}

/// The channel's table placed with its first segment `base` words from the area's start
/// (the directory's end, or past other tables kept in the same area): its directory, and the
/// segments' words to write at `base`. Directory entries past the table's segments are 0.
#[must_use]
pub fn encode_at(table: &ValidTable, base: usize) -> ([u16; DIRECTORY_WORDS], Vec<u16>) {
    let table = table.table();
    let mut directory = [0u16; DIRECTORY_WORDS];
    let mut words = Vec::with_capacity(encoded_words(table) - DIRECTORY_WORDS);
    for (i, seg) in table.segments.iter().enumerate() {
        // Validation bounds a table by its area, and a caller its base: an offset fits a word.
        directory[i] = (base + words.len()) as u16;
        push_dint(&mut words, seg.control.value());
        for row in &seg.rows {
            push_dint(&mut words, row.freq_hz);
            // Validation guarantees the target fits an i32.
            push_dint(&mut words, row.target as i32 as u32);
        }
        push_dint(&mut words, 0);
    }
    (directory, words)
}

/// Why a word image is not a table.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum DecodeError {
    /// The image is shorter than its directory.
    #[error("table area holds {words} words; the directory alone needs {DIRECTORY_WORDS}")]
    NoDirectory {
        /// Words given.
        words: usize,
    },
    /// A directory entry points outside the area or into the directory.
    #[error("segment {segment} offset {offset} is outside {DIRECTORY_WORDS}..{words}")]
    BadOffset {
        /// Segment index (1-based).
        segment: usize,
        /// The offset found.
        offset: u16,
        /// Words in the area.
        words: usize,
    },
    /// A control code with undocumented digits.
    #[error("segment {segment} control code {value:#x} is not a valid F174 control code")]
    BadControlCode {
        /// Segment index (1-based).
        segment: usize,
        /// The value found.
        value: u32,
    },
    /// A segment runs past the end of the area without its end marker.
    #[error("segment {segment} has no end marker inside the area")]
    Unterminated {
        /// Segment index (1-based).
        segment: usize,
    },
    /// More segments than the start announces are missing from the directory.
    #[error("the start announces {wanted} segments; the directory holds {found}")]
    MissingSegments {
        /// Segments announced.
        wanted: usize,
        /// Segments found.
        found: usize,
    },
}

fn dint(words: &[u16], at: usize) -> Option<u32> {
    Some(u32::from(*words.get(at)?) | (u32::from(*words.get(at + 1)?) << 16))
}

/// Reads the first `segments` segments of a channel area back into rows (what the PLC program
/// plays). Nothing here judges the rows: run [`super::problems`] for that.
pub fn decode(words: &[u16], segments: usize) -> Result<Vec<Segment>, DecodeError> {
    if words.len() < DIRECTORY_WORDS {
        return Err(DecodeError::NoDirectory { words: words.len() });
    }
    let wanted = segments.min(MAX_SEGMENTS);
    let mut out = Vec::with_capacity(wanted);
    for i in 0..wanted {
        let segment = i + 1;
        let offset = words[i];
        if offset == 0 {
            return Err(DecodeError::MissingSegments { wanted, found: i });
        }
        let start = usize::from(offset);
        if start < DIRECTORY_WORDS || start >= words.len() {
            return Err(DecodeError::BadOffset {
                segment,
                offset,
                words: words.len(),
            });
        }
        let value = dint(words, start).ok_or(DecodeError::Unterminated { segment })?;
        let control =
            ControlCode::from_value(value).ok_or(DecodeError::BadControlCode { segment, value })?;
        let mut rows = Vec::new();
        let mut at = start + 2;
        loop {
            let freq_hz = dint(words, at).ok_or(DecodeError::Unterminated { segment })?;
            if freq_hz == 0 {
                break;
            }
            let target = dint(words, at + 2).ok_or(DecodeError::Unterminated { segment })?;
            rows.push(Row {
                freq_hz,
                target: i64::from(target as i32),
            });
            at += 4;
        }
        out.push(Segment { control, rows });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::*;

    fn sample() -> ChannelTable {
        let control = ControlCode {
            output: OutputMethod::CwCcw,
            direction: Direction::Down,
            absolute: true,
            range: FrequencyRange::Mid,
            duty: Duty::Half,
        };
        ChannelTable {
            channel: 0,
            start: 0,
            segments: vec![
                Segment {
                    control,
                    rows: vec![Row {
                        freq_hz: 1_000,
                        target: -5_000,
                    }],
                },
                Segment {
                    control: ControlCode {
                        direction: Direction::Up,
                        duty: Duty::Quarter,
                        ..control
                    },
                    rows: vec![
                        Row {
                            freq_hz: 70_000,
                            target: -10,
                        },
                        Row {
                            freq_hz: 100,
                            target: 3,
                        },
                    ],
                },
            ],
        }
    }

    fn limits() -> ChannelLimits {
        ChannelLimits {
            max_freq_hz: 100_000,
            area_words: 2_000,
        }
    }

    #[test]
    fn dint_words_are_low_word_first() {
        // PLC.md: -5000 = 0xFFFFEC78 -> words 0xEC78, 0xFFFF; 1000 = 0x03E8.
        let mut t = sample();
        t.segments.truncate(1);
        let words = encode(&validate(t, limits()).unwrap());
        assert_eq!(&words[..DIRECTORY_WORDS], &[8, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(&words[8..], &[0x0111, 0, 0x03E8, 0, 0xEC78, 0xFFFF, 0, 0]);
    }

    #[test]
    fn encode_then_decode_gives_the_segments_back() {
        let t = sample();
        let words = encode(&validate(t.clone(), limits()).unwrap());
        assert_eq!(words.len(), encoded_words(&t));
        assert_eq!(decode(&words, 2).unwrap(), t.segments);
    }

    #[test]
    fn a_table_placed_past_another_decodes_through_its_directory_alone() {
        // Two tables kept in one area: the first from the directory's end, the second after
        // its words. With the second's directory in place the area decodes to the second.
        let limits = limits();
        let first = validate(sample(), limits).unwrap();
        let mut other = sample();
        other.segments[0].rows[0].freq_hz = 2_000;
        let second = validate(other.clone(), limits).unwrap();
        let mut area = encode(&first);
        let base = area.len();
        let (directory, words) = encode_at(&second, base);
        assert_eq!(directory[0] as usize, base);
        assert_eq!(directory[2..], [0; 6]);
        area.extend(&words);
        assert_eq!(decode(&area, 2).unwrap(), sample().segments);
        area[..DIRECTORY_WORDS].copy_from_slice(&directory);
        assert_eq!(decode(&area, 2).unwrap(), other.segments);
        // At the directory's end, it is `encode` split in two.
        let (directory, words) = encode_at(&second, DIRECTORY_WORDS);
        assert_eq!([&directory[..], &words[..]].concat(), encode(&second));
    }

    #[test]
    fn decode_refuses_a_pointer_outside_the_area() {
        let mut words = vec![0u16; 12];
        words[0] = 40;
        assert!(matches!(
            decode(&words, 1),
            Err(DecodeError::BadOffset { offset: 40, .. })
        ));
    }

    #[test]
    fn decode_refuses_a_segment_without_end_marker() {
        let mut words = vec![0u16; 12];
        words[0] = 8;
        words[8] = 0x0110;
        words[10] = 100;
        assert_eq!(
            decode(&words, 1),
            Err(DecodeError::Unterminated { segment: 1 })
        );
    }

    #[test]
    fn decode_refuses_more_segments_than_the_directory_holds() {
        let words = encode(&validate(sample(), limits()).unwrap());
        assert_eq!(
            decode(&words, 3),
            Err(DecodeError::MissingSegments {
                wanted: 3,
                found: 2
            })
        );
    }
}
