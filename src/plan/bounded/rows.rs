//! Rows from pulse windows: from where the channel really is, the longest run of pulses that
//! one realisable frequency lands inside all their windows (pulse i of a row lands at
//! `start + i / f`), then the next row from where that one really ends. Each stretch of one
//! direction becomes segments in the finest frequency range that plays it without breaking a
//! window, split where no range can.

use super::pulses::{Pulse, Run};
use crate::plan::segments::segment;
use crate::robot::Joint;
use crate::table::{FrequencyModel, FrequencyRange, MAX_SEGMENTS, Row, Segment};

/// What a channel can play: its joint, the model, and the segments left.
pub(super) struct Channel<'a> {
    /// The joint.
    pub joint: &'a Joint,
    /// The frequency model.
    pub model: FrequencyModel,
}

/// Rows for a stretch of pulses in one range.
struct Attempt {
    rows: Vec<Row>,
    end_s: f64,
    /// Pulses before the first one that could not land in its window.
    clean_pulses: usize,
    broken: usize,
}

impl Channel<'_> {
    fn fastest_set(&self, range: FrequencyRange) -> u32 {
        range
            .max_set_hz()
            .min(self.joint.max_freq_hz)
            .max(range.min_set_hz())
    }

    /// A set value whose real frequency gives a pulse period in `[lo_s, hi_s]`, and that
    /// frequency.
    fn realise(
        &self,
        range: FrequencyRange,
        lo_s: f64,
        hi_s: f64,
        want_s: f64,
    ) -> Option<(u32, f64)> {
        let set = self
            .model
            .set_for_period(range, lo_s, hi_s, want_s, self.joint.max_freq_hz)?;
        Some((
            set,
            self.model
                .actual_hz(set, range)
                .min(f64::from(self.joint.max_freq_hz)),
        ))
    }

    /// The longest row from `t_s` over `pulses`, or `None` when not even one pulse fits.
    fn longest(
        &self,
        range: FrequencyRange,
        pulses: &[Pulse],
        t_s: f64,
    ) -> Option<(usize, u32, f64)> {
        let fastest = self
            .model
            .actual_hz(self.fastest_set(range), range)
            .min(f64::from(self.joint.max_freq_hz));
        let (mut lo, mut hi) = (1.0 / fastest, 1.0 / range.min_actual_hz());
        let mut bounds = Vec::new();
        for (i, p) in pulses.iter().enumerate() {
            let n = (i + 1) as f64;
            lo = lo.max((p.lo_s - t_s) / n);
            hi = hi.min((p.hi_s - t_s) / n);
            if lo > hi {
                break;
            }
            bounds.push((lo, hi));
        }
        bounds.iter().enumerate().rev().find_map(|(i, &(lo, hi))| {
            let want = (pulses[i].ideal_s - t_s) / (i + 1) as f64;
            self.realise(range, lo, hi, want)
                .map(|(set, f)| (i + 1, set, f))
        })
    }

    /// Rows for `pulses` in `range` from `t_s`; a pulse no frequency can place is played at the
    /// nearest the range allows and counted as broken.
    fn attempt(&self, range: FrequencyRange, pulses: &[Pulse], mut t_s: f64) -> Attempt {
        let mut a = Attempt {
            rows: Vec::new(),
            end_s: t_s,
            clean_pulses: pulses.len(),
            broken: 0,
        };
        let mut k = 0;
        while k < pulses.len() {
            let (m, set, f) = self.longest(range, &pulses[k..], t_s).unwrap_or_else(|| {
                if a.broken == 0 {
                    a.clean_pulses = k;
                }
                a.broken += 1;
                let want = (pulses[k].ideal_s - t_s).max(1e-6);
                let set = self
                    .model
                    .best_set_hz(1.0 / want, 1, range, self.joint.max_freq_hz);
                (
                    1,
                    set,
                    self.model
                        .actual_hz(set, range)
                        .min(f64::from(self.joint.max_freq_hz)),
                )
            });
            t_s += m as f64 / f;
            k += m;
            a.rows.push(Row {
                freq_hz: set,
                target: pulses[k - 1].count,
            });
        }
        a.end_s = t_s;
        a
    }

    /// Segments for one run of pulses starting at `t_s` from `count`; returns them and the
    /// time the last pulse lands. `segments_left` bounds the splitting.
    pub(super) fn run(
        &self,
        run: &Run,
        mut t_s: f64,
        mut count: i64,
        segments_left: usize,
    ) -> (Vec<Segment>, f64) {
        let mut out = Vec::new();
        let mut pulses = &run.pulses[..];
        while !pulses.is_empty() {
            let attempts = FrequencyRange::FINEST_FIRST.map(|r| (r, self.attempt(r, pulses, t_s)));
            let clean = attempts.iter().find(|(_, a)| a.broken == 0);
            let last_chance = out.len() + 1 >= segments_left.min(MAX_SEGMENTS);
            let (range, a) = match clean {
                Some(found) => found,
                None if last_chance => attempts
                    .iter()
                    .min_by_key(|(_, a)| a.broken)
                    .expect("three ranges"),
                None => attempts
                    .iter()
                    .max_by_key(|(_, a)| a.clean_pulses)
                    .expect("three ranges"),
            };
            let take = if clean.is_some() || last_chance || a.clean_pulses == 0 {
                pulses.len()
            } else {
                a.clean_pulses
            };
            let rows = rows_covering(&a.rows, count, take);
            let played = rows
                .last()
                .map_or(0, |r| (r.target - count).unsigned_abs() as usize);
            t_s = if played == pulses.len() {
                a.end_s
            } else {
                self.end_of(*range, &rows, t_s, count)
            };
            count = rows.last().map_or(count, |r| r.target);
            out.push(segment(self.joint, run.direction, *range, rows));
            pulses = &pulses[played.max(1).min(pulses.len())..];
        }
        (out, t_s)
    }

    fn end_of(&self, range: FrequencyRange, rows: &[Row], mut t_s: f64, mut count: i64) -> f64 {
        for r in rows {
            let f = self
                .model
                .actual_hz(r.freq_hz, range)
                .min(f64::from(self.joint.max_freq_hz));
            t_s += (r.target - count).abs() as f64 / f;
            count = r.target;
        }
        t_s
    }
}

/// The rows that play exactly the first `pulses` pulses from `count`.
fn rows_covering(rows: &[Row], count: i64, pulses: usize) -> Vec<Row> {
    rows.iter()
        .take_while(|r| (r.target - count).unsigned_abs() as usize <= pulses)
        .copied()
        .collect()
}
