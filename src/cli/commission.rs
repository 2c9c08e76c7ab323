//! `linterpd commission`: the guided check of a real unit with the drives' power off
//! ([`crate::commission`]): asks for confirmation (unless `--yes`), opens the robot's link as
//! `linterpd serve` would, prints every check as it is made, then the figures, the counts and the
//! config lines to paste.
//!
//! ```text
//!  stdout:  the report as text, check by check as they are made (or, with --json, one JSON
//!           object at the end: docs/COMMISSION.md, "The report")
//!  stderr:  the confirmation prompt; with --json the checks as they are made
//!  exit:    0 every check passed; 1 a check failed or the link could not be opened;
//!           2 bad arguments or config, or not confirmed (nothing was sent)
//! ```

use std::fmt::Write as _;
use std::io::{BufRead, Write};
use std::path::PathBuf;

use anyhow::{Context, anyhow};
use clap::Args;

use super::{Failure, bad_input};
use crate::commission::{
    self, CheckReport, Report, Target, Verdict, describe_link, relays_switched,
};
use crate::config::Config;
use crate::plc::{BoxedLink, LinkSettings, PlcError, Transport, open_serial, open_tcp};

/// Arguments of `linterpd commission`.
#[derive(Debug, Args)]
pub struct CommissionArgs {
    /// The configuration file (the robot and its `[robots.NAME.plc]` link).
    #[arg(
        long,
        env = "LINTERPD_CONFIG",
        default_value = "/etc/linterpd/linterpd.toml"
    )]
    pub config: PathBuf,
    /// The robot to commission (needed when the file holds several).
    #[arg(long)]
    pub robot: Option<String>,
    /// The pulse channels to play tables on, e.g. `0,2` (default: every joint's channel).
    #[arg(long, value_delimiter = ',')]
    pub channels: Vec<u8>,
    /// Do not ask: the drives' power is off and nothing else talks to the PLC.
    #[arg(long)]
    pub yes: bool,
    /// Print the report as JSON (the checks go to stderr as they are made).
    #[arg(long)]
    pub json: bool,
}

/// The arguments and config, checked.
fn target(args: &CommissionArgs) -> anyhow::Result<Target> {
    let config = Config::load(&args.config)?;
    let robot = config.robot(args.robot.as_deref())?.clone();
    let link = config.link(&robot.name).cloned().ok_or_else(|| {
        anyhow!(
            "robot {} has no [robots.{}.plc] table: the commission needs its PLC link",
            robot.name,
            robot.name
        )
    })?;
    let mut target = Target::new(robot, link);
    if !args.channels.is_empty() {
        for c in &args.channels {
            if !target.channels.contains(c) {
                return Err(anyhow!(
                    "--channels {c}: robot {} drives channels {:?}",
                    target.robot.name,
                    target.channels
                ));
            }
        }
        target.channels.clone_from(&args.channels);
        target.channels.dedup();
    }
    Ok(target)
}

/// What the operator is asked before anything is sent.
#[must_use]
pub fn prompt(target: &Target) -> String {
    let channels: Vec<String> = target.channels.iter().map(u8::to_string).collect();
    let relays = match relays_switched(target).as_slice() {
        [] => String::new(),
        names => format!(
            "It switches relays {} (input bits the permit checks use) over the link for a moment\n\
             each, and back.\n",
            names.join(" and ")
        ),
    };
    format!(
        "linterpd commission: robot {}, {}\n\
         It plays tiny pulse tables on channel {}, one channel at a time: at most 600 pulses away\n\
         from where each channel stands, at 100..2000 Hz, and back again.\n\
         {relays}\
         Before you go on:\n  \
         - switch the drives' power OFF: the tables must move nothing;\n  \
         - stop `linterpd serve` and anything else that talks to this PLC: the commission must\n    \
         own the link (a second host writing the host word stops it);\n  \
         - close the e-stop circuit and home the robot (the homed bit must be set).\n\
         Type yes to go on: ",
        target.robot.name,
        describe_link(&target.link),
        channels.join(", ")
    )
}

/// Asks on stderr, reads one line from stdin: only `yes` goes on.
fn confirmed(target: &Target) -> anyhow::Result<bool> {
    let mut err = std::io::stderr();
    err.write_all(prompt(target).as_bytes())
        .and_then(|()| err.flush())
        .context("cannot write the prompt to stderr")?;
    let mut answer = String::new();
    std::io::stdin()
        .lock()
        .read_line(&mut answer)
        .context("cannot read the answer from stdin")?;
    Ok(answer.trim().eq_ignore_ascii_case("yes"))
}

/// Opens the link the settings describe (a serial port or a TCP connection), as `linterpd
/// serve` does.
async fn open(settings: &LinkSettings) -> Result<BoxedLink, PlcError> {
    match &settings.transport {
        Transport::Serial(serial) => open_serial(serial),
        Transport::Tcp(tcp) => open_tcp(tcp).await,
    }
}

/// Runs `linterpd commission`.
pub fn run(args: &CommissionArgs, out: &mut dyn Write) -> Result<(), Failure> {
    let target = target(args).map_err(bad_input)?;
    if !args.yes && !confirmed(&target).map_err(Failure::Runtime)? {
        return Err(bad_input(anyhow!(
            "not confirmed: nothing was sent to the PLC"
        )));
    }
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")
        .map_err(Failure::Runtime)?;
    let report = runtime.block_on(commission_on(&target, args.json, out))?;
    if args.json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| Failure::Runtime(e.into()))?;
        writeln!(out, "{text}").map_err(|e| Failure::Runtime(e.into()))?;
    } else {
        write!(out, "{}", summary(&report)).map_err(|e| Failure::Runtime(e.into()))?;
    }
    if report.passed {
        Ok(())
    } else {
        let failed = report.failures().count();
        Err(Failure::Runtime(anyhow!(
            "commission: {failed} check(s) failed{}",
            report
                .stopped
                .as_ref()
                .map_or(String::new(), |why| format!("; stopped: {why}"))
        )))
    }
}

