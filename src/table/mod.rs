//! PURE. F174 pulse tables: rows, segments, a channel's table, the one validation every table
//! passes before it can be encoded, and the DT word image of `CONTRACT.md` (encode and decode).
//!
//! A channel's table area (CONTRACT.md, "Table areas"), all values DINT, low word first:
//! ```text
//! +0 .. +7   offset of segment 1..8 in words from the area's start (0 = no segment)
//! +8 ...     segment 1: control code, (frequency, target) x rows, 0
//!            segment 2: ...
//! ```

mod code;
mod image;
mod range;

pub use code::{ControlCode, Direction, Duty, OutputMethod, quarter_duty_from_hz};
pub use image::{DecodeError, decode, encode, encode_at, encoded_words};
pub use range::{FrequencyModel, FrequencyRange};

/// Segments one channel may hold in one start (CONTRACT.md: offsets of segment 1..8).
pub const MAX_SEGMENTS: usize = 8;
/// Words of the offset directory at the head of every channel area.
pub const DIRECTORY_WORDS: usize = MAX_SEGMENTS;

/// One F174 row: output at `freq_hz` until the count reaches the absolute `target`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Row {
    /// The frequency value written to the PLC (range 0: 1 means 1.5 Hz).
    pub freq_hz: u32,
    /// Absolute target count.
    pub target: i64,
}

/// One F174 execution: a control code and its rows.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Segment {
    /// Direction, range, duty and output method of the whole segment.
    pub control: ControlCode,
    /// The rows, in order.
    pub rows: Vec<Row>,
}

impl Segment {
    /// Words this segment takes in the table area: control code, rows, end marker.
    #[must_use]
    pub fn words(&self) -> usize {
        2 + 4 * self.rows.len() + 2
    }
}

/// Everything one channel plays in one start.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelTable {
    /// Pulse channel 0-3.
    pub channel: u8,
    /// The count the channel holds when the start begins.
    pub start: i64,
    /// The segments, played back to back.
    pub segments: Vec<Segment>,
}

impl ChannelTable {
    /// Rows over all segments.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.segments.iter().map(|s| s.rows.len()).sum()
    }

    /// The count after the last row (the start count for an empty table).
    #[must_use]
    pub fn end(&self) -> i64 {
        self.segments
            .iter()
            .rev()
            .find_map(|s| s.rows.last())
            .map_or(self.start, |r| r.target)
    }
}

/// What a channel allows: its top frequency and the size of its table area.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChannelLimits {
    /// Highest frequency value the channel may be given.
    pub max_freq_hz: u32,
    /// Words in the channel's table area.
    pub area_words: usize,
}

/// One reason a table must not be sent to a PLC.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TableProblem {
    /// More segments than the directory holds.
    #[error("channel {channel} needs {segments} segments; a start allows {MAX_SEGMENTS}")]
    TooManySegments {
        /// Channel.
        channel: u8,
        /// Segments in the table.
        segments: usize,
    },
    /// A segment without rows.
    #[error("channel {channel} segment {segment} has no rows")]
    EmptySegment {
        /// Channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
    },
    /// A target that does not move the count in the segment's direction (a zero-length row or a
    /// reversal): on an FP-X the count would run on without end.
    #[error(
        "channel {channel} segment {segment} row {row}: target {target} from count {from} does \
         not move {}; an FP-X would run on without end",
        up_or_down(*direction)
    )]
    AgainstDirection {
        /// Channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
        /// Row index (1-based).
        row: usize,
        /// Count before the row.
        from: i64,
        /// The row's target.
        target: i64,
        /// The segment's direction.
        direction: Direction,
    },
    /// A frequency outside the segment's range or above the channel's maximum.
    #[error(
        "channel {channel} segment {segment} row {row}: frequency {freq_hz} Hz is outside \
         {min_hz}..={max_hz} Hz"
    )]
    FrequencyOutOfRange {
        /// Channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
        /// Row index (1-based).
        row: usize,
        /// The frequency value.
        freq_hz: u32,
        /// Lowest allowed.
        min_hz: u32,
        /// Highest allowed.
        max_hz: u32,
    },
    /// A target that does not fit a DINT.
    #[error("channel {channel}: target {target} does not fit a 32-bit DINT")]
    TargetOutOfI32 {
        /// Channel.
        channel: u8,
        /// The target.
        target: i64,
    },
    /// Duty 1/2 at a frequency that needs 1/4.
    #[error(
        "channel {channel} segment {segment}: duty 1/2 at {freq_hz} Hz; 1/4 is required from \
         {from_hz} Hz"
    )]
    DutyTooHigh {
        /// Channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
        /// The highest frequency in the segment.
        freq_hz: u32,
        /// The frequency from which 1/4 is required.
        from_hz: u32,
    },
    /// Incremental targets: linterpd only writes absolute ones.
    #[error("channel {channel} segment {segment}: targets are not absolute")]
    NotAbsolute {
        /// Channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
    },
    /// The encoded table is larger than the channel's area.
    #[error("channel {channel} table needs {words} words; its area holds {area_words}")]
    AreaOverflow {
        /// Channel.
        channel: u8,
        /// Words needed.
        words: usize,
        /// Words available.
        area_words: usize,
    },
}

