//! Starts the program must refuse or ignore, with nothing moving: `from` one pulse off (fault
//! 5, then clear fault), and a repeated seq (command back to 0).

use super::bench::{Bench, Channel, jittered};
use super::{PROBE_PULSES, QUIET_POLLS, check, counts};
use crate::commission::error::Failure;
use crate::commission::report::CheckReport;
use crate::commission::{Check, Halt, Session};
use crate::contract::{Fault, Permit, State, StatusBlock};
use crate::plc::Plc;

/// What the interlock check looks at, after its start.
const INTERLOCK_CHECKS: &str = "refused with state fault, fault 5, seq not latched, nothing \
                                moves; then clear fault gives idle";

/// What the repeated seq check looks at, after the start's size.
const REPEAT_CHECKS: &str = "carrying the seq of the last accepted start: the program sets \
                             command back to 0 and nothing moves, state and seq stay";

/// What a check says when clear fault does not give idle.
pub(super) const CLEAR_FAULT_HINT: &str =
    "clear fault (command = 3) must give fault 0 and state idle";

/// A start whose `from` is one pulse off on this channel: refused with fault 5, nothing moves;
/// then the fault is cleared.
pub(super) async fn interlock<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let (c, i) = (ch.c, ch.index());
    let what = format!("a start whose from[{c}] is one pulse off the count: {INTERLOCK_CHECKS}");
    let (k, hz) = probe(bench, ch, "`from` interlock refuses fault 5", what);
    let counts_now = counts(s, bench, &k).await?;
    let before = bench.status().await.map(|b| b.seq).unwrap_or_default();
    let c0 = i64::from(counts_now[i]);
    let mut from = counts_now;
    from[i] = (c0 + ch.sign) as i32;
    let off = i64::from(from[i]);
    let target = off + ch.sign * PROBE_PULSES;
    let run = bench
        .play_refused(
            ch,
            ch.segment(off, target, hz),
            (from, Permit::NONE),
            c0,
            hz,
        )
        .await;
    let saw = format!("count {c0}, from[{c}] {off}: {}", run.still_words(i, c0));
    if !run.refused_still(Fault::NotAtStart, before, i, c0) {
        return s.record(k.fail(saw, interlock_hint(run.stopped_for.is_some())));
    }
    match clear_after(bench, &k, saw).await {
        Ok(saw) => s.record(k.pass(saw)),
        Err(report) => s.record(report),
    }
}

/// Why a start one pulse off its `from` was not refused: it `ran`, or it did something else.
fn interlock_hint(ran: bool) -> &'static str {
    if ran {
        "the start ran from counts other than its from: the program must compare every \
         channel's count with from[c] before starting (fault 5)"
    } else {
        "the start was not refused with fault 5"
    }
}

/// A probe of [`PROBE_PULSES`] on `ch`: its check (`name`, `what` it checks) and its speed, Hz.
fn probe<P: Plc>(
    bench: &Bench<'_, P>,
    ch: &Channel<'_>,
    name: &'static str,
    what: String,
) -> (Check, u32) {
    let hz = ch.hz_for(PROBE_PULSES, 8.0 * bench.pace.sample_s());
    (check(name, ch.c, what), hz)
}

/// Writes clear fault and reads until fault 0 and state idle.
pub(super) async fn clear_fault<P: Plc>(bench: &mut Bench<'_, P>) -> Result<(), Failure> {
    bench.contract.clear_fault().await?;
    for k in 0..QUIET_POLLS * 2 {
        tokio::time::sleep(jittered(bench.pace.poll(), k as u32)).await;
        let b = bench.status().await?;
        if b.fault == 0 && b.state == State::Idle.word() {
            return Ok(());
        }
    }
    Err(Failure::NotIdleAfterClear)
}

/// Clears the fault a check's refused start latched: `saw` and that clear fault gave idle, or
/// the check failed.
pub(super) async fn clear_after<P: Plc>(
    bench: &mut Bench<'_, P>,
    k: &Check,
    saw: String,
) -> Result<String, CheckReport> {
    match clear_fault(bench).await {
        Ok(()) => Ok(format!("{saw}; clear fault gave idle")),
        Err(e) => Err(k.clone().fail(format!("{saw}; {e}"), CLEAR_FAULT_HINT)),
    }
}

