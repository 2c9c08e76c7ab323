//! PURE. The execution model: what a PLC does with a start's tables, and how close that comes to
//! the planned line (`docs/ACCURACY.md`).
//!
//! - every channel of a start begins at t = 0 from its start count;
//! - a row `(f_set, target)` emits |target - count| pulses at the real frequency
//!   `model(f_set, range)`, clamped to the channel's maximum: pulse k of the row lands at
//!   `row_start + k / f`, and the next row starts when the last pulse lands ([`row_actual_hz`]
//!   and [`pulse_time_s`]: the mock PLC times its rows with the same two);
//! - a channel's next segment starts when its previous one ends, plus a configurable gap (the
//!   PLC's scan; 0 in the planner's own report);
//! - rows go toward their target whatever the segment's direction says: the runaway of an FP-X on
//!   a target against the direction is the mock PLC's business, and `table::problems` flags it.
//!
//! The planner's report and the mock PLC both use it.

mod figures;
mod play;

pub use figures::{Figures, Planned, SAMPLE_PERIOD_S, measure, measure_within, path_deviation_mm};
pub use play::{ChannelPulses, Merged, PlayedRow, Rows, finish_times, pulses};

use crate::table::{ChannelTable, FrequencyModel, FrequencyRange};

/// The real frequency (Hz) a row written as `freq_hz` in `range` runs at on a channel whose top
/// frequency is `limit_hz`: the model's output, clamped to the range and then to the channel.
/// The planner's report and the mock PLC both time rows with this.
#[must_use]
pub fn row_actual_hz(
    model: FrequencyModel,
    freq_hz: u32,
    range: FrequencyRange,
    limit_hz: f64,
) -> f64 {
    model.actual_hz(freq_hz, range).min(limit_hz)
}

/// When pulse `k` (from 1) of a row that began at `row_start_s` and runs at `actual_hz` lands;
/// pulse `n` of an `n`-pulse row is also when the row ends.
#[must_use]
pub fn pulse_time_s(row_start_s: f64, k: i64, actual_hz: f64) -> f64 {
    row_start_s + k as f64 / actual_hz
}

/// How a start is executed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// What the channels really output.
    pub model: FrequencyModel,
    /// Time between the end of one segment and the start of the next, s.
    pub segment_gap_s: f64,
}

/// One pulse: at `t_s`, the channel of table `table` reaches `count`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulseEvent {
    /// Time from the start, s.
    pub t_s: f64,
    /// Index of the table (the joint) in the start.
    pub table: usize,
    /// The count after this pulse.
    pub count: i64,
}

/// When one row ran.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowTiming {
    /// Index of the table (the joint) in the start.
    pub table: usize,
    /// Segment index, from 0.
    pub segment: usize,
    /// Row index within the segment, from 0.
    pub row: usize,
    /// The real frequency the row ran at, Hz.
    pub actual_hz: f64,
    /// When its first pulse period began, s.
    pub start_s: f64,
    /// When its last pulse landed, s.
    pub end_s: f64,
}

/// Everything a start did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Execution {
    /// Every pulse of every channel, in time order (ties in table order).
    pub events: Vec<PulseEvent>,
    /// Every row's timing, table by table.
    pub rows: Vec<RowTiming>,
    /// When each table's last pulse landed (`None` for a table that emits nothing).
    pub finish_s: Vec<Option<f64>>,
}

/// Executes a start: `tables[i]` runs with channel limit `max_hz[i]`.
#[must_use]
pub fn execute(tables: &[ChannelTable], max_hz: &[u32], settings: Settings) -> Execution {
    Execution {
        events: pulses(tables, max_hz, settings).collect(),
        rows: row_timings(tables, max_hz, settings),
        finish_s: finish_times(tables, max_hz, settings),
    }
}

