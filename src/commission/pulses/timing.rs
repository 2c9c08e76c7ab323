//! The timing run: a table of [`TIMING_PULSES`] pulses at the frequency where the models differ
//! most, judged three ways (busy on then off; elapsed exact; time taken vs frequency).

use super::bench::{Bench, Channel, Run, unfinished_hint};
use super::{Check, RANGE, TIMING_POLLS, TIMING_PULSES, check, counts, within};
use crate::commission::judge::{Fit, fit_rate, timing_hz};
use crate::commission::report::{ChannelRate, CheckReport};
use crate::commission::{Halt, Session};
use crate::contract::State;
use crate::plc::Plc;
use crate::table::FrequencyModel;

/// The timing run: busy on then off, elapsed exact, time taken vs frequency.
pub(super) async fn timing<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let (c, i) = (ch.c, ch.index());
    let duration_s = (TIMING_POLLS * bench.pace.sample_s()).clamp(0.25, 5.0);
    let hz = timing_hz(
        TIMING_PULSES as f64 / duration_s,
        ch.low_hz(),
        ch.top_hz(),
        RANGE,
    );
    let busy = check(
        "busy on then off",
        c,
        format!(
            "a table of {TIMING_PULSES} pulses at {hz} Hz: busy bit {c} (DT1006, from the busy \
             relay) reads ON while it plays and OFF once it is done"
        ),
    );
    let from = counts(s, bench, &busy).await?;
    let c0 = i64::from(from[i]);
    let target = c0 + ch.sign * TIMING_PULSES;
    let deadline = bench.deadline_s(TIMING_PULSES, hz);
    let watch = within(i, c0.min(target), c0.max(target));
    let run = bench
        .play(ch, vec![ch.segment(c0, target, hz)], from, deadline, &watch)
        .await;
    let model = s.target.robot.motion.frequency_model;
    let (elapsed, time) = judged_checks(c, (c0, target), hz, model);
    let first = s.record(judge_busy(busy, &run, i));
    let second = s.record(judge_elapsed(elapsed, &run, i, c0, target));
    let third = judge_time(s, time, &run, ch, c0, hz);
    let third = s.record(third);
    first.and(second).and(third)
}

/// The elapsed and time checks of the timing run from `c0` to `target` at `hz`.
fn judged_checks(
    c: u8,
    (c0, target): (i64, i64),
    hz: u32,
    model: FrequencyModel,
) -> (Check, Check) {
    let elapsed = check(
        "elapsed moves by exactly the table's pulses",
        c,
        format!(
            "elapsed[{c}] (from the elapsed-value register) goes {c0} -> {target} and no further"
        ),
    );
    let time = check(
        "time taken vs frequency",
        c,
        format!(
            "the rate of those pulses against the `ideal` and `fpx-divider` models (range 0, \
             {hz} Hz); the config says {}",
            model.name()
        ),
    );
    (elapsed, time)
}

fn judge_busy(c: Check, run: &Run, i: usize) -> CheckReport {
    let on = run.busy_reads(i);
    let saw = format!(
        "busy bit ON in {on} of {} reads; {}; busy {} at the end",
        run.samples.len(),
        run.ending(),
        if run.last().is_some_and(|s| s.block.busy & (1 << i) != 0) {
            "ON"
        } else {
            "OFF"
        }
    );
    if !run.ended(State::Done) {
        return c.fail(saw, unfinished_hint(run));
    }
    if on == 0 {
        return c.fail(
            saw,
            "the busy relay the program reads never rose while pulses went out: the listing's \
             R911C..R911F (channels 0-3) are not this unit's busy flags; try R9120..R9123 (FP-XH \
             numbering), deploy/plc/README.md. Without them fault 2 never protects a running \
             channel",
        );
    }
    if run.last().is_some_and(|s| s.block.busy & (1 << i) != 0) {
        return c.fail(
            saw,
            "the busy bit stayed ON after done: check the busy relay's address",
        );
    }
    c.pass(saw)
}

