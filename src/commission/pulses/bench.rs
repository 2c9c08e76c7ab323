//! The bench a channel's checks run on: the channel under test and the tables it takes, the
//! contract with the next sequence number and bank, and a run of one start polled to its end.

use std::time::Duration;

use tokio::time::Instant;

use super::{MAX_HZ, MIN_HZ, QUIET_POLLS, RANGE, within};
use crate::commission::LinkTiming;
use crate::commission::error::Failure;
use crate::contract::{CHANNELS, Fault, Permit, State, StatusBlock};
use crate::plc::Plc;
use crate::plc::exchange::{Contract, StartBlock, fault_meaning};
use crate::robot::Joint;
use crate::table::{
    ChannelLimits, ChannelTable, ControlCode, Direction, Duty, FrequencyModel, Row, Segment,
    validate,
};

/// The channel under test.
#[derive(Debug, Clone, Copy)]
pub(super) struct Channel<'a> {
    pub c: u8,
    pub joint: &'a Joint,
    /// +1 or -1: the direction towards the middle of the joint's range.
    pub sign: i64,
    pub limits: ChannelLimits,
}

impl Channel<'_> {
    pub(super) fn index(&self) -> usize {
        usize::from(self.c)
    }

    pub(super) fn top_hz(&self) -> u32 {
        MAX_HZ
            .min(self.joint.max_freq_hz)
            .max(MIN_HZ.min(self.joint.max_freq_hz))
    }

    pub(super) fn low_hz(&self) -> u32 {
        MIN_HZ.min(self.top_hz())
    }

    /// A frequency giving `pulses` pulses about `duration_s`.
    pub(super) fn hz_for(&self, pulses: i64, duration_s: f64) -> u32 {
        ((pulses as f64 / duration_s).round() as u32).clamp(self.low_hz(), self.top_hz())
    }

    pub(super) fn segment(&self, from: i64, to: i64, freq_hz: u32) -> Segment {
        let direction = if to > from {
            Direction::Up
        } else {
            Direction::Down
        };
        Segment {
            control: ControlCode {
                output: self.joint.output,
                direction,
                absolute: true,
                range: RANGE,
                duty: Duty::Half,
            },
            rows: vec![Row {
                freq_hz,
                target: to,
            }],
        }
    }
}

/// One status read while a table plays.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sample {
    pub t_s: f64,
    pub block: StatusBlock,
    pub state: State,
}

/// What one start did.
#[derive(Debug, Default)]
pub(super) struct Run {
    pub seq: u16,
    pub samples: Vec<Sample>,
    /// A stop the run wrote: when (s since the start) and why.
    pub stopped_for: Option<(f64, String)>,
    /// The link failed.
    pub link_error: Option<String>,
}

impl Run {
    pub(super) fn last(&self) -> Option<&Sample> {
        self.samples.last()
    }

    pub(super) fn count(&self, c: usize) -> Option<i64> {
        self.last().map(|s| i64::from(s.block.elapsed[c]))
    }

    pub(super) fn ended(&self, state: State) -> bool {
        self.last()
            .is_some_and(|s| s.state == state && s.block.seq == self.seq)
    }

    /// Whether the start was refused with `fault` and nothing moved: its seq not latched (still
    /// `seq_before`), channel `c` still at `c0` and never busy.
    pub(super) fn refused_still(&self, fault: Fault, seq_before: u16, c: usize, c0: i64) -> bool {
        let refused = self.last().is_some_and(|x| {
            x.state == State::Fault && x.block.fault == fault.word() && x.block.seq == seq_before
        });
        refused && self.count(c).unwrap_or(c0) == c0 && self.busy_reads(c) == 0
    }

    /// Whether `sample` ends the run: a fault, its own start done or stopped, or any end
    /// once the run wrote a stop.
    fn is_over(&self, sample: &Sample) -> bool {
        let ours = sample.block.seq == self.seq;
        sample.state == State::Fault
            || (ours && matches!(sample.state, State::Done | State::Stopped))
            || (self.stopped_for.is_some() && sample.state != State::Running)
    }

    /// How a start that must not run ended, then where channel `c` (found at `c0`) ended and
    /// in how many reads it was busy.
    pub(super) fn still_words(&self, c: usize, c0: i64) -> String {
        format!(
            "{}; the count ended at {}, busy ON in {} reads",
            self.ending(),
            self.count(c).unwrap_or(c0),
            self.busy_reads(c)
        )
    }

    pub(super) fn busy_reads(&self, c: usize) -> usize {
        self.samples
            .iter()
            .filter(|s| s.block.busy & (1 << c) != 0)
            .count()
    }