/// `up` or `down`.
fn up_or_down(direction: Direction) -> &'static str {
    if direction == Direction::Up {
        "up"
    } else {
        "down"
    }
}

/// A channel table that passed [`validate`]; the only thing [`encode`] accepts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ValidTable(ChannelTable);

impl ValidTable {
    /// The table.
    #[must_use]
    pub fn table(&self) -> &ChannelTable {
        &self.0
    }
}

/// Checks every rule a table must keep before a PLC may play it: at most eight segments, each
/// non-empty, absolute, strictly monotonic in its own direction from where the previous one ended
/// (so no zero-length row and no reversal), frequencies inside the segment's range and the
/// channel's maximum, duty 1/4 where the FP-X needs it, targets inside a DINT, and the whole image
/// inside the channel's area.
pub fn validate(
    table: ChannelTable,
    limits: ChannelLimits,
) -> Result<ValidTable, Vec<TableProblem>> {
    let problems = problems(&table, limits);
    if problems.is_empty() {
        Ok(ValidTable(table))
    } else {
        Err(problems)
    }
}

/// The problems [`validate`] would report, without taking the table.
#[must_use]
pub fn problems(table: &ChannelTable, limits: ChannelLimits) -> Vec<TableProblem> {
    let channel = table.channel;
    let mut out = Vec::new();
    if table.segments.len() > MAX_SEGMENTS {
        out.push(TableProblem::TooManySegments {
            channel,
            segments: table.segments.len(),
        });
    }
    let mut count = table.start;
    for (si, seg) in table.segments.iter().enumerate() {
        let segment = si + 1;
        segment_problems(channel, segment, seg, &mut count, limits, &mut out);
    }
    let words = encoded_words(table);
    if words > limits.area_words {
        out.push(TableProblem::AreaOverflow {
            channel,
            words,
            area_words: limits.area_words,
        });
    }
    out
}

fn segment_problems(
    channel: u8,
    segment: usize,
    seg: &Segment,
    count: &mut i64,
    limits: ChannelLimits,
    out: &mut Vec<TableProblem>,
) {
    if seg.rows.is_empty() {
        out.push(TableProblem::EmptySegment { channel, segment });
    }
    if !seg.control.absolute {
        out.push(TableProblem::NotAbsolute { channel, segment });
    }
    let range = seg.control.range;
    let min_hz = range.min_set_hz();
    let max_hz = range.max_set_hz().min(limits.max_freq_hz);
    let direction = seg.control.direction;
    for (ri, r) in seg.rows.iter().enumerate() {
        let at = (channel, segment, ri + 1);
        row_problems(at, r, (*count, direction), (min_hz, max_hz), out);
        *count = r.target;
    }
    let top = seg.rows.iter().map(|r| r.freq_hz).max().unwrap_or(0);
    let from_hz = quarter_duty_from_hz(channel);
    if seg.control.duty == Duty::Half && top >= from_hz {
        out.push(TableProblem::DutyTooHigh {
            channel,
            segment,
            freq_hz: top,
            from_hz,
        });
    }
}

/// The problems of row `row` of `segment` on `channel`: a target that does not move `direction`
/// from `from`, a frequency outside `min_hz..=max_hz`, a target outside a DINT.
fn row_problems(
    (channel, segment, row): (u8, usize, usize),
    r: &Row,
    (from, direction): (i64, Direction),
    (min_hz, max_hz): (u32, u32),
    out: &mut Vec<TableProblem>,
) {
    if (r.target - from) * direction.sign() <= 0 {
        out.push(TableProblem::AgainstDirection {
            channel,
            segment,
            row,
            from,
            target: r.target,
            direction,
        });
    }
    if r.freq_hz < min_hz || r.freq_hz > max_hz {
        out.push(TableProblem::FrequencyOutOfRange {
            channel,
            segment,
            row,
            freq_hz: r.freq_hz,
            min_hz,
            max_hz,
        });
    }
    if i32::try_from(r.target).is_err() {
        out.push(TableProblem::TargetOutOfI32 {
            channel,
            target: r.target,
        });
    }
}

/// For tests elsewhere in the crate: a segment of `rows` (frequency, absolute target) in
/// pulse and sign output, `direction` and `range`, half duty.
#[cfg(test)]
pub(crate) fn pulse_sign_segment(
    direction: Direction,
    range: FrequencyRange,
    rows: &[(u32, i64)],
) -> Segment {
    Segment {
        control: ControlCode {
            output: OutputMethod::PulseSign,
            direction,
            absolute: true,
            range,
            duty: Duty::Half,
        },
        rows: rows
            .iter()
            .map(|&(freq_hz, target)| Row { freq_hz, target })
            .collect(),
    }
}

