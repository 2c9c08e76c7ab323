//! A running move's permit that stops holding (contract version 3): once a start whose permit
//! needs an R input bit as it is runs, the relay is switched over the link; the program must
//! stop every channel within one scan (state stopped, fault 9, busy OFF). Then the relay goes
//! back, the fault is cleared and a start brings the channel back where it was found.
//!
//! ```text
//! permit: DROP_BIT of the first R word = its value     c0 -> c0 + 300; after 60 pulses the
//!                                                      relay is switched: held with fault 9
//! relay back, clear fault, held count -> c0
//! ```
//! The count when the relay write is acknowledged is not read: it is at most the count of the
//! read before, plus what the table's frequency gives from when that read was sent to the
//! acknowledgement. The program must stop within one scan (the measured mean) after that.

use tokio::time::Instant;

use super::bench::{Bench, Channel, Sample, jittered, unfinished_hint};
use super::permit::one_bit;
use super::refusals::clear_after;
use super::{QUIET_POLLS, check, counts};
use crate::commission::error::Failure;
use crate::commission::inputs::{self, DROP_BIT, is_on, on_off, relay, switch};
use crate::commission::{Check, Halt, Session};
use crate::contract::{CHANNELS, Fault, Permit, State, bit_name};
use crate::plc::Plc;
use crate::plc::exchange::{ContractError, fault_meaning};

/// Pulses of the table whose permit is dropped.
const DROP_PULSES: i64 = 300;
/// Pulses moved before the relay is switched.
const DROP_AFTER: i64 = DROP_PULSES / 5;
/// Pulses allowed past the bound for rounding (a pulse under way, the model's rounding).
const DROP_SLACK: i64 = 2;
/// The shortest the table whose permit is dropped lasts, s: a poll delayed on a loaded PC must
/// still find it running.
const DROP_MIN_S: f64 = 0.5;
/// Reads in a row with the channel stopped that end the watch after the switch.
const SETTLED_READS: usize = 3;

/// Why the drop check cannot switch an R input bit.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
enum NoDropRelay {
    /// The inputs step found nothing.
    #[error("the inputs step did not read the status block's inputs")]
    NotRead,
    /// The four input words are X words.
    #[error(
        "all four input words are X words ({words}), which the link cannot switch: this check \
         needs wiring (switch an input a move's permit needs while it runs, \
         deploy/plc/README.md, \"by hand\")"
    )]
    AllX {
        /// The words, `WX0, WX1, WX2, WX3`.
        words: String,
    },
    /// The R word's copy was not seen in the inputs step.
    #[error("{word}'s copy was not seen in inputs[{index}] (inputs: copied every scan)")]
    NotCopied {
        /// The R word.
        word: String,
        /// Its place among the inputs.
        index: usize,
    },
}

/// The R word whose [`DROP_BIT`] the drop check switches, or why it cannot.
fn drop_word(s: &Session<'_>) -> Result<usize, NoDropRelay> {
    let Some(found) = &s.findings.inputs else {
        return Err(NoDropRelay::NotRead);
    };
    match (found.relay_word, found.copied) {
        (None, _) => Err(NoDropRelay::AllX {
            words: found.words.join(", "),
        }),
        (Some(w), Some(true)) => Ok(w),
        (Some(w), _) => Err(NoDropRelay::NotCopied {
            word: found.words[w].clone(),
            index: w,
        }),
    }
}

/// The switch of the relay during the run.
#[derive(Debug, Clone, Copy)]
struct Switched {
    /// The count of the last read before the write.
    count: i64,
    /// From when that read was sent to the write's acknowledgement, s.
    read_to_ack_s: f64,
    /// The furthest the count may go: one scan at the table's frequency past the count at the
    /// acknowledgement (bounded from the read before).
    limit: i64,
}