    /// How it ended, in words.
    pub(super) fn ending(&self) -> String {
        if let Some(e) = &self.link_error {
            return format!("the link failed: {e}");
        }
        let Some(last) = self.last() else {
            return "no status read".to_owned();
        };
        let state = match last.state {
            State::Fault => format!(
                "state fault, fault {} ({})",
                last.block.fault,
                fault_meaning(last.block.fault)
            ),
            other => format!("state {}", other.name()),
        };
        let whose = if last.block.seq == self.seq {
            format!("seq {}", self.seq)
        } else {
            format!("seq {} (ours {} not taken)", last.block.seq, self.seq)
        };
        match &self.stopped_for {
            Some((t, why)) => format!("{state}, {whose}; stopped at {t:.3} s: {why}"),
            None => format!("{state}, {whose}"),
        }
    }
}

/// Irregular poll intervals, 0.5..1.5 times `poll` (a low-discrepancy sequence).
pub(super) fn jittered(poll: Duration, k: u32) -> Duration {
    poll.mul_f64(0.5 + (f64::from(k) * 0.618_033_988_749_895).fract())
}

/// The contract, the pace and the next sequence number and bank.
pub(super) struct Bench<'c, P> {
    pub contract: &'c mut Contract<P>,
    pub pace: LinkTiming,
    pub seq: u16,
    pub bank: u16,
}

/// Decides, from each sample, whether to write a stop and why.
pub(super) type Watch<'w> = &'w dyn Fn(&Sample) -> Option<String>;

impl<P: Plc> Bench<'_, P> {
    pub(super) fn next_seq(&mut self) -> u16 {
        self.seq = self.seq.wrapping_add(1).max(1);
        self.seq
    }

    pub(super) async fn status(&mut self) -> Result<StatusBlock, Failure> {
        Ok(self.contract.status().await?.block)
    }

    /// Uploads `segments` for channel `ch` with `from` and `permit` (and `seq`, or a new one)
    /// and writes the start once.
    pub(super) async fn launch(
        &mut self,
        ch: &Channel<'_>,
        segments: Vec<Segment>,
        (from, permit): ([i32; CHANNELS], Permit),
        seq: Option<u16>,
    ) -> Result<u16, Failure> {
        let table = ChannelTable {
            channel: ch.c,
            start: i64::from(from[ch.index()]),
            segments,
        };
        let table =
            validate(table, ch.limits).map_err(|problems| Failure::OwnTable { problems })?;
        let seq = seq.unwrap_or_else(|| self.next_seq());
        self.bank ^= 1;
        let start = StartBlock {
            bank: self.bank,
            seq,
            from,
            permit,
        };
        let mut upload = self.contract.begin_upload(&start, &[table])?;
        let bank = loop {
            if let Some(bank) = self.contract.upload_step(&mut upload).await? {
                break bank;
            }
        };
        self.contract.start(&bank).await?;
        Ok(seq)
    }

    /// Plays a table and polls until it ends (done, stopped or a fault), writing a stop when
    /// `watch` asks or when it runs past `deadline_s`.
    pub(super) async fn play(
        &mut self,
        ch: &Channel<'_>,
        segments: Vec<Segment>,
        from: [i32; CHANNELS],
        deadline_s: f64,
        watch: Watch<'_>,
    ) -> Run {
        self.play_permitted(ch, segments, (from, Permit::NONE), deadline_s, watch)
            .await
    }

    /// [`Self::play`] for a start whose command block carries `permit`.
    pub(super) async fn play_permitted(
        &mut self,
        ch: &Channel<'_>,
        segments: Vec<Segment>,
        start: ([i32; CHANNELS], Permit),
        deadline_s: f64,
        watch: Watch<'_>,
    ) -> Run {
        let mut run = Run::default();
        match self.launch(ch, segments, start, None).await {
            Ok(seq) => run.seq = seq,
            Err(e) => {
                run.link_error = Some(e.to_string());
                return run;
            }
        }
        let began = Instant::now();
        for k in 0.. {
            tokio::time::sleep(jittered(self.pace.poll(), k)).await;
            let sample = match self.contract.status().await {
                Ok(st) => Sample {
                    t_s: began.elapsed().as_secs_f64(),
                    block: st.block,
                    state: st.state,
                },
                Err(e) => {
                    run.link_error = Some(format!("{e:#}"));
                    let _ = self.contract.stop().await;
                    break;
                }
            };
            let t_s = sample.t_s;
            run.samples.push(sample);
            if run.stopped_for.is_none() {
                let why = watch(&sample).or_else(|| {
                    (t_s > deadline_s).then(|| format!("no end within {deadline_s:.2} s"))
                });
                if let Some(why) = why {
                    if !self.stop_for(ch, &mut run, t_s, why).await {
                        break;
                    }
                    continue;
                }
            }
            if run.is_over(&sample) || t_s > deadline_s + 1.0 {
                break;
            }
        }
        run
    }

    /// Plays a table on `ch` from `at` to `to` (the counts `from`), stopping it should the count
    /// leave the span between them.
    pub(super) async fn play_between(
        &mut self,
        ch: &Channel<'_>,
        from: [i32; CHANNELS],
        (at, to, hz): (i64, i64, u32),
        deadline_s: f64,
    ) -> Run {
        let watch = within(ch.index(), at.min(to), at.max(to));
        self.play(ch, vec![ch.segment(at, to, hz)], from, deadline_s, &watch)
            .await
    }

    /// Plays a start that must be refused: a stop is written as soon as channel `ch` leaves
    /// `c0` or the program runs.
    pub(super) async fn play_refused(
        &mut self,
        ch: &Channel<'_>,
        segment: Segment,
        start: ([i32; CHANNELS], Permit),
        c0: i64,
        hz: u32,
    ) -> Run {
        let i = ch.index();
        let watch = move |x: &Sample| {
            (i64::from(x.block.elapsed[i]) != c0 || x.state == State::Running)
                .then(|| "the start ran".to_owned())
        };
        let deadline = self.deadline_s(0, hz) + self.pace.sample_s() * QUIET_POLLS as f64;
        self.play_permitted(ch, vec![segment], start, deadline, &watch)
            .await
    }

    /// Writes a stop for `why`, `t_s` into `run`: whether it was written (else the link failed).
    async fn stop_for(&mut self, ch: &Channel<'_>, run: &mut Run, t_s: f64, why: String) -> bool {
        tracing::warn!(channel = ch.c, %why, "commission: stop");
        if let Err(e) = self.contract.stop().await {
            run.link_error = Some(format!("{e:#}"));
            return false;
        }
        run.stopped_for = Some((t_s, why));
        true
    }

    /// How long `pulses` take at `hz` under the slower model, with room for polls and scans, s.
    pub(super) fn deadline_s(&self, pulses: i64, hz: u32) -> f64 {
        let slowest = FrequencyModel::FpxDivider
            .actual_hz(hz, RANGE)
            .min(f64::from(hz));
        pulses as f64 / slowest * 1.5 + 20.0 * self.pace.sample_s() + 0.5
    }

    /// Reads the status block `QUIET_POLLS` times; the reads.
    pub(super) async fn watch_quietly(&mut self) -> Result<Vec<StatusBlock>, Failure> {
        let mut out = Vec::with_capacity(QUIET_POLLS);
        for k in 0..QUIET_POLLS {
            tokio::time::sleep(jittered(self.pace.poll(), k as u32)).await;
            out.push(self.status().await?);
        }
        Ok(out)
    }
}