/// A start with the last accepted seq and a valid table: the program must drop it.
pub(super) async fn repeated_seq<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let i = ch.index();
    let what = format!("a valid start of {PROBE_PULSES} pulses {REPEAT_CHECKS}");
    let (k, hz) = probe(bench, ch, "repeated seq ignored", what);
    let before = match bench.status().await {
        Ok(b) => b,
        Err(e) => return s.record(k.fail(e.to_string(), "the link failed")),
    };
    let c0 = i64::from(before.elapsed[i]);
    let target = c0 + ch.sign * PROBE_PULSES;
    let launched = bench
        .launch(
            ch,
            vec![ch.segment(c0, target, hz)],
            (before.elapsed, Permit::NONE),
            Some(before.seq),
        )
        .await;
    if let Err(e) = launched {
        return s.record(k.fail(e.to_string(), "the link failed"));
    }
    let report = repeat_report(bench, k, &before, i, s.target.link.layout.command_base).await;
    s.record(report)
}

/// The check `k` of a repeated start on channel `i`, from what the reads after it saw; a start
/// it acted on stopped, one left pending withdrawn.
async fn repeat_report<P: Plc>(
    bench: &mut Bench<'_, P>,
    k: Check,
    before: &StatusBlock,
    i: usize,
    command_at: u16,
) -> CheckReport {
    let c0 = i64::from(before.elapsed[i]);
    match after_repeat(bench, i, before, command_at).await {
        Repeat::Link(e) => k.fail(e.to_string(), "the link failed"),
        Repeat::Acted(block) => {
            let _ = bench.contract.stop().await;
            repeat_acted(k, before, &block, i)
        }
        Repeat::Quiet { reads, dropped } => {
            if !dropped {
                let _ = bench.contract.withdraw().await;
            }
            repeat_quiet(k, before.seq, reads, dropped, c0)
        }
    }
}

/// What the reads after a repeated start saw.
enum Repeat {
    /// The link failed.
    Link(Failure),
    /// The start acted (the channel moved, or the seq or the state changed): the read that
    /// showed it.
    Acted(StatusBlock),
    /// Nothing acted over `reads` reads; whether the command word went back to 0.
    Quiet { reads: usize, dropped: bool },
}

/// Reads the command word and the status block until the command is back to 0 (three reads at
/// least), something acts, or [`QUIET_POLLS`] twice.
async fn after_repeat<P: Plc>(
    bench: &mut Bench<'_, P>,
    i: usize,
    before: &StatusBlock,
    command_at: u16,
) -> Repeat {
    let c0 = i64::from(before.elapsed[i]);
    let (mut reads, mut dropped) = (0, false);
    for n in 0..QUIET_POLLS * 2 {
        tokio::time::sleep(jittered(bench.pace.poll(), n as u32)).await;
        let (command, block) = match (
            bench.contract.plc().read_words(command_at, 1).await,
            bench.status().await,
        ) {
            (Ok(w), Ok(b)) => (w[0], b),
            (Err(e), _) => return Repeat::Link(e.into()),
            (_, Err(e)) => return Repeat::Link(e),
        };
        reads += 1;
        let moved = i64::from(block.elapsed[i]) != c0 || block.busy & (1 << i) != 0;
        if moved || block.seq != before.seq || block.state != before.state {
            return Repeat::Acted(block);
        }
        if command == 0 {
            dropped = true;
            if reads >= 3 {
                break;
            }
        }
    }
    Repeat::Quiet { reads, dropped }
}

/// The report of a repeated start that nothing acted on over `reads` reads: it passes when the
/// command word went back to 0 (`dropped`).
fn repeat_quiet(k: Check, seq: u16, reads: usize, dropped: bool, c0: i64) -> CheckReport {
    if !dropped {
        return k.fail(
            format!("seq {seq} repeated: the command word stayed 1 for {reads} reads"),
            "the program must set command back to 0 when it drops a repeated start",
        );
    }
    k.pass(format!(
        "seq {seq} repeated: command back to 0, the count held at {c0}, state and seq unchanged \
         over {reads} reads"
    ))
}

/// The failure of a repeated start that acted.
fn repeat_acted(k: Check, before: &StatusBlock, block: &StatusBlock, i: usize) -> CheckReport {
    let state = State::from_word(block.state).map_or("unknown", State::name);
    let saw = format!(
        "seq {} repeated: the count went to {}, state {state}, seq {}",
        before.seq, block.elapsed[i], block.seq
    );
    k.fail(
        saw,
        "a start carrying the last accepted seq must be dropped (command = 0) in any state: the \
         listing's repeated-seq rule",
    )
}