impl Switched {
    /// The switch acknowledged now, after read `x` (sent at `sent`) showed channel `i` `moved`
    /// pulses into a table at `hz` on a PLC scanning every `scan_s`.
    fn at(x: &Sample, i: usize, moved: i64, sent: Instant, (hz, scan_s): (u32, f64)) -> Self {
        let read_to_ack_s = sent.elapsed().as_secs_f64();
        let allowed = (f64::from(hz) * (read_to_ack_s + scan_s.max(0.001))).ceil() as i64;
        Self {
            count: i64::from(x.block.elapsed[i]),
            read_to_ack_s,
            limit: moved + allowed + DROP_SLACK,
        }
    }
}

/// What the run whose permit was dropped did.
#[derive(Debug, Default)]
struct DropRun {
    seq: u16,
    /// The read that ended the run before the switch, if one did.
    ended_early: Option<Sample>,
    switched: Option<Switched>,
    /// Reads after the switch.
    after: Vec<Sample>,
    /// A stop the check wrote, and why.
    stopped_for: Option<String>,
    error: Option<String>,
}

impl DropRun {
    fn last(&self) -> Option<&Sample> {
        self.after.last().or(self.ended_early.as_ref())
    }

    /// The furthest the count went after the switch, as pulses moved from `c0` (sign-aware).
    fn furthest(&self, i: usize, c0: i64, sign: i64) -> Option<i64> {
        self.after
            .iter()
            .map(|x| sign * (i64::from(x.block.elapsed[i]) - c0))
            .max()
    }

    /// The link failed: a stop is written, and the run ends.
    async fn link_failed<P: Plc>(&mut self, bench: &mut Bench<'_, P>, e: impl ToString) {
        self.error = Some(e.to_string());
        let _ = bench.contract.stop().await;
    }
}

/// The drop run's status reads: irregular polls, timed from the start.
struct Polls {
    began: Instant,
    k: u32,
}

impl Polls {
    /// Waits a poll, reads the status block; when the read was sent, and the sample.
    async fn read<P: Plc>(
        &mut self,
        bench: &mut Bench<'_, P>,
    ) -> Result<(Instant, Sample), ContractError> {
        tokio::time::sleep(jittered(bench.pace.poll(), self.k)).await;
        self.k += 1;
        let sent = Instant::now();
        let st = bench.contract.status().await?;
        let sample = Sample {
            t_s: self.began.elapsed().as_secs_f64(),
            block: st.block,
            state: st.state,
        };
        Ok((sent, sample))
    }
}

/// Plays `DROP_PULSES` with `permit`; once the channel has moved [`DROP_AFTER`], writes the
/// relay `(w, on)`; then reads until the channel has stood still [`SETTLED_READS`] times (a
/// stop is written if it still runs after [`QUIET_POLLS`] reads).
async fn drop_run<P: Plc>(
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
    (from, permit): ([i32; CHANNELS], Permit),
    relay_at: (usize, bool),
    hz: u32,
) -> DropRun {
    let c0 = i64::from(from[ch.index()]);
    let target = c0 + ch.sign * DROP_PULSES;
    let mut run = DropRun::default();
    match bench
        .launch(ch, vec![ch.segment(c0, target, hz)], (from, permit), None)
        .await
    {
        Ok(seq) => run.seq = seq,
        Err(e) => {
            run.error = Some(e.to_string());
            return run;
        }
    }
    let mut polls = Polls {
        began: Instant::now(),
        k: 0,
    };
    if until_switched(bench, ch, &mut run, &mut polls, (c0, relay_at, hz)).await {
        until_settled(bench, ch.index(), &mut run, &mut polls).await;
    }
    run
}