/// What to do about a start that did not end done, from how it ended.
pub(super) fn unfinished_hint(run: &Run) -> String {
    let fault = run
        .last()
        .filter(|s| s.state == State::Fault)
        .map(|s| s.block.fault);
    match fault.and_then(|f| Fault::from_word(f).ok()) {
        Some(Fault::PulseInstruction) => {
            "F174 refused the table (fault 4): check the listing's F174 and the control code \
             (R9008, the operation-error system register)"
                .to_owned()
        }
        Some(Fault::NotHomed) => "home the robot first (fault 6)".to_owned(),
        Some(Fault::NotAtStart) => {
            "the count moved between the read and the start (fault 5): is something else \
             driving this channel?"
                .to_owned()
        }
        Some(Fault::PermitNotMet) => {
            "the start was refused for its permit (fault 8): the program compares the permit with \
             other words than the status block's inputs, or an input changed under it"
                .to_owned()
        }
        Some(Fault::PermitDropped) => {
            "the move was held by its permit (fault 9): an input its permit looks at changed while \
             it ran"
                .to_owned()
        }
        Some(Fault::BadTableHeader) => {
            "the program could not decode the table (fault 1): check the table layout constants \
             in the listing against [robots.NAME.plc.contract]"
                .to_owned()
        }
        _ if run.link_error.is_some() => "the link failed during the run".to_owned(),
        _ => "the start did not end done: see what the status block showed".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jittered_polls_stay_within_half_and_one_and_a_half_of_the_poll() {
        let poll = Duration::from_millis(10);
        for k in 0..100 {
            let d = jittered(poll, k);
            assert!(d >= Duration::from_millis(5) && d < Duration::from_millis(15));
        }
    }
}
