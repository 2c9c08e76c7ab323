//! One pulse channel executing F174 segments on the shared execution model (`crate::sim`): a row
//! of `f_set` emits |target - count| pulses at `sim::row_actual_hz`, pulse k at
//! `sim::pulse_time_s(row_start, k, f)`; the next row starts when the last pulse lands.
//!
//! What an FP-X does with a table that breaks the rules (PLC.md §3, "Hazards"):
//! - first frequency outside the range (or above the channel): operation error, nothing output;
//! - first frequency 0 (a segment without rows): nothing output;
//! - a later frequency outside the range: clamped, and recorded as [`Anomaly::Clamped`];
//! - a target against the segment's direction, or equal to the count: the count runs on in the
//!   segment's direction without end, at that row's frequency, until a stop
//!   ([`Anomaly::RunOn`]);
//! - incremental targets: refused as a pulse instruction error (the mock plays absolute targets
//!   only).
//!
//! A stop command aborts the segment ([`Engine::stop`]), unless the mock is the `stop-pauses`
//! variant ([`Engine::halt`]): the output then halts with the busy flag OFF, and the next F174 on
//! the channel resumes the paused segment where it stood (the listing's `H n100` before F174
//! releases the stop bit) and is itself refused without an error, as F174 on a busy channel is.

use thiserror::Error;

use super::trace::{Anomaly, PulsePoint, Recorder};
use crate::sim::{pulse_time_s, row_actual_hz};
use crate::table::{Direction, FrequencyModel, FrequencyRange, Row, Segment};

/// Why F174 refused to start a segment (the PLC program latches fault 4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum PulseError {
    /// Incremental targets: the mock plays absolute targets only.
    #[error("channel {channel} segment {segment}: incremental targets are not supported")]
    NotAbsolute {
        /// Pulse channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
    },
    /// The first frequency is outside the segment's range or above the channel's limit.
    #[error(
        "channel {channel} segment {segment}: first frequency {freq_hz} Hz is outside \
         {min_hz}..={max_hz} Hz (operation error)"
    )]
    FirstFrequencyOutOfRange {
        /// Pulse channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
        /// The frequency value.
        freq_hz: u32,
        /// Lowest allowed.
        min_hz: u32,
        /// Highest allowed.
        max_hz: u32,
    },
}

/// The segment a channel is playing.
#[derive(Debug, Clone, PartialEq)]
struct Playing {
    segment: usize,
    direction: Direction,
    range: FrequencyRange,
    rows: Vec<Row>,
    row: usize,
    row_start_s: f64,
    actual_hz: f64,
    step: i64,
    /// Pulses of the current row; `None` while running on without end.
    pulses: Option<i64>,
    emitted: i64,
}

/// One pulse channel.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Engine {
    channel: u8,
    limit_hz: u32,
    model: FrequencyModel,
    count: i64,
    playing: Option<Playing>,
    /// A segment halted by a stop that only pauses, and when it was halted, s.
    paused: Option<(Playing, f64)>,
}

impl Engine {
    /// An idle channel at count 0 with top frequency `limit_hz`.
    #[must_use]
    pub(super) fn new(channel: u8, limit_hz: u32, model: FrequencyModel) -> Self {
        Self {
            channel,
            limit_hz,
            model,
            count: 0,
            playing: None,
            paused: None,
        }
    }

    /// The elapsed (absolute) count.
    #[must_use]
    pub(super) fn count(&self) -> i64 {
        self.count
    }

    /// Presets the count (as writing the elapsed-value register does, e.g. after homing).
    pub(super) fn set_count(&mut self, count: i64) {
        self.count = count;
    }

    /// Whether the channel is outputting pulses.
    #[must_use]
    pub(super) fn busy(&self) -> bool {
        self.playing.is_some()
    }

    /// Whether the channel is running on without end.
    #[must_use]
    pub(super) fn running_on(&self) -> bool {
        self.playing.as_ref().is_some_and(|p| p.pulses.is_none())
    }

    /// Stops pulse output at once and ends the segment (a paused one too); the count stays
    /// where it is.
    pub(super) fn stop(&mut self) {
        self.playing = None;
        self.paused = None;
    }

    /// What a stop command does at `at_s`: ends the segment when `aborts`, else pauses it (the
    /// busy flag drops; the next F174 resumes it).
    pub(super) fn halt(&mut self, at_s: f64, aborts: bool) {
        if aborts {
            return self.stop();
        }
        if let Some(p) = self.playing.take() {
            tracing::warn!(
                channel = self.channel,
                count = self.count,
                at_s,
                "stop paused the segment"
            );
            self.paused = Some((p, at_s));
        }
    }