async fn commission_on(
    target: &Target,
    json: bool,
    out: &mut dyn Write,
) -> Result<Report, Failure> {
    let link = open(&target.link)
        .await
        .with_context(|| format!("cannot open {}", describe_link(&target.link)))
        .map_err(Failure::Runtime)?;
    if !json {
        let _ = writeln!(
            out,
            "linterpd commission: robot {}, {}\n",
            target.robot.name,
            describe_link(&target.link)
        );
    }
    let mut observe = |check: &CheckReport| {
        let text = check_text(check);
        let _ = if json {
            write!(std::io::stderr(), "{text}")
        } else {
            write!(out, "{text}").and_then(|()| out.flush())
        };
    };
    Ok(commission::run(link, target, &mut observe).await)
}

/// One check as text: `[pass] step: check (channel c)`, then what it checks, what it saw and a
/// hint or note.
#[must_use]
pub fn check_text(check: &CheckReport) -> String {
    let mut text = format!("[{}] {}\n", check.verdict.tag(), check.title());
    if !check.checks.is_empty() {
        let _ = writeln!(text, "       checks: {}", check.checks);
    }
    let _ = writeln!(text, "       saw:    {}", check.saw);
    if let Some(hint) = &check.hint {
        let label = if check.verdict == Verdict::Fail {
            "hint:  "
        } else {
            "note:  "
        };
        let _ = writeln!(text, "       {label} {hint}");
    }
    if check.stopped {
        let _ = writeln!(
            text,
            "       (the procedure stops here: every channel is stopped)"
        );
    }
    text
}

/// The end of the text report: tally, counts, whether everything stopped, config lines.
#[must_use]
pub fn summary(report: &Report) -> String {
    let count = |v: Verdict| report.checks.iter().filter(|c| c.verdict == v).count();
    let mut text = String::from("\n");
    let _ = writeln!(
        text,
        "result: {} checks: {} pass, {} FAIL, {} skipped{}",
        report.checks.len(),
        count(Verdict::Pass),
        count(Verdict::Fail),
        count(Verdict::Skip),
        report
            .stopped
            .as_ref()
            .map_or(String::new(), |why| format!("; stopped early: {why}"))
    );
    for c in &report.findings.counts {
        let left = match c.left {
            Some(left) if left == c.found => format!("left at {left} (as found)"),
            Some(left) => format!(
                "left at {left}: the count no longer matches the robot, home it before moving"
            ),
            None => "left at an unknown count: home the robot before moving".to_owned(),
        };
        let _ = writeln!(text, "channel {}: found at {}, {left}", c.channel, c.found);
    }
    let _ = writeln!(
        text,
        "final stop: {}",
        if report.all_stopped {
            "written, every channel idle"
        } else {
            "NOT confirmed: check the PLC before switching the drives on"
        }
    );
    if !report.config_lines.is_empty() {
        let _ = writeln!(text, "\nconfig lines to paste into linterpd.toml:");
        for line in &report.config_lines {
            let _ = writeln!(text, "  {line}");
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commission::{ChannelCounts, Findings, Step};

    fn check(verdict: Verdict, hint: Option<&str>, stopped: bool) -> CheckReport {
        CheckReport {
            step: Step::Pulses,
            check: "busy on then off".into(),
            channel: Some(0),
            checks: "busy ON then OFF".into(),
            saw: "busy bit ON in 0 of 58 reads".into(),
            verdict,
            hint: hint.map(Into::into),
            stopped,
        }
    }

    #[test]
    fn a_failed_check_prints_its_hint_and_that_the_procedure_stops() {
        let text = check_text(&check(Verdict::Fail, Some("try R9120"), true));
        assert_eq!(
            text,
            "[FAIL] pulses: busy on then off (channel 0)\n       checks: busy ON then OFF\n       \
             saw:    busy bit ON in 0 of 58 reads\n       hint:   try R9120\n       (the \
             procedure stops here: every channel is stopped)\n"
        );
        let text = check_text(&check(Verdict::Pass, Some("drives ready ON"), false));
        assert!(text.contains("note:   drives ready ON") && !text.contains("stops here"));
    }

    #[test]
    fn the_summary_tallies_and_says_where_counts_were_left() {
        let report = Report {
            robot: "r".into(),
            link: "l".into(),
            checks: vec![check(Verdict::Fail, Some("h"), true)],
            findings: Findings {
                counts: vec![
                    ChannelCounts {
                        channel: 0,
                        found: 10,
                        left: Some(25),
                    },
                    ChannelCounts {
                        channel: 1,
                        found: 5,
                        left: Some(5),
                    },
                ],
                ..Findings::default()
            },
            config_lines: vec!["[robots.r.plc]".into(), "header = \"percent\"".into()],
            stopped: Some("pulses: busy on then off (channel 0) failed".into()),
            all_stopped: true,
            passed: false,
        };
        let text = summary(&report);
        assert!(text.contains("result: 1 checks: 0 pass, 1 FAIL, 0 skipped; stopped early"));
        assert!(text.contains("channel 0: found at 10, left at 25: the count no longer matches"));
        assert!(text.contains("channel 1: found at 5, left at 5 (as found)"));
        assert!(text.contains("  header = \"percent\""));
    }
}
