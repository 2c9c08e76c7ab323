//! IO (but for `judge`, `report` and `lines`). `linterpd commission`: a guided check of a real
//! unit, with the drives' power off, that measures what `docs/PLC.md` tags \[unverified\] and
//! `deploy/plc/README.md` lists as probable or unknown, and says which config lines fit the unit.
//!
//! Four steps, each a list of checks named as `deploy/plc/README.md`'s "measured by" column
//! names them:
//! ```text
//! link      headers %, <  |  largest frame/read/write  |  multi-frame read  |  round trip  |
//!           scan time from heartbeat rate  |  RUN/PROG read                    (link/)
//! contract  magic  |  version  |  heartbeat  |  host echo  |  ready bits       (contract.rs)
//! inputs    copied every scan                                                 (inputs.rs)
//! pulses    per channel, one at a time, tiny tables at a low frequency:      (pulses/)
//!           busy on then off  |  elapsed moves by exactly the table's pulses  |
//!           time taken vs frequency  |  two-segment table chains  |
//!           stop mid-table then a following start works  |
//!           `from` interlock refuses fault 5  |  repeated seq ignored  |
//!           permit refuses fault 8  |  permit drop holds within one scan
//! ```
//! Every check reports what it checks, what it saw, pass or fail, and a hint. A failure that
//! only asks for a config change (a header, a request size, a timeout, the frequency model) lets
//! the procedure go on with what was measured; any other failure stops it: every channel is
//! stopped (`command = 2`, once the contract's magic and version were read, never before) and
//! the remaining checks are reported as skipped. The procedure also writes a stop at its end.
//!
//! Each channel's tables return it to the count it was found at (out and back), so a passing run
//! leaves every count as it found it; a run that stops early says where it left them.
//!
//! ```text
//! judge.rs     PURE  rate fit and frequency model, test frequency, scan rate, spreads, bisection
//! report.rs    PURE  Step, Verdict, CheckReport, Findings, Report (the --json report)
//! lines.rs     PURE  the config lines to paste, from the findings
//! link/        the link step over the raw stream (MEWTOCOL headers, request sizes, round trip,
//!              scan time, RUN/PROG); hands back the client it settled on
//! error.rs     Failure: why an exchange failed (what a failed check quotes)
//! contract.rs  the contract step over any Plc
//! inputs.rs    the inputs step over any Plc: the status block's inputs, a relay of an R input
//!              word switched and seen in its copy; which input bits the permit checks use
//! pulses/      the pulses step over any Plc: the bench a run plays on, then per channel the
//!              timing run, chain and stop, and the starts that must be refused or ignored
//! ```

mod contract;
mod error;
mod inputs;
pub mod judge;
mod lines;
mod link;
mod pulses;
pub mod report;

use std::time::Duration;

pub use lines::config_lines;
pub use report::{
    ChannelCounts, ChannelRate, CheckReport, Findings, HeaderProbe, InputsFound, Report,
    RequestSizes, Step, Verdict,
};

use crate::plc::exchange::{Contract, ContractSettings};
use crate::plc::{BoxedLink, LinkSettings, Plc, Protocol, Transport};
use crate::robot::Robot;

/// The checks of the link step, in order.
pub const LINK_CHECKS: [&str; 6] = [
    "headers %, <",
    "largest frame/read/write",
    "multi-frame read",
    "round trip",
    "scan time from heartbeat rate",
    "RUN/PROG read",
];
/// The checks of the contract step, in order.
pub const CONTRACT_CHECKS: [&str; 5] = ["magic", "version", "heartbeat", "host echo", "ready bits"];
/// The checks of the inputs step, in order.
pub const INPUT_CHECKS: [&str; 1] = ["copied every scan"];
/// The checks of the pulses step, per channel, in order.
pub const PULSE_CHECKS: [&str; 9] = [
    "busy on then off",
    "elapsed moves by exactly the table's pulses",
    "time taken vs frequency",
    "two-segment table chains",
    "stop mid-table then a following start works",
    "`from` interlock refuses fault 5",
    "repeated seq ignored",
    "permit refuses fault 8",
    "permit drop holds within one scan",
];

/// What to commission.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// The robot (its joints' channels, output methods, limits and frequency model).
    pub robot: Robot,
    /// Its link, as the config describes it.
    pub link: LinkSettings,
    /// The channels the pulses step plays tables on, in order.
    pub channels: Vec<u8>,
}

