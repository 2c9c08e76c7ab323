//! What the mock's pulse engines did: every pulse (optional, it can be large) and every anomaly
//! (a clamped frequency, a run-on), with the pulse trace as CSV `time_s,channel,count`.

use std::io::{self, Write};

use crate::table::Direction;

/// One pulse: at `time_s`, `channel`'s count became `count`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PulsePoint {
    /// Seconds since the mock started.
    pub time_s: f64,
    /// Pulse channel 0-3.
    pub channel: u8,
    /// The count after this pulse.
    pub count: i64,
}

/// Something a real FP-X would do that a good table never asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anomaly {
    /// A row's frequency was outside its range or above the channel's limit: it ran clamped.
    Clamped {
        /// Pulse channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
        /// Row index (1-based).
        row: usize,
        /// The frequency value written.
        freq_hz: u32,
        /// Lowest value the range allows.
        min_hz: u32,
        /// Highest value the range and channel allow.
        max_hz: u32,
        /// When the row began, s.
        at_s: f64,
    },
    /// A row's target was against the segment's direction (or equal to the count): the count runs
    /// on without end until a stop.
    RunOn {
        /// Pulse channel.
        channel: u8,
        /// Segment index (1-based).
        segment: usize,
        /// Row index (1-based).
        row: usize,
        /// The count when the row began.
        from: i64,
        /// The row's target.
        target: i64,
        /// The segment's direction (the way the count runs).
        direction: Direction,
        /// When the row began, s.
        at_s: f64,
    },
}

/// A write a client (the host) made to the PLC's memory, and whether the host could have known
/// of the last power cycle before it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HostWrite {
    /// The mock's command count at it ([`super::MockPlc::commands`]).
    pub command: u64,
    /// The area: DT words, or Y / R bits.
    pub area: crate::gateway::Area,
    /// The first word or bit written.
    pub start: u32,
    /// The words, or the bits as 0 and 1.
    pub values: Vec<u16>,
    /// Whether the mock had power-cycled and a client had read the status block's `host` word
    /// since (the host then knew of the restart before it wrote this).
    pub after_restart_seen: bool,
    /// The channels' counts as the write landed (where the robot stood).
    pub counts: [i64; 4],
}

/// A client's write into a table area (an upload's or a preload's), in the order written: when
/// a bank was written, against the other writes ([`HostWrite::command`]) and the starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableWrite {
    /// The mock's command count at it.
    pub command: u64,
    /// When, s since the mock started (as [`super::StartRecord::at_s`]).
    pub at_s: f64,
    /// The bank written.
    pub bank: u16,
    /// The channel whose area was written.
    pub channel: usize,
    /// The first word written.
    pub start: u32,
    /// How many words.
    pub words: usize,
}

/// A power cut of the mock ([`super::MockPlc::power_cycle`]): what it lost.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PowerCut {
    /// The mock's command count at it: a write of the same command landed after it.
    pub command: u64,
    /// The channels' counts before they were lost (where the robot stood).
    pub counts: [i64; 4],
    /// The Y outputs that were on (and went off).
    pub outputs: Vec<u32>,
    /// The non-hold R relays that were on (and went off).
    pub relays: Vec<u32>,
}

/// Where the engines put what they did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recorder {
    /// Every pulse, in the order emitted (channel by channel between two scans), when recording.
    pub pulses: Option<Vec<PulsePoint>>,
    /// Every anomaly since the mock started.
    pub anomalies: Vec<Anomaly>,
    /// Every write a client made, in order.
    pub host_writes: Vec<HostWrite>,
    /// Every write a client made into a table area, in order.
    pub table_writes: Vec<TableWrite>,
    /// What a client can know of the last power cycle.
    pub restart: RestartSeen,
    /// Every power cut, in order.
    pub power_cuts: Vec<PowerCut>,
}

/// What a client can know of the mock's last power cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RestartSeen {
    /// It never power-cycled.
    #[default]
    Never,
    /// It power-cycled and has not scanned since: its status block still shows the old `host`
    /// word.
    NotScanned,
    /// Its first scan since cleared the `host` word; no client has read it since.
    Unseen,
    /// A client has read the cleared `host` word.
    Seen,
}

impl Recorder {
    /// Notes one pulse if recording.
    pub fn pulse(&mut self, point: PulsePoint) {
        if let Some(p) = &mut self.pulses {
            p.push(point);
        }
    }
}

/// Writes pulses as CSV, header `time_s,channel,count`, sorted by time (ties by channel).
pub fn write_csv(pulses: &[PulsePoint], mut out: impl Write) -> io::Result<()> {
    let mut sorted = pulses.to_vec();
    sorted.sort_by(|a, b| {
        a.time_s
            .total_cmp(&b.time_s)
            .then(a.channel.cmp(&b.channel))
    });
    writeln!(out, "time_s,channel,count")?;
    for p in sorted {
        writeln!(out, "{:.9},{},{}", p.time_s, p.channel, p.count)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_has_the_header_and_rows_in_time_order() {
        let pulses = [
            PulsePoint {
                time_s: 0.002,
                channel: 1,
                count: -1,
            },
            PulsePoint {
                time_s: 0.001,
                channel: 0,
                count: 11,
            },
        ];
        let mut out = Vec::new();
        write_csv(&pulses, &mut out).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "time_s,channel,count\n0.001000000,0,11\n0.002000000,1,-1\n"
        );
    }

    #[test]
    fn recorder_keeps_pulses_only_when_recording() {
        let mut r = Recorder::default();
        r.pulse(PulsePoint {
            time_s: 0.0,
            channel: 0,
            count: 1,
        });
        assert!(r.pulses.is_none());
        r.pulses = Some(Vec::new());
        r.pulse(PulsePoint {
            time_s: 0.0,
            channel: 0,
            count: 1,
        });
        assert_eq!(r.pulses.unwrap().len(), 1);
    }
}