/// Reads until the channel has moved [`DROP_AFTER`] pulses of its run, then switches the relay
/// `(w, on)`: whether it did (else the run ended, or was stopped, before).
async fn until_switched<P: Plc>(
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
    run: &mut DropRun,
    polls: &mut Polls,
    (c0, (w, on), hz): (i64, (usize, bool), u32),
) -> bool {
    let i = ch.index();
    let deadline_s = bench.deadline_s(DROP_PULSES, hz);
    let relay_no = relay(bench.contract.settings().layout.inputs[w], DROP_BIT);
    loop {
        let (sent, x) = match polls.read(bench).await {
            Ok(read) => read,
            Err(e) => {
                run.link_failed(bench, format!("{e:#}")).await;
                return false;
            }
        };
        let moved = ch.sign * (i64::from(x.block.elapsed[i]) - c0);
        let ours = x.block.seq == run.seq;
        if x.state == State::Fault || (ours && matches!(x.state, State::Done | State::Stopped)) {
            run.ended_early = Some(x);
            return false;
        }
        if x.t_s > deadline_s || !(0..=DROP_PULSES).contains(&moved) {
            run.ended_early = Some(x);
            run.stopped_for = Some(format!("the channel reached {}", x.block.elapsed[i]));
            let _ = bench.contract.stop().await;
            return false;
        }
        if x.state == State::Running && ours && moved >= DROP_AFTER {
            let Err(e) = bench.contract.plc().write_relay(relay_no, on).await else {
                run.switched = Some(Switched::at(&x, i, moved, sent, (hz, bench.pace.scan_s)));
                return true;
            };
            run.link_failed(bench, format!("{e:#}")).await;
            return false;
        }
    }
}

/// Reads after the switch until channel `i` has stood still [`SETTLED_READS`] times in a row;
/// writes a stop should it still run after [`QUIET_POLLS`] reads, and gives up after three
/// times that.
async fn until_settled<P: Plc>(
    bench: &mut Bench<'_, P>,
    i: usize,
    run: &mut DropRun,
    polls: &mut Polls,
) {
    let mut settled = 0;
    loop {
        let x = match polls.read(bench).await {
            Ok((_, x)) => x,
            Err(e) => return run.link_failed(bench, format!("{e:#}")).await,
        };
        run.after.push(x);
        let still = x.state != State::Running && x.block.busy & (1 << i) == 0;
        settled = if still { settled + 1 } else { 0 };
        if settled >= SETTLED_READS {
            return;
        }
        if run.stopped_for.is_none() && run.after.len() >= QUIET_POLLS {
            run.stopped_for = Some(format!(
                "still running {} reads after the switch",
                run.after.len()
            ));
            let _ = bench.contract.stop().await;
        }
        if run.after.len() >= QUIET_POLLS * 3 {
            let _ = bench.contract.stop().await;
            return;
        }
    }
}

/// The drop check's channel: its index, the count it was found at and the direction it runs.
#[derive(Debug, Clone, Copy)]
struct Origin {
    i: usize,
    c0: i64,
    sign: i64,
}

/// Once a permitted move runs, the relay its permit needs is switched: the move must stop
/// within one scan with fault 9. Then the relay back, clear fault, a start back to where the
/// channel was found.
pub(super) async fn drop_holds<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
) -> Result<(), Halt> {
    let words = s.target.link.layout.inputs;
    let hz = ch.hz_for(DROP_PULSES, (20.0 * bench.pace.sample_s()).max(DROP_MIN_S));
    let plan = drop_word(s);
    let name = plan.as_ref().map_or_else(
        |_| "an R input bit".to_owned(),
        |&w| bit_name(words[w], DROP_BIT),
    );
    let k = drop_check(ch.c, &name, hz);
    let w = match plan {
        Ok(w) => w,
        Err(why) => return s.record(k.skip(why.to_string())),
    };
    let before = match bench.status().await {
        Ok(b) => b,
        Err(e) => return s.record(k.fail(e.to_string(), "the link failed")),
    };
    let i = ch.index();
    let at = Origin {
        i,
        c0: i64::from(before.elapsed[i]),
        sign: ch.sign,
    };
    let on = is_on(before.inputs[w], DROP_BIT);
    let permit = one_bit(w, DROP_BIT, on);
    let run = drop_run(bench, ch, (before.elapsed, permit), (w, !on), hz).await;
    // The relay goes back whatever happened.
    let restored = switch(bench.contract, bench.pace, (w, DROP_BIT), on, &before).await;
    let saw = describe_drop(&run, at, (&name, on), hz, bench.pace.scan_s);
    let saw = match restored_saw(restored, saw, &name, on) {
        Ok(saw) => saw,
        Err((saw, hint)) => return s.record(k.fail(saw, hint)),
    };
    if let Some(hint) = drop_verdict(&run, at, &name, hz) {
        return s.record(k.fail(saw, hint));
    }
    back_to_start(s, bench, ch, (k, saw), (at.c0, hz)).await
}