fn judge_elapsed(c: Check, run: &Run, i: usize, c0: i64, target: i64) -> CheckReport {
    let counts: Vec<i64> = run
        .samples
        .iter()
        .map(|s| i64::from(s.block.elapsed[i]))
        .collect();
    let (lo, hi) = (
        counts.iter().copied().min().unwrap_or(c0),
        counts.iter().copied().max().unwrap_or(c0),
    );
    let end = run.count(i).unwrap_or(c0);
    let saw = format!(
        "elapsed[{}] went from {c0} to {end} ({} pulses; the table has {}), ranging {lo}..={hi}",
        i,
        (end - c0).abs(),
        (target - c0).abs()
    );
    if end == target && lo >= c0.min(target) && hi <= c0.max(target) {
        return c.pass(saw);
    }
    let hint = if end == c0 {
        "the count never moved: the elapsed-value register the program copies (DT90348.. for \
         channels 0-3) is not this unit's; try DT90400.. (FP-XH numbering), \
         deploy/plc/README.md"
    } else {
        "the count did not move by exactly the table's pulses: check the elapsed-value register \
         address (DT90348..) and the table's target mode (absolute)"
    };
    c.fail(saw, hint)
}

fn judge_time(
    s: &mut Session<'_>,
    c: Check,
    run: &Run,
    ch: &Channel<'_>,
    c0: i64,
    hz: u32,
) -> CheckReport {
    if !run.ended(State::Done) {
        return c.skip(format!("the run did not end done ({})", run.ending()));
    }
    let samples: Vec<(f64, i64)> = run
        .samples
        .iter()
        .map(|x| {
            (
                x.t_s,
                ch.sign * (i64::from(x.block.elapsed[ch.index()]) - c0),
            )
        })
        .collect();
    let limit_hz = f64::from(ch.joint.max_freq_hz);
    let Some(rate) = fit_rate(&samples, TIMING_PULSES, hz, RANGE, limit_hz) else {
        return c.skip(format!(
            "too few reads inside the run ({} in all) to fit a rate: the link is too slow for \
             this table",
            run.samples.len()
        ));
    };
    s.findings.rates.push(ChannelRate {
        channel: ch.c,
        rate,
    });
    let configured = s.target.robot.motion.frequency_model;
    rate_report(c, rate_saw(&rate, hz), rate.fit, configured)
}

/// The fitted rate against both models, in words.
fn rate_saw(rate: &crate::commission::judge::RateFit, hz: u32) -> String {
    format!(
        "{} pulses at {hz} Hz ran at {:.2} Hz +- {:.2} ({} reads): {:.4} s; ideal {:.2} Hz \
         ({:.4} s), fpx-divider {:.2} Hz ({:.4} s): {}",
        rate.pulses,
        rate.measured_hz,
        rate.tolerance_hz,
        rate.samples,
        rate.took_s(),
        rate.ideal_hz,
        rate.predicted_s(FrequencyModel::Ideal),
        rate.divider_hz,
        rate.predicted_s(FrequencyModel::FpxDivider),
        rate.fit.describe()
    )
}

/// The time check's report: which model the rate `fit`s against the config's `configured`.
fn rate_report(c: Check, saw: String, fit: Fit, configured: FrequencyModel) -> CheckReport {
    match fit {
        Fit::Neither => c.fail(
            saw,
            "the channel's rate matches neither model: check the control code's range digit \
             and the channel's wiring of pulse output; plans would be timed wrong",
        ),
        fit if fit.admits(configured) && fit == Fit::Undecided => c.pass_noting(
            saw,
            "the models are too close at this link's pace to tell apart; the config's model \
             fits",
        ),
        fit if fit.admits(configured) => c.pass(saw),
        fit => {
            let fits = fit.model().map_or("another model", FrequencyModel::name);
            c.config(
                saw,
                format!(
                    "the config says frequency_model = \"{}\" but this unit follows {fits}: set \
                     frequency_model = \"{fits}\" in [robots.NAME.motion]",
                    configured.name()
                ),
            )
        }
    }
}
