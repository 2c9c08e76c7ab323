//! Two-segment chaining, and a stop mid-table followed by a new start: both bring the channel
//! back to where it began.

use super::bench::{Bench, Channel, Run, Sample, unfinished_hint};
use super::{
    CHAIN_PULSES, Check, QUIET_POLLS, STOP_AFTER, STOP_PULSES, TIMING_PULSES, check, counts, within,
};
use crate::commission::report::CheckReport;
use crate::commission::{Halt, Session};
use crate::contract::{CHANNELS, Fault, State, StatusBlock};
use crate::plc::Plc;

/// Two segments: further out, then back to the start count.
pub(super) async fn chain<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let (c, i) = (ch.c, ch.index());
    let hz = ch.hz_for(CHAIN_PULSES, 8.0 * bench.pace.sample_s());
    let k = check(
        "two-segment table chains",
        c,
        format!(
            "a table of two segments at {hz} Hz, {CHAIN_PULSES} pulses further, then back to \
             where the timing run began: segment[{c}] goes 1 -> 2 and the count ends there"
        ),
    );
    let from = counts(s, bench, &k).await?;
    let c1 = i64::from(from[i]);
    let far = c1 + ch.sign * CHAIN_PULSES;
    let home = c1 - ch.sign * TIMING_PULSES;
    let segments = vec![ch.segment(c1, far, hz), ch.segment(far, home, hz)];
    let pulses = CHAIN_PULSES * 2 + TIMING_PULSES;
    let deadline = bench.deadline_s(pulses, hz);
    let watch = within(i, home.min(far), home.max(far));
    let run = bench.play(ch, segments, from, deadline, &watch).await;
    let seen: Vec<u16> = {
        let mut v: Vec<u16> = run.samples.iter().map(|x| x.block.segment[i]).collect();
        v.dedup();
        v
    };
    let end = run.count(i).unwrap_or(c1);
    let saw = format!(
        "segment[{c}] read {seen:?}; the count went {c1} -> {end} (out to {far}, back to \
         {home}); {}",
        run.ending()
    );
    s.record(chain_report(k, &run, saw, (end, far, home), &seen))
}

/// The chain check's report: the run ended at `end`, out to `far` and back to `home`, its
/// segment index read as `seen`.
fn chain_report(
    k: Check,
    run: &Run,
    saw: String,
    (end, far, home): (i64, i64, i64),
    seen: &[u16],
) -> CheckReport {
    if run.ended(State::Done) && end == home && seen.contains(&2) {
        k.pass(saw)
    } else if end == far {
        k.fail(
            saw,
            "the second segment never ran: the program judged the first ended too early (a busy \
             flag that rises late) or F174 refused the second on a channel still busy; the \
             listing chains only after the flag was seen ON and is OFF, or the count shows the \
             segment's last target",
        )
    } else if run.ended(State::Done) {
        k.fail(
            saw,
            "the chain ended done away from its last target: check the table walk (SUB 1)",
        )
    } else {
        k.fail(saw, unfinished_hint(run))
    }
}

/// A table stopped mid-way, its count held; then a new start back to the start count.
pub(super) async fn stop_then_start<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let hz = ch.hz_for(STOP_PULSES, 20.0 * bench.pace.sample_s());
    let k = check(
        "stop mid-table then a following start works",
        ch.c,
        format!(
            "a table of {STOP_PULSES} pulses at {hz} Hz stopped (command = 2) after \
             {STOP_AFTER}: state stopped, busy OFF, the count held; then a new start back to \
             the start count plays to done"
        ),
    );
    let from = counts(s, bench, &k).await?;
    let report = match stop_mid_table(bench, ch, from, hz).await {
        Ok(held) => following_start(bench, ch, &held, hz, k).await,
        Err((saw, hint)) => k.fail(saw, hint),
    };
    s.record(report)
}

/// Where a stopped table left the channel.
struct Held {
    c0: i64,
    at: i64,
    from: [i32; CHANNELS],
    saw: String,
}