/// What was seen once the relay `name` was switched back to `on`, or (the check fails) what
/// was seen and the hint.
fn restored_saw(
    restored: Result<inputs::Switched, Failure>,
    saw: String,
    name: &str,
    on: bool,
) -> Result<String, (String, String)> {
    match restored {
        Ok(r) if r.shown_after_s.is_some() => Ok(format!("{saw}; {name} back {}", on_off(on))),
        Ok(_) => Err((
            format!(
                "{saw}; {name} switched back {} but its copy did not follow",
                on_off(on)
            ),
            format!("{name} may be left {}: switch it back", on_off(!on)),
        )),
        Err(e) => Err((
            format!("{saw}; {e}"),
            format!("the link failed: {name} may be left {}", on_off(!on)),
        )),
    }
}

/// The drop check, as its report names what it looks at.
fn drop_check(c: u8, name: &str, hz: u32) -> Check {
    check(
        "permit drop holds within one scan",
        c,
        format!(
            "a start of {DROP_PULSES} pulses at {hz} Hz whose permit needs {name} as it is; \
             after {DROP_AFTER} pulses {name} is switched over the link: state stopped, fault 9, \
             busy OFF, the count held within one scan's pulses at {hz} Hz of where it stood when \
             the write was acknowledged; then {name} back, clear fault gives idle, and a start \
             back"
        ),
    )
}

/// After the held run: clear fault, and a start back to `c0`, which must end done there.
async fn back_to_start<P: Plc>(
    s: &mut Session<'_>,
    bench: &mut Bench<'_, P>,
    ch: &Channel<'_>,
    (k, saw): (Check, String),
    (c0, hz): (i64, u32),
) -> Result<(), Halt> {
    let saw = match clear_after(bench, &k, saw).await {
        Ok(saw) => saw,
        Err(report) => return s.record(report),
    };
    let i = ch.index();
    let from = counts(s, bench, &k).await?;
    let at = i64::from(from[i]);
    let deadline = bench.deadline_s((at - c0).abs(), hz);
    let back = bench.play_between(ch, from, (at, c0, hz), deadline).await;
    let end = back.count(i).unwrap_or(at);
    let saw = format!("{saw}; back {at} -> {end}: {}", back.ending());
    if back.ended(State::Done) && end == c0 {
        s.record(k.pass(saw))
    } else {
        s.record(k.fail(saw, unfinished_hint(&back)))
    }
}

/// A read's state and fault, with the fault's meaning when it latched one.
fn state_words(x: &Sample) -> String {
    match x.state {
        State::Fault | State::Stopped if x.block.fault != 0 => format!(
            "state {}, fault {} ({})",
            x.state.name(),
            x.block.fault,
            fault_meaning(x.block.fault)
        ),
        other => format!("state {}, fault {}", other.name(), x.block.fault),
    }
}

/// What the run did, in words.
fn describe_drop(
    run: &DropRun,
    Origin { i, c0, sign }: Origin,
    (name, on): (&str, bool),
    hz: u32,
    scan_s: f64,
) -> String {
    if let Some(e) = &run.error {
        return format!("count {c0}; the link failed: {e}");
    }
    let Some(sw) = run.switched else {
        return describe_early(run, (i, c0), (name, on));
    };
    let limit = c0 + sign * sw.limit;
    let last = run.last().map_or("no read after it".to_owned(), |x| {
        let busy = if x.block.busy & (1 << i) == 0 {
            "OFF"
        } else {
            "ON"
        };
        format!(
            "{}, busy {busy}, the count at {}",
            state_words(x),
            x.block.elapsed[i]
        )
    });
    let furthest = run
        .furthest(i, c0, sign)
        .map_or(String::new(), |m| format!(", furthest {}", c0 + sign * m));
    let stop = run.stopped_for.as_ref().map_or(String::new(), |why| {
        format!("; the check wrote a stop: {why}")
    });
    format!(
        "count {c0}; {name} switched {} at count {} (read {:.1} ms before the write was \
         acknowledged): over {} reads then {last}{furthest}; one scan ({:.1} ms) at {hz} Hz \
         allows it as far as {limit}{stop}",
        on_off(!on),
        sw.count,
        sw.read_to_ack_s * 1e3,
        run.after.len(),
        scan_s * 1e3
    )
}

