//! PURE. The execution model played as it is read: every channel's rows timed one after the
//! other ([`Rows`]), their pulses made one at a time ([`ChannelPulses`]), and the channels'
//! pulses merged into one time order as they are consumed ([`Merged`]). Nothing is
//! materialised: a planner judging a start reads some 25 000 events once, and an
//! [`Execution`](super::Execution) is the same stream collected.

use super::{PulseEvent, RowTiming, Settings, pulse_time_s, row_actual_hz};
use crate::table::{ChannelTable, Segment};

/// One row as the channel plays it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlayedRow {
    /// When it ran.
    pub timing: RowTiming,
    /// The count before its first pulse.
    pub from_count: i64,
    /// +1 or -1 per pulse (0 for a row that emits nothing).
    pub step: i64,
    /// How many pulses it emits.
    pub pulses: i64,
}

/// A channel's rows in order, each timed: a row starts when the row before it ends, a segment
/// `segment_gap_s` after the one before it.
#[derive(Debug, Clone)]
pub struct Rows<'a> {
    table: usize,
    segments: &'a [Segment],
    limit_hz: f64,
    settings: Settings,
    segment: usize,
    row: usize,
    t_s: f64,
    count: i64,
}

impl<'a> Rows<'a> {
    /// The rows of `table` (the start's table number `index`) on a channel whose top frequency
    /// is `limit_hz`.
    #[must_use]
    pub fn new(index: usize, table: &'a ChannelTable, limit_hz: f64, settings: Settings) -> Self {
        Self {
            table: index,
            segments: &table.segments,
            limit_hz,
            settings,
            segment: 0,
            row: 0,
            t_s: 0.0,
            count: table.start,
        }
    }
}

impl Iterator for Rows<'_> {
    type Item = PlayedRow;

    fn next(&mut self) -> Option<PlayedRow> {
        loop {
            let seg = self.segments.get(self.segment)?;
            let Some(row) = seg.rows.get(self.row) else {
                self.segment += 1;
                self.row = 0;
                if self.segment < self.segments.len() {
                    self.t_s += self.settings.segment_gap_s;
                }
                continue;
            };
            let actual_hz = row_actual_hz(
                self.settings.model,
                row.freq_hz,
                seg.control.range,
                self.limit_hz,
            );
            let step = (row.target - self.count).signum();
            let pulses = (row.target - self.count).abs();
            let start_s = self.t_s;
            let from_count = self.count;
            self.t_s = pulse_time_s(start_s, pulses, actual_hz);
            self.count = row.target;
            let played = PlayedRow {
                timing: RowTiming {
                    table: self.table,
                    segment: self.segment,
                    row: self.row,
                    actual_hz,
                    start_s,
                    end_s: self.t_s,
                },
                from_count,
                step,
                pulses,
            };
            self.row += 1;
            return Some(played);
        }
    }
}

/// A channel's pulses in order: pulse `k` of a row lands at [`pulse_time_s`].
#[derive(Debug, Clone)]
pub struct ChannelPulses<'a> {
    rows: Rows<'a>,
    current: Option<PlayedRow>,
    k: i64,
}

impl<'a> ChannelPulses<'a> {
    /// The pulses of `table` (the start's table number `index`) on a channel whose top
    /// frequency is `limit_hz`.
    #[must_use]
    pub fn new(index: usize, table: &'a ChannelTable, limit_hz: f64, settings: Settings) -> Self {
        Self {
            rows: Rows::new(index, table, limit_hz, settings),
            current: None,
            k: 0,
        }
    }
}

impl Iterator for ChannelPulses<'_> {
    type Item = PulseEvent;

    fn next(&mut self) -> Option<PulseEvent> {
        loop {
            match &self.current {
                Some(row) if self.k < row.pulses => {
                    self.k += 1;
                    return Some(PulseEvent {
                        t_s: pulse_time_s(row.timing.start_s, self.k, row.timing.actual_hz),
                        table: row.timing.table,
                        count: row.from_count + self.k * row.step,
                    });
                }
                _ => {
                    self.current = Some(self.rows.next()?);
                    self.k = 0;
                }
            }
        }
    }
}

/// Channels' events (each already in time order, the channel's place in the list being its
/// table) merged into one time order as they are read, ties in table order: every read takes
/// the earliest of the channels' next events (a start has at most four channels).
#[derive(Debug, Clone)]
pub struct Merged<I: Iterator<Item = PulseEvent>> {
    /// Every channel's next event; an ended channel's stays with its time at infinity.
    heads: Vec<PulseEvent>,
    channels: Vec<I>,
}

/// The head of a channel that has no more events.
const ENDED: PulseEvent = PulseEvent {
    t_s: f64::INFINITY,
    table: usize::MAX,
    count: 0,
};

impl<I: Iterator<Item = PulseEvent>> Merged<I> {
    /// Merges `channels`, channel `c` holding table `c`'s events.
    pub fn new(channels: impl IntoIterator<Item = I>) -> Self {
        let mut channels: Vec<I> = channels.into_iter().collect();
        Self {
            heads: channels
                .iter_mut()
                .map(|c| c.next().unwrap_or(ENDED))
                .collect(),
            channels,
        }
    }
}

impl<I: Iterator<Item = PulseEvent>> Iterator for Merged<I> {
    type Item = PulseEvent;

    // Inlined into the measurement's loop, the event stays in registers (returned through
    // memory, it was read back from a store not yet done).
    #[allow(clippy::inline_always)]
    #[inline(always)]
    fn next(&mut self) -> Option<PulseEvent> {
        // The first channel, in table order, whose next event is the earliest (an event's time
        // is never NaN: a row's frequency is above zero).
        let mut c = 0;
        for (i, head) in self.heads.iter().enumerate().skip(1) {
            if head.t_s < self.heads[c].t_s {
                c = i;
            }
        }
        let head = self.heads.get_mut(c)?;
        if head.t_s.is_infinite() {
            return None;
        }
        let e = *head;
        *head = self.channels[c].next().unwrap_or(ENDED);
        Some(e)
    }
}

/// Every pulse of a start's `tables` (channel limits `max_hz[i]`, none past the list) in time
/// order, ties in table order, made as they are read.
#[must_use]
pub fn pulses<'a>(
    tables: &'a [ChannelTable],
    max_hz: &[u32],
    settings: Settings,
) -> Merged<ChannelPulses<'a>> {
    Merged::new(
        tables
            .iter()
            .enumerate()
            .map(|(i, t)| ChannelPulses::new(i, t, limit_hz(max_hz, i), settings)),
    )
}

/// When each of `tables` lands its last pulse (`None` for a table that emits nothing).
#[must_use]
pub fn finish_times(
    tables: &[ChannelTable],
    max_hz: &[u32],
    settings: Settings,
) -> Vec<Option<f64>> {
    tables
        .iter()
        .enumerate()
        .map(|(i, t)| {
            Rows::new(i, t, limit_hz(max_hz, i), settings)
                .filter(|r| r.pulses > 0)
                .last()
                .map(|r| r.timing.end_s)
        })
        .collect()
}

/// Channel `i`'s top frequency, Hz (none when `max_hz` does not name it).
pub(super) fn limit_hz(max_hz: &[u32], i: usize) -> f64 {
    max_hz.get(i).copied().map_or(f64::INFINITY, f64::from)
}
