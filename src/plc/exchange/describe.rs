//! Describing a start the host did not give (found running after a daemon restart): its bank read
//! back from the PLC, decoded, and turned into the [`Planned`] the machine watches it with.
//!
//! The command block describes the running start only while its `seq` is the running one's.
//! Once a later start was written (waiting, withdrawn, or refused) the running one's bank is the
//! other one (a start is only ever uploaded into the bank that is not running), its segment counts
//! come from each area's directory and its `from` is unknown: then only the channels whose tables
//! hold their present count are bounded, and no final counts are compared.

use crate::contract::Permit;
use std::time::Duration;

use super::{Contract, ContractError};
use crate::contract::machine::{Planned, Status};
use crate::contract::{CHANNELS, CommandBlock};
use crate::plc::Plc;
use crate::table::{DIRECTORY_WORDS, DecodeError, Segment, decode};

/// Words read at a time while looking for the end of a table.
const READ_STEP: u16 = 120;

impl<P: Plc> Contract<P> {
    /// The segments of `channel`'s table in `bank`: `segments` of them, or as many as its
    /// directory names.
    pub async fn read_table(
        &mut self,
        bank: u16,
        channel: usize,
        segments: Option<usize>,
    ) -> Result<Vec<Segment>, ContractError> {
        let layout = self.settings.layout;
        let start = layout.area(bank, channel);
        let bad = |detail: String| ContractError::BadTable {
            bank,
            channel,
            detail,
        };
        let mut words = self.plc.read_words(start, DIRECTORY_WORDS as u16).await?;
        let count =
            segments.unwrap_or_else(|| words.iter().take_while(|&&offset| offset != 0).count());
        if count == 0 {
            return Ok(Vec::new());
        }
        loop {
            match decode(&words, count) {
                Ok(segments) => return Ok(segments),
                Err(DecodeError::Unterminated { .. } | DecodeError::BadOffset { .. })
                    if words.len() < usize::from(layout.area_words) =>
                {
                    let more = READ_STEP.min(layout.area_words - words.len() as u16);
                    let next = start + words.len() as u16;
                    words.extend(self.plc.read_words(next, more).await?);
                }
                Err(e) => return Err(bad(e.to_string())),
            }
        }
    }

    /// The table of channel `c` in `bank` of a running start: `segments` of them when the
    /// command block describes it (then a table that cannot be read is an error), else as many as
    /// its directory names (then none, if it cannot be read).
    async fn running_table(
        &mut self,
        bank: u16,
        c: usize,
        segments: Option<usize>,
    ) -> Result<Vec<Segment>, ContractError> {
        match self.read_table(bank, c, segments).await {
            Err(e) if segments.is_none() => {
                tracing::debug!(channel = c, error = %e, "no table to bound the channel by");
                Ok(Vec::new())
            }
            read => read,
        }
    }

    /// Describes start `seq`, found running with `status`, as `tag` (see the module docs).
    pub async fn describe_running(
        &mut self,
        seq: u16,
        tag: u64,
        status: &Status,
    ) -> Result<Planned, ContractError> {
        let block = self.command_block().await?;
        let known = block.seq == seq;
        let elapsed = status.block.elapsed;
        let mut planned = unbounded(tag, seq, &block, elapsed);
        let bank = planned.bank;
        let mut targets = planned.from;
        for c in 0..CHANNELS {
            let busy = status.block.busy & (1 << c) != 0;
            if known && block.mask & (1 << c) == 0 {
                continue;
            }
            let segments = known.then(|| usize::from(block.segments[c]));
            let table = self.running_table(bank, c, segments).await?;
            let (min, max, end, seconds) = bounds(planned.from[c], &table);
            let holds_count = (min..=max).contains(&elapsed[c]);
            if known || (holds_count && !table.is_empty()) {
                planned.envelope[c] = (min, max);
                targets[c] = end;
                planned.duration = planned.duration.max(Duration::from_secs_f64(seconds));
            } else if busy {
                planned.envelope[c] = (i32::MIN, i32::MAX);
            }
        }
        planned.targets = known.then_some(targets);
        Ok(planned)
    }
}

/// Start `seq` as `tag` before its tables are read, each channel bounded by its count now
/// (`elapsed`): its bank, `from` and permit `block`'s when that describes it, else the other
/// bank (a start is only uploaded into the bank that is not running).
fn unbounded(tag: u64, seq: u16, block: &CommandBlock, elapsed: [i32; CHANNELS]) -> Planned {
    let known = block.seq == seq;
    Planned {
        tag,
        seq,
        bank: if known {
            block.bank
        } else {
            1 - block.bank.min(1)
        },
        from: if known { block.from } else { elapsed },
        targets: None,
        envelope: std::array::from_fn(|c| (elapsed[c], elapsed[c])),
        duration: Duration::ZERO,
        // Its plan is not known here: its progress is the clock's.
        curve: None,
        permit: if known { block.permit } else { Permit::NONE },
    }
}

/// A channel's lowest and highest count, last target and playing time from `from` through
/// `segments` (each row at its frequency value).
fn bounds(from: i32, segments: &[Segment]) -> (i32, i32, i32, f64) {
    let (mut min, mut max, mut at, mut seconds) = (from, from, i64::from(from), 0.0);
    for row in segments.iter().flat_map(|s| &s.rows) {
        let target = row.target as i32;
        min = min.min(target);
        max = max.max(target);
        if row.freq_hz > 0 {
            seconds += (row.target - at).unsigned_abs() as f64 / f64::from(row.freq_hz);
        }
        at = row.target;
    }
    (min, max, at as i32, seconds)
}

/// The envelope, final counts and duration of a plan's tables, per channel (`from` for a channel
/// without a table).
#[must_use]
pub fn planned_bounds(
    from: [i32; CHANNELS],
    tables: &[(usize, &[Segment])],
) -> ([(i32, i32); CHANNELS], [i32; CHANNELS]) {
    let mut envelope = from.map(|f| (f, f));
    let mut targets = from;
    for &(c, segments) in tables {
        let (min, max, end, _) = bounds(from[c], segments);
        envelope[c] = (min, max);
        targets[c] = end;
    }
    (envelope, targets)
}