/// A run that ended before the relay was switched, in words.
fn describe_early(run: &DropRun, (i, c0): (usize, i64), (name, on): (&str, bool)) -> String {
    let how = run.last().map_or("no status read".to_owned(), |x| {
        format!("{} at count {}", state_words(x), x.block.elapsed[i])
    });
    let stop = run
        .stopped_for
        .as_ref()
        .map_or(String::new(), |why| format!(" (stopped: {why})"));
    format!(
        "count {c0}; the start whose permit needs {name} {} (as it is) ended before it had \
         moved {DROP_AFTER} pulses: {how}{stop}",
        on_off(on)
    )
}

/// `None` when the run held as the contract says; else the hint.
fn drop_verdict(
    run: &DropRun,
    Origin { i, c0, sign }: Origin,
    name: &str,
    hz: u32,
) -> Option<String> {
    if run.error.is_some() {
        return Some("the link failed during the run".to_owned());
    }
    let Some(sw) = run.switched else {
        return Some(not_switched_hint(run, name));
    };
    let last = run.last()?;
    let held = last.state == State::Stopped
        && last.block.fault == Fault::PermitDropped.word()
        && last.block.busy & (1 << i) == 0
        && run.stopped_for.is_none();
    if !held {
        return Some(
            "the contract says a move whose latched permit stops holding is stopped within one \
             scan: state stopped, fault 9, busy OFF (and a waiting start dropped); this program \
             did not hold it: it does not check the latched permit every scan of the move, as a \
             program still at contract version 2's logic would. Load the listing that comes with \
             this linterpd"
                .to_owned(),
        );
    }
    let furthest = run.furthest(i, c0, sign).unwrap_or(0);
    if furthest > sw.limit {
        return Some(format!(
            "the channel went {} pulses past where one scan at {hz} Hz allows: the contract \
             says the permit is checked every scan on that scan's inputs, so the move stops in \
             the scan after the input changed",
            furthest - sw.limit
        ));
    }
    moved_after_still(run, i)
}

/// The hint for a run that ended before its relay was switched.
fn not_switched_hint(run: &DropRun, name: &str) -> String {
    let fault8 = run
        .last()
        .is_some_and(|x| x.block.fault == Fault::PermitNotMet.word());
    if fault8 {
        format!(
            "the contract says a start whose permit holds runs; this program refused it with \
             fault 8 although {name} was as the permit needs"
        )
    } else {
        "the start did not run long enough to switch its permit's input: see what the status \
         block showed"
            .to_owned()
    }
}

