//! A start's permit at its start (contract version 3): a start whose permit does not hold must
//! be refused with fault 8, nothing moving; the same start with a permit that holds must run.
//!
//! ```text
//! permit: REFUSE_BIT of inputs[c % 4] = not its value   refused, fault 8, seq not latched;
//!                                                       clear fault gives idle
//! permit: the same bit = its value                      c0 -> c0 + 50 done, then back to c0
//! ```
//! Using `inputs[c % 4]` on channel c, a four-channel commission asks a bit of every input word.

use super::bench::{Bench, Channel, Run, unfinished_hint};
use super::refusals::clear_after;
use super::{PROBE_PULSES, check, within};
use crate::commission::inputs::{REFUSE_BIT, is_on, on_off};
use crate::commission::report::CheckReport;
use crate::commission::{Check, Halt, Session};
use crate::contract::{Fault, INPUT_WORDS, Permit, PermitBit, State, bit_name};
use crate::plc::Plc;

/// A start whose permit asks one input bit for the opposite of its value is refused with fault
/// 8; the same start asking the bit's value runs to done; a start back.
pub(super) async fn refuses<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let (c, i) = (ch.c, ch.index());
    let w = i % INPUT_WORDS;
    let name = bit_name(s.target.link.layout.inputs[w], REFUSE_BIT);
    let hz = ch.hz_for(PROBE_PULSES, 8.0 * bench.pace.sample_s());
    let k = refuse_check(c, &name, w);
    let before = match bench.status().await {
        Ok(b) => b,
        Err(e) => return s.record(k.fail(e.to_string(), "the link failed")),
    };
    let c0 = i64::from(before.elapsed[i]);
    let on = is_on(before.inputs[w], REFUSE_BIT);
    let target = c0 + ch.sign * PROBE_PULSES;
    let refused = one_bit(w, REFUSE_BIT, !on);
    let run = bench
        .play_refused(
            ch,
            ch.segment(c0, target, hz),
            (before.elapsed, refused),
            c0,
            hz,
        )
        .await;
    let saw = format!(
        "count {c0}; the permit needs {name} {} (inputs[{w}] = 0x{:04X}: it is {}): {}",
        on_off(!on),
        before.inputs[w],
        on_off(on),
        run.still_words(i, c0)
    );
    if !run.refused_still(Fault::PermitNotMet, before.seq, i, c0) {
        return s.record(k.fail(saw, not_refused_hint(&run)));
    }
    let saw = match clear_after(bench, &k, saw).await {
        Ok(saw) => saw,
        Err(report) => return s.record(report),
    };
    let permit = one_bit(w, REFUSE_BIT, on);
    let report =
        permitted_out_and_back(bench, ch, (c0, target, hz), (permit, &name, on), saw, k).await;
    s.record(report)
}

/// The refusal check, as its report names what it looks at (`name`: bit [`REFUSE_BIT`] of
/// `inputs[w]`).
fn refuse_check(c: u8, name: &str, w: usize) -> Check {
    check(
        "permit refuses fault 8",
        c,
        format!(
            "a valid start of {PROBE_PULSES} pulses whose permit asks {name} (inputs[{w}]) for \
             the opposite of its value: refused with state fault, fault 8, seq not latched, \
             nothing moves; clear fault gives idle; the same start asking {name}'s value runs to \
             done, and a start back"
        ),
    )
}

/// A permit that asks bit `bit` of `inputs[w]` to be `on`.
pub(super) fn one_bit(word: usize, bit: u8, on: bool) -> Permit {
    Permit::of(&[PermitBit { word, bit, on }]).unwrap_or(Permit::NONE)
}

/// What to do about a start whose permit did not hold and that was not refused with fault 8.
fn not_refused_hint(run: &Run) -> String {
    if run.stopped_for.is_some() {
        "the contract says a start whose permit does not hold is refused with fault 8 and \
         nothing moves; this program started it: it does not check the permit \
         (permit_mask/permit_value, command +17..+24) against inputs, as a program still at \
         contract version 2's logic would. Load the listing that comes with this linterpd"
            .to_owned()
    } else if run.link_error.is_none() && run.last().is_some_and(|x| x.state == State::Fault) {
        format!(
            "the contract says fault 8 (permit not met at start); the program latched another \
             fault: {}",
            unfinished_hint(run)
        )
    } else {
        "the contract says a start whose permit does not hold is refused with state fault, \
         fault 8, seq not latched: it was not"
            .to_owned()
    }
}

/// The start whose permit holds, out to `target` and back to `c0`.
async fn permitted_out_and_back<P: Plc>(
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
    (c0, target, hz): (i64, i64, u32),
    (permit, name, on): (Permit, &str, bool),
    saw: String,
    k: Check,
) -> CheckReport {
    let i = ch.index();
    let (lo, hi) = (c0.min(target), c0.max(target));
    let Ok(from) = bench.status().await.map(|b| b.elapsed) else {
        return k.fail(saw, "the link failed");
    };
    let deadline = bench.deadline_s(PROBE_PULSES, hz);
    let out = bench
        .play_permitted(
            ch,
            vec![ch.segment(c0, target, hz)],
            (from, permit),
            deadline,
            &within(i, lo, hi),
        )
        .await;
    let out_end = out.count(i).unwrap_or(c0);
    let saw = format!(
        "{saw}; the same start needing {name} {} (as it is): {}, the count at {out_end}",
        on_off(on),
        out.ending()
    );
    if !(out.ended(State::Done) && out_end == target) {
        return k.fail(saw, held_back_hint(&out, name, on));
    }
    let from = out.last().map_or(from, |x| x.block.elapsed);
    let back = bench
        .play_between(ch, from, (target, c0, hz), deadline)
        .await;
    let back_end = back.count(i).unwrap_or(target);
    let saw = format!("{saw}; back to {back_end}: {}", back.ending());
    if back.ended(State::Done) && back_end == c0 {
        k.pass(saw)
    } else {
        k.fail(saw, unfinished_hint(&back))
    }
}

/// What to do about a start whose permit holds and that did not run to done.
fn held_back_hint(out: &Run, name: &str, on: bool) -> String {
    let fault8 = out
        .last()
        .is_some_and(|x| x.block.fault == Fault::PermitNotMet.word());
    if fault8 {
        format!(
            "the contract says a start whose permit holds runs; this program refused it with \
             fault 8 although {name} is {}: it compares the permit with other words than the \
             status block's inputs, or in another order",
            on_off(on)
        )
    } else {
        unfinished_hint(out)
    }
}