impl Target {
    /// Every joint's channel of `robot`, in channel order.
    #[must_use]
    pub fn new(robot: Robot, link: LinkSettings) -> Self {
        let mut channels: Vec<u8> = robot.joints.iter().map(|j| j.channel).collect();
        channels.sort_unstable();
        channels.dedup();
        Self {
            robot,
            link,
            channels,
        }
    }
}

/// The relays the commission switches over the link and back (named `R10F`): two bits of the
/// first R word among the input words, none when all four are X words.
#[must_use]
pub fn relays_switched(target: &Target) -> Vec<String> {
    let words = target.link.layout.inputs;
    inputs::relay_word(&words).map_or_else(Vec::new, |w| {
        [inputs::COPY_BIT, inputs::DROP_BIT]
            .map(|bit| crate::contract::bit_name(words[w], bit))
            .to_vec()
    })
}

/// The link in words: protocol, transport and station.
#[must_use]
pub fn describe_link(settings: &LinkSettings) -> String {
    let protocol = match settings.protocol {
        Protocol::Mewtocol => "mewtocol",
        Protocol::ModbusRtu => "modbus-rtu",
        Protocol::ModbusTcp => "modbus-tcp",
    };
    let over = match &settings.transport {
        Transport::Serial(s) => format!("{} at {} baud", s.path, s.baud),
        Transport::Tcp(t) => t.address.clone(),
    };
    format!("{protocol} over {over}, station {}", settings.station)
}

/// The procedure stops here (a failure that is not only a config change).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Halt;

/// One check being made: its identity and what it looks at.
#[derive(Debug, Clone)]
struct Check {
    step: Step,
    name: &'static str,
    channel: Option<u8>,
    checks: String,
}

impl Check {
    fn new(step: Step, name: &'static str, checks: impl Into<String>) -> Self {
        Self {
            step,
            name,
            channel: None,
            checks: checks.into(),
        }
    }

    fn on(mut self, channel: u8) -> Self {
        self.channel = Some(channel);
        self
    }

    fn report(
        self,
        saw: String,
        verdict: Verdict,
        hint: Option<String>,
        stops: bool,
    ) -> CheckReport {
        CheckReport {
            step: self.step,
            check: self.name.to_owned(),
            channel: self.channel,
            checks: self.checks,
            saw,
            verdict,
            hint,
            stopped: verdict == Verdict::Fail && stops,
        }
    }

    /// It holds.
    fn pass(self, saw: impl Into<String>) -> CheckReport {
        self.report(saw.into(), Verdict::Pass, None, false)
    }

    /// It holds, with a note.
    fn pass_noting(self, saw: impl Into<String>, note: impl Into<String>) -> CheckReport {
        self.report(saw.into(), Verdict::Pass, Some(note.into()), false)
    }

    /// It does not hold, and the procedure stops.
    fn fail(self, saw: impl Into<String>, hint: impl Into<String>) -> CheckReport {
        self.report(saw.into(), Verdict::Fail, Some(hint.into()), true)
    }

    /// It does not hold as configured; the config must change, and the procedure goes on.
    fn config(self, saw: impl Into<String>, hint: impl Into<String>) -> CheckReport {
        self.report(saw.into(), Verdict::Fail, Some(hint.into()), false)
    }

    /// It does not apply.
    fn skip(self, saw: impl Into<String>) -> CheckReport {
        self.report(saw.into(), Verdict::Skip, None, false)
    }
}

/// The procedure's record: checks made so far, findings, and who watches.
struct Session<'a> {
    target: &'a Target,
    checks: Vec<CheckReport>,
    findings: Findings,
    stopped: Option<String>,
    observe: &'a mut dyn FnMut(&CheckReport),
}

impl Session<'_> {
    /// Records a check; a failure that stops the procedure comes back as `Err(Halt)`.
    fn record(&mut self, report: CheckReport) -> Result<(), Halt> {
        (self.observe)(&report);
        let halt = report.stopped;
        if halt && self.stopped.is_none() {
            self.stopped = Some(format!("{} failed", report.title()));
        }
        self.checks.push(report);
        if halt { Err(Halt) } else { Ok(()) }
    }

    /// Every planned check in order.
    fn planned(&self) -> Vec<(Step, &'static str, Option<u8>)> {
        let mut out: Vec<(Step, &'static str, Option<u8>)> = LINK_CHECKS
            .iter()
            .map(|&c| (Step::Link, c, None))
            .chain(CONTRACT_CHECKS.iter().map(|&c| (Step::Contract, c, None)))
            .chain(INPUT_CHECKS.iter().map(|&c| (Step::Inputs, c, None)))
            .collect();
        for &channel in &self.target.channels {
            out.extend(
                PULSE_CHECKS
                    .iter()
                    .map(|&c| (Step::Pulses, c, Some(channel))),
            );
        }
        out
    }

    /// Reports every planned check not made as skipped, after a stop.
    fn skip_the_rest(&mut self) {
        let why = match &self.stopped {
            Some(reason) => format!("not run: the procedure stopped ({reason})"),
            None => "not run".to_owned(),
        };
        for (step, check, channel) in self.planned() {
            let made = self
                .checks
                .iter()
                .any(|c| c.step == step && c.check == check && c.channel == channel);
            if !made {
                let mut skipped = Check::new(step, check, "");
                skipped.channel = channel;
                let report = skipped.skip(why.clone());
                (self.observe)(&report);
                self.checks.push(report);
            }
        }
    }
}