/// The hint when channel `i`'s count moved on after a read showed it stopped.
fn moved_after_still(run: &DropRun, i: usize) -> Option<String> {
    let first_still = run
        .after
        .iter()
        .position(|x| x.state != State::Running && x.block.busy & (1 << i) == 0)?;
    let counts: Vec<i32> = run.after[first_still..]
        .iter()
        .map(|x| x.block.elapsed[i])
        .collect();
    (counts.windows(2).any(|p| p[0] != p[1])).then(|| {
        format!(
            "the count kept moving after the state read stopped ({counts:?}): a stop must end \
             the output at once (H n108 to DT90052)"
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commission::report::{CheckReport, Findings};
    use crate::commission::{LinkTiming, Target, Verdict, inputs};
    use crate::mock::{
        MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, MockVariant, SharedMock,
    };
    use crate::plc::exchange::{Contract, ContractSettings};
    use crate::plc::{
        LinkSettings, MewtocolClient, MewtocolOptions, Parity, Protocol, SerialSettings, Transport,
    };

    /// The inputs step, then the drop check alone on channel 0, over MEWTOCOL at 115200 baud
    /// against `variant` on paused time; every report and the mock.
    async fn drop_check_against(variant: MockVariant) -> (Vec<CheckReport>, SharedMock) {
        let mut mock = MockPlc::new(MockConfig {
            variant,
            ..MockConfig::default()
        })
        .unwrap();
        mock.set_count(0, 1_000);
        let shared = SharedMock::new(mock);
        let driver = tokio::spawn(shared.clone().run_scans());
        let (ours, theirs) = tokio::io::duplex(8_192);
        let options = MewtocolServerOptions {
            baud: Some(115_200),
            ..MewtocolServerOptions::default()
        };
        let server = MewtocolServer::new(shared.clone(), options);
        tokio::spawn(async move { server.serve(theirs).await });
        let link = LinkSettings::new(
            Protocol::Mewtocol,
            Transport::Serial(SerialSettings {
                path: "/dev/ttyUSB0".into(),
                baud: 115_200,
                data_bits: 8,
                parity: Parity::Odd,
                stop_bits: 1,
            }),
        );
        let client = MewtocolClient::new(ours, MewtocolOptions::from_settings(&link).unwrap());
        let mut contract = Contract::new(client, ContractSettings::default());
        let target = Target::new(crate::robot::seed_robot(), link);
        let mut observe = |_: &CheckReport| {};
        let mut s = Session {
            target: &target,
            checks: Vec::new(),
            findings: Findings::default(),
            stopped: None,
            observe: &mut observe,
        };
        let pace = LinkTiming {
            status_s: 0.012,
            scan_s: 0.002,
        };
        inputs::step(&mut s, &mut contract, pace).await.unwrap();
        let seq = contract.status().await.unwrap().block.seq;
        let mut bench = Bench {
            contract: &mut contract,
            pace,
            seq,
            bank: 1,
        };
        let robot = &target.robot;
        let ch = Channel {
            c: 0,
            joint: &robot.joints[0],
            sign: super::super::toward_middle(&robot.joints[0], 1_000),
            limits: robot.channel_limits(0),
        };
        let _ = drop_holds(&mut s, &mut bench, &ch).await;
        let checks = s.checks.clone();
        driver.abort();
        (checks, shared)
    }

    #[tokio::test(start_paused = true)]
    async fn the_listing_holds_a_dropped_permit_and_the_channel_comes_back() {
        let (checks, shared) = drop_check_against(MockVariant::Listing).await;
        let c = &checks[1];
        assert_eq!(c.verdict, Verdict::Pass, "{c:?}");
        assert!(c.saw.contains("fault 9 (permit dropped"), "{}", c.saw);
        shared.with(|m| {
            assert_eq!(m.count(0), 1_000);
            assert!(!m.read_relay(10 * 16 + u32::from(DROP_BIT)).unwrap());
        });
    }

    #[tokio::test(start_paused = true)]
    async fn a_program_that_never_holds_fails_the_drop_check_with_nothing_moving() {
        let (checks, shared) = drop_check_against(MockVariant::IgnoresPermit).await;
        eprintln!("{:#?}", checks[1]);
        assert_eq!(checks[0].verdict, Verdict::Pass, "{:?}", checks[0]);
        let c = &checks[1];
        assert_eq!(c.verdict, Verdict::Fail, "{c:?}");
        assert!(c.stopped);
        let hint = c.hint.as_deref().unwrap();
        assert!(
            hint.contains("stopped within one scan: state stopped, fault 9")
                && hint.contains("did not hold it"),
            "{hint}"
        );
        assert!(c.saw.contains("R10E switched on"), "{}", c.saw);
        assert!(c.saw.contains("R10E back off"), "{}", c.saw);
        shared.with(|m| {
            assert!(!m.busy(0) && m.state() != State::Running);
            assert!(!m.read_relay(10 * 16 + u32::from(DROP_BIT)).unwrap());
        });
    }
}
