//! Starts the program must refuse or ignore, with nothing moving: `from` one pulse off (fault
//! 5, then clear fault), and a repeated seq (command back to 0).

use super::bench::{Bench, Channel, Sample, jittered};
use super::{PROBE_PULSES, QUIET_POLLS, check, counts};
use crate::commission::{Halt, Session};
use crate::contract::{Fault, Permit, State};
use crate::plc::Plc;

/// A start whose `from` is one pulse off on this channel: refused with fault 5, nothing moves;
/// then the fault is cleared.
pub(super) async fn interlock<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let (c, i) = (ch.c, ch.index());
    let hz = ch.hz_for(PROBE_PULSES, 8.0 * bench.pace.sample_s());
    let k = check(
        "`from` interlock refuses fault 5",
        c,
        format!(
            "a start whose from[{c}] is one pulse off the count: refused with state fault, fault \
             5, seq not latched, nothing moves; then clear fault gives idle"
        ),
    );
    let counts_now = counts(s, bench, &k).await?;
    let before = bench.status().await.map(|b| b.seq).unwrap_or_default();
    let c0 = i64::from(counts_now[i]);
    let mut from = counts_now;
    from[i] = (c0 + ch.sign) as i32;
    let off = i64::from(from[i]);
    let target = off + ch.sign * PROBE_PULSES;
    let watch = move |x: &Sample| {
        (i64::from(x.block.elapsed[i]) != c0 || x.state == State::Running)
            .then(|| "the start ran".to_owned())
    };
    let deadline = bench.deadline_s(0, hz) + bench.pace.sample_s() * QUIET_POLLS as f64;
    let run = bench
        .play(
            ch,
            vec![ch.segment(off, target, hz)],
            from,
            deadline,
            &watch,
        )
        .await;
    let end = run.count(i).unwrap_or(c0);
    let saw = format!(
        "count {c0}, from[{c}] {off}: {}; the count ended at {end}, busy ON in {} reads",
        run.ending(),
        run.busy_reads(i)
    );
    let refused = run.last().is_some_and(|x| {
        x.state == State::Fault
            && x.block.fault == Fault::NotAtStart.word()
            && x.block.seq == before
    });
    if !refused || end != c0 || run.busy_reads(i) > 0 {
        let hint = if run.stopped_for.is_some() {
            "the start ran from counts other than its from: the program must compare every \
             channel's count with from[c] before starting (fault 5)"
        } else {
            "the start was not refused with fault 5"
        };
        return s.record(k.fail(saw, hint));
    }
    let cleared = clear_fault(bench).await;
    match cleared {
        Ok(()) => s.record(k.pass(format!("{saw}; clear fault gave idle"))),
        Err(e) => s.record(k.fail(
            format!("{saw}; {e}"),
            "clear fault (command = 3) must give fault 0 and state idle",
        )),
    }
}

/// Writes clear fault and reads until fault 0 and state idle.
pub(super) async fn clear_fault<P: Plc>(bench: &mut Bench<'_, P>) -> Result<(), String> {
    bench
        .contract
        .clear_fault()
        .await
        .map_err(|e| format!("{e:#}"))?;
    for k in 0..QUIET_POLLS * 2 {
        tokio::time::sleep(jittered(bench.pace.poll(), k as u32)).await;
        let b = bench.status().await?;
        if b.fault == 0 && b.state == State::Idle.word() {
            return Ok(());
        }
    }
    Err("after clear fault the state is not idle".to_owned())
}

/// A start with the last accepted seq and a valid table: the program must drop it.
pub(super) async fn repeated_seq<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let (c, i) = (ch.c, ch.index());
    let hz = ch.hz_for(PROBE_PULSES, 8.0 * bench.pace.sample_s());
    let k = check(
        "repeated seq ignored",
        c,
        format!(
            "a valid start of {PROBE_PULSES} pulses carrying the seq of the last accepted \
             start: the program sets command back to 0 and nothing moves, state and seq stay"
        ),
    );
    let before = match bench.status().await {
        Ok(b) => b,
        Err(e) => return s.record(k.fail(e, "the link failed")),
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
        return s.record(k.fail(e, "the link failed"));
    }
    let command_at = s.target.link.layout.command_base;
    let mut reads = Vec::new();
    let mut acted = false;
    for n in 0..QUIET_POLLS * 2 {
        tokio::time::sleep(jittered(bench.pace.poll(), n as u32)).await;
        let (command, block) = match (
            bench.contract.plc().read_words(command_at, 1).await,
            bench.status().await,
        ) {
            (Ok(w), Ok(b)) => (w[0], b),
            (Err(e), _) => return s.record(k.fail(format!("{e:#}"), "the link failed")),
            (_, Err(e)) => return s.record(k.fail(e, "the link failed")),
        };
        reads.push(block);
        let moved = i64::from(block.elapsed[i]) != c0 || block.busy & (1 << i) != 0;
        if moved || block.seq != before.seq || block.state != before.state {
            let _ = bench.contract.stop().await;
            let state = State::from_word(block.state).map_or("unknown", State::name);
            let saw = format!(
                "seq {} repeated: the count went to {}, state {state}, seq {}",
                before.seq, block.elapsed[i], block.seq
            );
            return s.record(k.fail(
                saw,
                "a start carrying the last accepted seq must be dropped (command = 0) in any \
                 state: the listing's repeated-seq rule",
            ));
        }
        if command == 0 {
            acted = true;
            if reads.len() >= 3 {
                break;
            }
        }
    }
    if !acted {
        let _ = bench.contract.withdraw().await;
        return s.record(k.fail(
            format!(
                "seq {} repeated: the command word stayed 1 for {} reads",
                before.seq,
                reads.len()
            ),
            "the program must set command back to 0 when it drops a repeated start",
        ));
    }
    s.record(k.pass(format!(
        "seq {} repeated: command back to 0, the count held at {c0}, state and seq unchanged \
         over {} reads",
        before.seq,
        reads.len()
    )))
}