/// Timing the pulses step plans with: the link's pace and the PLC's scan.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LinkTiming {
    /// Median round trip of a status-block read, s.
    status_s: f64,
    /// Mean scan time, s.
    scan_s: f64,
}

impl LinkTiming {
    /// How long the procedure sleeps between two polls (at least 1 ms).
    fn poll(self) -> Duration {
        Duration::from_secs_f64(self.scan_s.max(0.001))
    }

    /// Time between two polls' samples, s.
    fn sample_s(self) -> f64 {
        self.scan_s.max(0.001) + self.status_s
    }
}

/// Runs the whole commission over `link` (opened as `target.link` describes), calling `observe`
/// with every check as it is made. Never fails: everything that goes wrong is in the report.
pub async fn run(
    link: BoxedLink,
    target: &Target,
    observe: &mut dyn FnMut(&CheckReport),
) -> Report {
    let mut session = Session {
        target,
        checks: Vec::new(),
        findings: Findings::default(),
        stopped: None,
        observe,
    };
    let mut all_stopped = false;
    if let Ok(linked) = link::step(&mut session, link).await {
        let defaults = ContractSettings::default();
        let settings = ContractSettings {
            layout: target.link.layout,
            poll_interval: linked.pace.poll(),
            scan_time: target.link.scan_time,
            watch: crate::contract::machine::WatchSettings {
                heartbeat_timeout: target.link.heartbeat_timeout,
                ..defaults.watch
            },
            ..defaults
        };
        let mut contract = Contract::new(linked.plc, settings);
        all_stopped = after_link(&mut session, &mut contract, linked.pace).await;
    }
    session.skip_the_rest();
    let config_lines = config_lines(target, &session.findings);
    let passed =
        session.stopped.is_none() && session.checks.iter().all(|c| c.verdict != Verdict::Fail);
    Report {
        robot: target.robot.name.clone(),
        link: describe_link(&target.link),
        checks: session.checks,
        findings: session.findings,
        config_lines,
        stopped: session.stopped,
        all_stopped,
        passed,
    }
}

/// The contract, inputs and pulses steps, then the final stop (only once the program was
/// recognised).
/// Whether every channel was seen stopped at the end.
async fn after_link<P: Plc>(
    session: &mut Session<'_>,
    contract: &mut Contract<P>,
    pace: LinkTiming,
) -> bool {
    let found = match contract::step(session, contract, pace).await {
        Ok(found) => found,
        Err(contract::Halted { recognised }) => {
            return recognised && stop_everything(contract, pace).await;
        }
    };
    if inputs::step(session, contract, pace).await.is_ok() {
        let _ = pulses::step(session, contract, pace, found).await;
    }
    let stopped = stop_everything(contract, pace).await;
    if let Ok(status) = contract.status().await {
        for counts in &mut session.findings.counts {
            counts.left = Some(status.block.elapsed[usize::from(counts.channel)]);
        }
    }
    stopped
}

/// Writes `command = 2` and reads the status block until no channel is busy (a few scans).
async fn stop_everything<P: Plc>(contract: &mut Contract<P>, pace: LinkTiming) -> bool {
    if let Err(e) = contract.stop().await {
        tracing::error!(error = %e, "commission: the final stop could not be written");
        return false;
    }
    for _ in 0..20 {
        tokio::time::sleep(pace.poll()).await;
        match contract.status().await {
            Ok(s) if s.block.busy == 0 && s.state != crate::contract::State::Running => {
                return true;
            }
            Ok(_) => {}
            Err(e) => {
                tracing::error!(error = %e, "commission: status after the final stop");
                return false;
            }
        }
    }
    false
}

#[cfg(test)]
mod tests;
