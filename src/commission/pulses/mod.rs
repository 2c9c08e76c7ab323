//! The pulses step: one channel at a time, tiny tables in frequency range 0 at 100..2000 Hz,
//! each polled while it plays. Per channel, counts out and back so that it ends where it began:
//!
//! ```text
//! timing     c0 -> c0 + 500            busy on then off; elapsed moves by exactly the table's
//!                                      pulses; time taken vs frequency (a rate fit)
//! chain      -> +100 more, then back to c0 (two segments)      two-segment table chains
//! stop       c0 -> c0 + 300, stopped after 60; then back to c0 (a new start)
//!                                      stop mid-table then a following start works
//! interlock  from = c0 + 1 on this channel: must be refused with fault 5, nothing moves
//! repeat     a start with the last accepted seq: must be ignored, nothing moves
//! permit     a start whose permit does not hold: refused with fault 8; the same start with
//!            a permit that holds: c0 -> c0 + 50 and back; a start of 300 whose permit's R bit
//!            is switched once it runs: held with fault 9 within a scan, then back to c0
//! ```
//! The direction is the one towards the middle of the joint's range. The run lengths follow the
//! link's pace: the timing run lasts about 60 polls (0.25..5 s), at the frequency near that where
//! the `ideal` and `fpx-divider` models differ most ([`super::judge::timing_hz`]); polls come at
//! irregular intervals around the scan time so that the PLC's scan grid cannot bias the fit.
//! Anything unexpected while a table plays (the count past its target or moving the wrong way,
//! no end in time) writes `command = 2` at once.
//!
//! ```text
//! mod.rs       the channel loop, the constants
//! bench.rs     Channel, Bench (upload, start, poll a run, stop), Run and its samples
//! timing.rs    the timing run and its three checks
//! moves.rs     two-segment chain; stop mid-table and the following start
//! refusals.rs  the `from` interlock; the repeated seq
//! permit.rs    the permit refused at start (fault 8), and let run when it holds
//! hold.rs      the permit dropped while running: held within one scan (fault 9)
//! ```

mod bench;
mod hold;
mod moves;
mod permit;
mod refusals;
mod timing;

use bench::{Bench, Channel, Sample};

use super::contract::Found;
use super::report::ChannelCounts;
use super::{Check, Halt, LinkTiming, PULSE_CHECKS, Session, Step};
use crate::contract::CHANNELS;
use crate::plc::Plc;
use crate::plc::exchange::Contract;
use crate::robot::Joint;
use crate::table::FrequencyRange;

/// Pulses of the timing run.
const TIMING_PULSES: i64 = 500;
/// Pulses of the chain run's first segment (the second comes back to the start).
const CHAIN_PULSES: i64 = 100;
/// Pulses of the table that is stopped mid-way.
const STOP_PULSES: i64 = 300;
/// Pulses moved before the stop is written.
const STOP_AFTER: i64 = STOP_PULSES / 5;
/// Pulses of the tables that must not run (interlock, repeated seq).
const PROBE_PULSES: i64 = 50;
/// The frequency range of every commission table (whole hertz, the models differ most here).
const RANGE: FrequencyRange = FrequencyRange::Low;
/// Lowest and highest frequency value the commission writes, Hz.
const MIN_HZ: u32 = 100;
const MAX_HZ: u32 = 2_000;
/// Polls the timing run should last.
const TIMING_POLLS: f64 = 60.0;
/// Polls a quiet check watches (a refused or ignored start, a held count).
const QUIET_POLLS: usize = 10;

fn check(name: &'static str, channel: u8, checks: impl Into<String>) -> Check {
    debug_assert!(PULSE_CHECKS.contains(&name));
    Check::new(Step::Pulses, name, checks).on(channel)
}

/// The pulses step, channel by channel.
pub(super) async fn step<P: Plc>(
    s: &mut Session<'_>,
    contract: &mut Contract<P>,
    pace: LinkTiming,
    found: Found,
) -> Result<(), Halt> {
    let mut bench = Bench {
        contract,
        pace,
        seq: found.status.seq,
        bank: 1,
    };
    let robot = &s.target.robot;
    let channels = s.target.channels.clone();
    for c in channels {
        let Some(j) = robot.joints.iter().position(|j| j.channel == c) else {
            continue;
        };
        let joint = robot.joints[j].clone();
        let limits = robot.channel_limits(j);
        let count = match bench.status().await {
            Ok(st) => st.elapsed[usize::from(c)],
            Err(e) => {
                s.record(check("busy on then off", c, "").fail(e.to_string(), "the link failed"))?;
                return Err(Halt);
            }
        };
        let ch = Channel {
            c,
            joint: &joint,
            sign: toward_middle(&joint, i64::from(count)),
            limits,
        };
        s.findings.counts.push(ChannelCounts {
            channel: c,
            found: count,
            left: None,
        });
        channel(s, &mut bench, &ch).await?;
    }
    Ok(())
}

/// +1 when the count lies in the lower half of the joint's range, else -1.
fn toward_middle(joint: &Joint, count: i64) -> i64 {
    let (a, b) = (joint.count_of(joint.min), joint.count_of(joint.max));
    if 2 * count <= a + b { 1 } else { -1 }
}

async fn channel<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    timing::timing(s, bench, ch).await?;
    moves::chain(s, bench, ch).await?;
    moves::stop_then_start(s, bench, ch).await?;
    refusals::interlock(s, bench, ch).await?;
    refusals::repeated_seq(s, bench, ch).await?;
    permit::refuses(s, bench, ch).await?;
    hold::drop_holds(s, bench, ch).await
}

/// The counts now, or a failed check.
async fn counts<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    c: &Check,
) -> Result<[i32; CHANNELS], Halt> {
    match bench.status().await {
        Ok(st) => Ok(st.elapsed),
        Err(e) => {
            s.record(c.clone().fail(e.to_string(), "the link failed"))?;
            Err(Halt)
        }
    }
}

/// A watch that stops a run whose count leaves `lo..=hi` on channel `c`.
fn within(c: usize, lo: i64, hi: i64) -> impl Fn(&Sample) -> Option<String> {
    move |s: &Sample| {
        let count = i64::from(s.block.elapsed[c]);
        (count < lo || count > hi)
            .then(|| format!("channel {c} reached {count}, outside the table's {lo}..={hi}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tables_go_towards_the_middle_of_the_joint_range() {
        let robot = crate::robot::seed_robot();
        let d3 = &robot.joints[2]; // 0..1000 mm
        assert_eq!(toward_middle(d3, 0), 1);
        assert_eq!(toward_middle(d3, d3.count_of(999.0)), -1);
    }
}