/// For tests elsewhere in the crate: a valid table on `channel` of one rising segment (pulse and
/// sign, high range), a row at 1 kHz to each of `targets`, within 20 kHz and 2000 words.
#[cfg(test)]
pub(crate) fn rising(channel: u8, targets: &[i64]) -> ValidTable {
    let rows: Vec<(u32, i64)> = targets.iter().map(|&target| (1_000, target)).collect();
    let table = ChannelTable {
        channel,
        start: 0,
        segments: vec![pulse_sign_segment(
            Direction::Up,
            FrequencyRange::High,
            &rows,
        )],
    };
    let limits = ChannelLimits {
        max_freq_hz: 20_000,
        area_words: 2_000,
    };
    validate(table, limits).expect("a rising table is valid")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn code(direction: Direction, range: FrequencyRange) -> ControlCode {
        ControlCode {
            output: OutputMethod::PulseSign,
            direction,
            absolute: true,
            range,
            duty: Duty::Half,
        }
    }

    fn limits() -> ChannelLimits {
        ChannelLimits {
            max_freq_hz: 20_000,
            area_words: 2_000,
        }
    }

    fn table(rows: &[(u32, i64)], direction: Direction) -> ChannelTable {
        ChannelTable {
            channel: 2,
            start: 100,
            segments: vec![Segment {
                control: code(direction, FrequencyRange::High),
                rows: rows
                    .iter()
                    .map(|&(freq_hz, target)| Row { freq_hz, target })
                    .collect(),
            }],
        }
    }

    #[test]
    fn monotonic_table_is_valid() {
        assert!(
            validate(
                table(&[(1_000, 150), (2_000, 250)], Direction::Up),
                limits()
            )
            .is_ok()
        );
    }

    #[test]
    fn zero_length_row_is_refused() {
        let errs = validate(
            table(&[(1_000, 150), (2_000, 150)], Direction::Up),
            limits(),
        )
        .unwrap_err();
        assert!(matches!(
            errs[0],
            TableProblem::AgainstDirection {
                row: 2,
                target: 150,
                ..
            }
        ));
    }

    #[test]
    fn target_against_direction_is_refused() {
        let errs = validate(table(&[(1_000, 90)], Direction::Up), limits()).unwrap_err();
        assert!(
            errs[0].to_string().contains("run on without end"),
            "{}",
            errs[0]
        );
    }

    #[test]
    fn frequency_above_channel_maximum_is_refused() {
        let errs = validate(table(&[(20_001, 150)], Direction::Up), limits()).unwrap_err();
        assert!(matches!(
            errs[0],
            TableProblem::FrequencyOutOfRange { max_hz: 20_000, .. }
        ));
    }

    #[test]
    fn frequency_below_range_minimum_is_refused() {
        let errs = validate(table(&[(190, 150)], Direction::Up), limits()).unwrap_err();
        assert!(matches!(
            errs[0],
            TableProblem::FrequencyOutOfRange { min_hz: 191, .. }
        ));
    }

    #[test]
    fn channel_two_above_ten_kilohertz_needs_quarter_duty() {
        let errs = validate(table(&[(12_000, 150)], Direction::Up), limits()).unwrap_err();
        assert!(matches!(
            errs[0],
            TableProblem::DutyTooHigh {
                from_hz: 10_000,
                ..
            }
        ));
    }

    #[test]
    fn nine_segments_are_refused() {
        let mut t = table(&[(1_000, 101)], Direction::Up);
        for i in 0..8 {
            t.segments.push(Segment {
                control: code(Direction::Up, FrequencyRange::High),
                rows: vec![Row {
                    freq_hz: 1_000,
                    target: 102 + i,
                }],
            });
        }
        let errs = validate(t, limits()).unwrap_err();
        assert!(matches!(
            errs[0],
            TableProblem::TooManySegments { segments: 9, .. }
        ));
    }

    #[test]
    fn target_beyond_dint_is_refused() {
        let errs = validate(
            table(&[(1_000, i64::from(i32::MAX) + 1)], Direction::Up),
            limits(),
        )
        .unwrap_err();
        assert!(matches!(errs[0], TableProblem::TargetOutOfI32 { .. }));
    }

    #[test]
    fn table_larger_than_area_is_refused() {
        let rows: Vec<(u32, i64)> = (1..=600).map(|i| (1_000, 100 + i)).collect();
        let errs = validate(table(&rows, Direction::Up), limits()).unwrap_err();
        assert!(matches!(
            errs[0],
            TableProblem::AreaOverflow {
                area_words: 2_000,
                ..
            }
        ));
    }
}