/// Plays a table and stops it after [`STOP_AFTER`] pulses; the count must then hold with busy
/// OFF. `Err((saw, hint))` otherwise.
async fn stop_mid_table<P: Plc>(
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
    from: [i32; CHANNELS],
    hz: u32,
) -> Result<Held, (String, String)> {
    let i = ch.index();
    let c0 = i64::from(from[i]);
    let target = c0 + ch.sign * STOP_PULSES;
    let (lo, hi, sign) = (c0.min(target), c0.max(target), ch.sign);
    let watch = move |x: &Sample| {
        let count = i64::from(x.block.elapsed[i]);
        if count < lo || count > hi {
            Some(format!("channel {i} reached {count}, outside {lo}..={hi}"))
        } else {
            (sign * (count - c0) >= STOP_AFTER).then(|| "the stop under test".to_owned())
        }
    };
    let deadline = bench.deadline_s(STOP_PULSES, hz);
    let run = bench
        .play(ch, vec![ch.segment(c0, target, hz)], from, deadline, &watch)
        .await;
    let at = run.count(i).unwrap_or(c0);
    let saw = format!("stopped at {at} ({})", run.ending());
    let planned = matches!(&run.stopped_for, Some((_, why)) if why == "the stop under test");
    if !planned || !run.ended(State::Stopped) {
        let hint = if run.ended(State::Done) {
            "the table ran to its end although a stop was written mid-way: the program's stop \
             (H n108 to DT90052) does not stop this channel"
                .to_owned()
        } else {
            unfinished_hint(&run)
        };
        return Err((saw, hint));
    }
    let held = held_after_stop(bench, i, at, &saw).await?;
    let from = held.last().map_or(from, |b| b.elapsed);
    Ok(Held { c0, at, from, saw })
}

/// Reads [`QUIET_POLLS`] times after a stop at `at`: the reads, when channel `i`'s count held
/// with busy OFF throughout; else (a stop written again) what was seen and the hint.
async fn held_after_stop<P: Plc>(
    bench: &mut Bench<'_, P>,
    i: usize,
    at: i64,
    saw: &str,
) -> Result<Vec<StatusBlock>, (String, String)> {
    let held = bench
        .watch_quietly()
        .await
        .map_err(|e| (format!("{saw}; {e}"), "the link failed".to_owned()))?;
    let moved = held.iter().any(|b| i64::from(b.elapsed[i]) != at);
    let busy = held.iter().any(|b| b.busy & (1 << i) != 0);
    if moved || busy {
        let _ = bench.contract.stop().await;
        let saw = format!(
            "{saw}; then over {QUIET_POLLS} reads the count {} and busy {}",
            if moved { "kept moving" } else { "held" },
            if busy { "stayed ON" } else { "read OFF" }
        );
        let hint = "a stop must end the output at once: the program writes H n108 to DT90052 \
                    for every channel (deploy/plc/README.md, DT90052)";
        return Err((saw, hint.to_owned()));
    }
    Ok(held)
}

/// A new start from where the stop left the channel back to its start count: it must play to
/// done there.
async fn following_start<P: Plc>(
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
    held: &Held,
    hz: u32,
    k: Check,
) -> CheckReport {
    let (i, away) = (ch.index(), ch.sign);
    let Held { c0, at, from, .. } = *held;
    let watch = move |x: &Sample| {
        let count = i64::from(x.block.elapsed[i]);
        if away * (count - at) > 0 {
            Some(format!(
                "channel {i} moved away from the new table's target, to {count}"
            ))
        } else {
            (away * (count - c0) < 0).then(|| format!("channel {i} ran past {c0}, to {count}"))
        }
    };
    let deadline = bench.deadline_s((at - c0).abs(), hz);
    let back = bench
        .play(ch, vec![ch.segment(at, c0, hz)], from, deadline, &watch)
        .await;
    let end = back.count(i).unwrap_or(at);
    let saw = format!(
        "{}; held {QUIET_POLLS} reads with busy OFF; the next start ({at} -> {c0}) ended at \
         {end}: {}",
        held.saw,
        back.ending()
    );
    following_report(k, &back, saw, (end, c0), i)
}

/// The following start's report: it ended at `end`, and should have played to done at `c0`.
fn following_report(
    k: Check,
    back: &Run,
    saw: String,
    (end, c0): (i64, i64),
    i: usize,
) -> CheckReport {
    let refused_busy = back
        .last()
        .is_some_and(|x| x.state == State::Fault && x.block.fault == Fault::ChannelBusy.word());
    if back.ended(State::Done) && end == c0 && back.busy_reads(i) > 0 {
        k.pass(saw)
    } else if back.ended(State::Done) && end == c0 {
        k.pass_noting(
            saw,
            "the busy bit was never seen ON during the second start",
        )
    } else if matches!(&back.stopped_for, Some((_, why)) if why.contains("moved away")) {
        k.fail(
            saw,
            "the stop only paused F174: the next F174 (after the listing's H n100) resumed the \
             stopped table instead of playing the new one. The listing assumes H n108 aborts: \
             see deploy/plc/README.md, DT90052 H n108 (abort or pause)",
        )
    } else if refused_busy {
        k.fail(
            saw,
            "the next start was refused with fault 2: the busy flag stays ON after a stop, so \
             the stop only paused F174 (deploy/plc/README.md, DT90052 H n108)",
        )
    } else {
        k.fail(saw, unfinished_hint(back))
    }
}