    fn allowed(&self, range: FrequencyRange) -> (u32, u32) {
        (range.min_set_hz(), range.max_set_hz().min(self.limit_hz))
    }

    /// Whether F174 would accept `seg` (segment index `segment`, 1-based) on this channel.
    pub(super) fn check(&self, seg: &Segment, segment: usize) -> Result<(), PulseError> {
        let channel = self.channel;
        if !seg.control.absolute {
            return Err(PulseError::NotAbsolute { channel, segment });
        }
        let Some(first) = seg.rows.first() else {
            return Ok(());
        };
        let (min_hz, max_hz) = self.allowed(seg.control.range);
        if first.freq_hz < min_hz || first.freq_hz > max_hz {
            return Err(PulseError::FirstFrequencyOutOfRange {
                channel,
                segment,
                freq_hz: first.freq_hz,
                min_hz,
                max_hz,
            });
        }
        Ok(())
    }

    /// Executes F174 on `seg` at `at_s`. A segment without rows outputs nothing (the channel
    /// stays idle).
    pub(super) fn start(
        &mut self,
        seg: &Segment,
        segment: usize,
        at_s: f64,
        rec: &mut Recorder,
    ) -> Result<(), PulseError> {
        if let Some((mut p, paused_s)) = self.paused.take() {
            p.row_start_s += at_s - paused_s;
            tracing::warn!(
                channel = self.channel,
                paused = p.segment,
                refused = segment,
                at_s,
                "F174 resumed the paused segment and refused the new one"
            );
            self.playing = Some(p);
            return Ok(());
        }
        self.check(seg, segment)?;
        self.playing = None;
        if seg.rows.is_empty() {
            return Ok(());
        }
        self.playing = Some(Playing {
            segment,
            direction: seg.control.direction,
            range: seg.control.range,
            rows: seg.rows.clone(),
            row: 0,
            row_start_s: at_s,
            actual_hz: 0.0,
            step: 0,
            pulses: None,
            emitted: 0,
        });
        self.begin_row(0, at_s, rec);
        Ok(())
    }

    fn begin_row(&mut self, row: usize, at_s: f64, rec: &mut Recorder) {
        let (model, limit_hz, count) = (self.model, self.limit_hz, self.count);
        let p = self
            .playing
            .as_mut()
            .expect("a row begins only while playing");
        let Row { freq_hz, target } = p.rows[row];
        p.row = row;
        p.row_start_s = at_s;
        p.emitted = 0;
        p.actual_hz = row_actual_hz(model, freq_hz, p.range, f64::from(limit_hz));
        p.step = p.direction.sign();
        let delta = target - count;
        p.pulses = (delta * p.step > 0).then_some(delta.abs());
        let (segment, direction, range, runs_on) =
            (p.segment, p.direction, p.range, p.pulses.is_none());
        let (min_hz, max_hz) = self.allowed(range);
        if freq_hz < min_hz || freq_hz > max_hz {
            let a = Anomaly::Clamped {
                channel: self.channel,
                segment,
                row: row + 1,
                freq_hz,
                min_hz,
                max_hz,
                at_s,
            };
            note(a, rec);
        }
        if runs_on {
            let a = Anomaly::RunOn {
                channel: self.channel,
                segment,
                row: row + 1,
                from: count,
                target,
                direction,
                at_s,
            };
            note(a, rec);
        }
    }

    /// Emits every pulse that lands at or before `to_s`.
    pub(super) fn advance(&mut self, to_s: f64, rec: &mut Recorder) {
        while let Some(p) = &mut self.playing {
            let k = p.emitted + 1;
            let t = pulse_time_s(p.row_start_s, k, p.actual_hz);
            if t > to_s {
                return;
            }
            self.count += p.step;
            p.emitted = k;
            rec.pulse(PulsePoint {
                time_s: t,
                channel: self.channel,
                count: self.count,
            });
            if p.pulses == Some(k) {
                let next = p.row + 1;
                if next == p.rows.len() {
                    self.playing = None;
                } else {
                    self.begin_row(next, t, rec);
                }
            }
        }
    }
}