/// When every row of `tables` runs (see [`execute`]), table by table.
#[must_use]
pub fn row_timings(tables: &[ChannelTable], max_hz: &[u32], settings: Settings) -> Vec<RowTiming> {
    let mut rows = Vec::with_capacity(tables.iter().map(ChannelTable::rows).sum());
    for (i, table) in tables.iter().enumerate() {
        rows.extend(Rows::new(i, table, play::limit_hz(max_hz, i), settings).map(|r| r.timing));
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::{Direction, FrequencyRange};

    use crate::table::pulse_sign_segment as segment;

    const IDEAL: Settings = Settings {
        model: FrequencyModel::Ideal,
        segment_gap_s: 0.0,
    };

    #[test]
    fn pulses_land_at_k_over_f_and_rows_chain() {
        let t = ChannelTable {
            channel: 0,
            start: 10,
            segments: vec![segment(
                Direction::Up,
                FrequencyRange::High,
                &[(1_000, 12), (500, 13)],
            )],
        };
        let exec = execute(&[t], &[100_000], IDEAL);
        let times: Vec<f64> = exec.events.iter().map(|e| e.t_s).collect();
        assert_eq!(times, vec![0.001, 0.002, 0.004]);
        assert_eq!(exec.events.last().unwrap().count, 13);
        assert_eq!(exec.finish_s, vec![Some(0.004)]);
    }

    #[test]
    fn next_segment_waits_for_the_gap_and_counts_down() {
        let t = ChannelTable {
            channel: 0,
            start: 0,
            segments: vec![
                segment(Direction::Up, FrequencyRange::High, &[(1_000, 2)]),
                segment(Direction::Down, FrequencyRange::High, &[(1_000, 1)]),
            ],
        };
        let exec = execute(
            &[t],
            &[100_000],
            Settings {
                segment_gap_s: 0.002,
                ..IDEAL
            },
        );
        let last = exec.events.last().unwrap();
        assert!((last.t_s - 0.005).abs() < 1e-12);
        assert_eq!(last.count, 1);
    }

    #[test]
    fn frequency_above_the_channel_limit_runs_at_the_limit() {
        let t = ChannelTable {
            channel: 2,
            start: 0,
            segments: vec![segment(
                Direction::Up,
                FrequencyRange::High,
                &[(40_000, 20_000)],
            )],
        };
        let exec = execute(&[t], &[20_000], IDEAL);
        assert!((exec.finish_s[0].unwrap() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn divider_model_stretches_a_row() {
        // 1000 Hz in range 0: 97656.25 / ceil(97.656) = 97656.25 / 98 = 996.49 Hz.
        let t = ChannelTable {
            channel: 0,
            start: 0,
            segments: vec![segment(
                Direction::Up,
                FrequencyRange::Low,
                &[(1_000, 1_000)],
            )],
        };
        let settings = Settings {
            model: FrequencyModel::FpxDivider,
            segment_gap_s: 0.0,
        };
        let exec = execute(&[t], &[100_000], settings);
        assert!((exec.finish_s[0].unwrap() - 98.0 / 97.656_25).abs() < 1e-9);
    }

    #[test]
    fn merge_keeps_time_order_and_breaks_ties_by_table() {
        // Three channels on grids that meet: 1/3, 1/4 and 1/6 ms apart, with shared instants.
        let channel = |table: usize, step_s: f64, n: i64| -> Vec<PulseEvent> {
            (1..=n)
                .map(|k| PulseEvent {
                    t_s: (k as f64 * step_s * 1e6).round() / 1e6,
                    table,
                    count: k,
                })
                .collect()
        };
        let channels = [
            channel(0, 0.003, 40),
            channel(1, 0.004, 30),
            channel(2, 0.006, 20),
        ];
        let merged: Vec<PulseEvent> =
            Merged::new(channels.iter().map(|c| c.iter().copied())).collect();
        let mut expected: Vec<PulseEvent> = channels.concat();
        expected.sort_by(|a, b| a.t_s.total_cmp(&b.t_s).then(a.table.cmp(&b.table)));
        assert_eq!(merged, expected);
        assert!(
            merged
                .windows(2)
                .any(|w| w[0].t_s.total_cmp(&w[1].t_s).is_eq())
        );
    }

    #[test]
    fn events_of_several_channels_are_merged_in_time_order() {
        let a = ChannelTable {
            channel: 0,
            start: 0,
            segments: vec![segment(Direction::Up, FrequencyRange::High, &[(300, 3)])],
        };
        let b = ChannelTable {
            channel: 1,
            start: 0,
            segments: vec![segment(Direction::Down, FrequencyRange::High, &[(400, -4)])],
        };
        let exec = execute(&[a, b], &[100_000, 100_000], IDEAL);
        assert!(exec.events.windows(2).all(|w| w[0].t_s <= w[1].t_s));
        assert_eq!(exec.events.len(), 7);
    }
}