/// Logs `anomaly` (a clamped row as a warning, a count that runs on as an error) and records it.
fn note(anomaly: Anomaly, rec: &mut Recorder) {
    match anomaly {
        Anomaly::Clamped {
            channel,
            segment,
            row,
            freq_hz,
            min_hz,
            max_hz,
            ..
        } => tracing::warn!(
            channel,
            segment,
            row,
            freq_hz,
            min_hz,
            max_hz,
            "row frequency out of range: clamped"
        ),
        Anomaly::RunOn {
            channel,
            segment,
            row,
            from,
            target,
            ..
        } => tracing::error!(
            channel,
            segment,
            row,
            from,
            target,
            "target against the segment's direction: the count runs on without end until a stop"
        ),
    }
    rec.anomalies.push(anomaly);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(direction: Direction, rows: &[(u32, i64)]) -> Segment {
        crate::table::pulse_sign_segment(direction, FrequencyRange::High, rows)
    }

    fn recorder() -> Recorder {
        Recorder {
            pulses: Some(Vec::new()),
            ..Recorder::default()
        }
    }

    #[test]
    fn rows_chain_and_pulses_land_at_k_over_f() {
        let mut e = Engine::new(0, 100_000, FrequencyModel::Ideal);
        let mut rec = recorder();
        e.start(
            &seg(Direction::Up, &[(1_000, 2), (500, 3)]),
            1,
            1.0,
            &mut rec,
        )
        .unwrap();
        e.advance(10.0, &mut rec);
        let times: Vec<f64> = rec.pulses.unwrap().iter().map(|p| p.time_s).collect();
        assert_eq!(times, vec![1.001, 1.002, 1.004]);
        assert!(!e.busy());
        assert_eq!(e.count(), 3);
    }

    #[test]
    fn advance_stops_between_pulses_and_resumes() {
        let mut e = Engine::new(0, 100_000, FrequencyModel::Ideal);
        let mut rec = recorder();
        e.start(&seg(Direction::Down, &[(1_000, -5)]), 1, 0.0, &mut rec)
            .unwrap();
        e.advance(0.0025, &mut rec);
        assert_eq!(e.count(), -2);
        assert!(e.busy());
        e.advance(0.005, &mut rec);
        assert_eq!(e.count(), -5);
        assert!(!e.busy());
    }

    #[test]
    fn segment_without_rows_outputs_nothing() {
        let mut e = Engine::new(0, 100_000, FrequencyModel::Ideal);
        e.start(&seg(Direction::Up, &[]), 1, 0.0, &mut recorder())
            .unwrap();
        assert!(!e.busy());
    }

    #[test]
    fn channel_two_refuses_a_first_frequency_above_twenty_kilohertz() {
        let e = Engine::new(2, 20_000, FrequencyModel::Ideal);
        let err = e.check(&seg(Direction::Up, &[(20_001, 5)]), 1).unwrap_err();
        assert!(matches!(
            err,
            PulseError::FirstFrequencyOutOfRange { max_hz: 20_000, .. }
        ));
    }

    #[test]
    fn a_pausing_stop_resumes_the_old_segment_at_the_next_start() {
        let mut e = Engine::new(0, 100_000, FrequencyModel::Ideal);
        let mut rec = recorder();
        e.start(&seg(Direction::Up, &[(1_000, 10)]), 1, 0.0, &mut rec)
            .unwrap();
        e.advance(0.0035, &mut rec);
        e.halt(0.0035, false);
        assert!(!e.busy());
        e.advance(1.0, &mut rec);
        assert_eq!(e.count(), 3);
        e.start(&seg(Direction::Down, &[(1_000, 0)]), 1, 1.0, &mut rec)
            .unwrap();
        assert!(e.busy());
        e.advance(2.0, &mut rec);
        assert_eq!(e.count(), 10, "the paused segment ran to its own target");
        let last = rec.pulses.unwrap().last().unwrap().time_s;
        assert!((last - 1.0065).abs() < 1e-9, "{last}");
    }

    #[test]
    fn an_aborting_stop_leaves_nothing_to_resume() {
        let mut e = Engine::new(0, 100_000, FrequencyModel::Ideal);
        let mut rec = recorder();
        e.start(&seg(Direction::Up, &[(1_000, 10)]), 1, 0.0, &mut rec)
            .unwrap();
        e.advance(0.0035, &mut rec);
        e.halt(0.0035, true);
        e.start(&seg(Direction::Down, &[(1_000, 0)]), 1, 1.0, &mut rec)
            .unwrap();
        e.advance(2.0, &mut rec);
        assert_eq!(e.count(), 0);
    }

    #[test]
    fn equal_target_runs_on_in_the_segment_direction() {
        let mut e = Engine::new(1, 100_000, FrequencyModel::Ideal);
        let mut rec = recorder();
        e.start(&seg(Direction::Up, &[(1_000, 0)]), 1, 0.0, &mut rec)
            .unwrap();
        e.advance(1.0, &mut rec);
        assert_eq!(e.count(), 1_000);
        assert!(e.running_on());
        assert!(matches!(
            rec.anomalies[0],
            Anomaly::RunOn {
                from: 0,
                target: 0,
                ..
            }
        ));
    }
}
