//! The contract step: the status block's magic and version, a heartbeat that moves, the host
//! word echoed (and kept: a second host writing it means a `linterpd serve` daemon still owns
//! the link), and the ready bits with the state the pulses step needs.

use std::time::Duration;

use tokio::time::Instant;

use super::error::Failure;
use super::judge::scan_rate;
use super::{CONTRACT_CHECKS, Check, Halt, LinkTiming, Session, Step};
use crate::contract::{
    MAGIC, READY_DRIVES, READY_ESTOP_CLEAR, READY_HOMED, STATUS_WORDS, State, StatusBlock, VERSION,
};
use crate::plc::Plc;
use crate::plc::exchange::{Contract, fault_meaning};

/// How long the host word is watched after its echo: more than twice the 250 ms at which an
/// idle `linterpd serve` reads the status block (and writes its own host word back).
const HOST_WATCH: Duration = Duration::from_millis(600);

/// Fewest heartbeat reads a rate is judged from, however slow the link.
const MIN_READS: usize = 3;

/// Why the contract step ended early: `recognised` once magic and version were read right (a
/// stop may then be written; never to a PLC whose program is not ours).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Halted {
    pub recognised: bool,
}

/// What the pulses step starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Found {
    /// The status block read last.
    pub status: StatusBlock,
}

fn check(name: &'static str, checks: String) -> Check {
    debug_assert!(CONTRACT_CHECKS.contains(&name));
    Check::new(Step::Contract, name, checks)
}

fn halted(recognised: bool) -> impl Fn(Halt) -> Halted {
    move |Halt| Halted { recognised }
}

/// The contract step.
pub(super) async fn step<P: Plc>(
    s: &mut Session<'_>,
    contract: &mut Contract<P>,
    pace: LinkTiming,
) -> Result<Found, Halted> {
    let base = s.target.link.layout.status_base;
    let first = match read_raw(contract, base).await {
        Ok(block) => block,
        Err(e) => {
            let c = check("magic", format!("DT{base} holds 0x{MAGIC:04X} (\"LI\")"));
            s.record(c.fail(
                e.to_string(),
                "the link failed while reading the status block",
            ))
            .map_err(halted(false))?;
            return Err(Halted { recognised: false });
        }
    };
    magic_and_version(s, base, &first).map_err(halted(false))?;
    heartbeat(s, contract, pace).await.map_err(halted(true))?;
    host_echo(s, contract, pace, &first)
        .await
        .map_err(halted(true))?;
    let status = ready_bits(s, contract).await.map_err(halted(true))?;
    Ok(Found { status })
}

async fn read_raw<P: Plc>(contract: &mut Contract<P>, base: u16) -> Result<StatusBlock, Failure> {
    let words = contract.plc().read_words(base, STATUS_WORDS as u16).await?;
    StatusBlock::from_words(&words).ok_or(Failure::ShortStatus { read: words.len() })
}

fn magic_and_version(s: &mut Session<'_>, base: u16, block: &StatusBlock) -> Result<(), Halt> {
    let c = check(
        "magic",
        format!("DT{base} holds the program's magic 0x{MAGIC:04X} (\"LI\")"),
    );
    let saw = format!("DT{base} = 0x{:04X}", block.magic);
    if block.magic == MAGIC {
        s.record(c.pass(saw))?;
    } else {
        s.record(c.fail(
            saw,
            "the linterpd PLC program is not running there: load deploy/plc's listing, switch to \
             RUN, or correct status_base in [robots.NAME.plc.contract]",
        ))?;
    }
    let c = check(
        "version",
        format!("DT{} holds contract version {VERSION}", base + 1),
    );
    let saw = format!("DT{} = {}", base + 1, block.version);
    if block.version == VERSION {
        s.record(c.pass(saw))
    } else {
        s.record(c.fail(
            saw,
            format!(
                "the PLC program speaks contract version {}; this linterpd speaks {VERSION}: load \
                 the listing that comes with this linterpd",
                block.version
            ),
        ))
    }
}

async fn status<P: Plc>(
    contract: &mut Contract<P>,
) -> Result<crate::contract::machine::Status, Failure> {
    Ok(contract.status().await?)
}

/// Reads the status block every scan for `heartbeat_timeout`: the heartbeat moves, and never
/// stands still for half the timeout.
async fn heartbeat<P: Plc>(
    s: &mut Session<'_>,
    contract: &mut Contract<P>,
    pace: LinkTiming,
) -> Result<(), Halt> {
    let limit = s.target.link.heartbeat_timeout;
    let c = check(
        "heartbeat",
        format!(
            "the heartbeat moves (+1 a scan) and never stands still for half of heartbeat_timeout \
             ({} ms); the status block decodes",
            limit.as_millis()
        ),
    );
    let reads = match heartbeats(contract, pace, limit).await {
        Ok(reads) => reads,
        Err(e) => {
            let hint = "the status block must decode: check the listing";
            return s.record(c.fail(e.to_string(), hint));
        }
    };
    let rate = scan_rate(&reads);
    let saw = format!(
        "{} steps over {} reads in {:.2} s; it stood still for at most {:.1} ms",
        rate.scans,
        reads.len(),
        rate.window_s,
        rate.longest_still_s * 1e3
    );
    if rate.scans == 0 {
        return s.record(c.fail(saw, "the program does not scan: switch the PLC to RUN"));
    }
    if rate.longest_still_s * 2.0 >= limit.as_secs_f64() {
        let wanted = Duration::from_secs_f64(rate.longest_still_s * 4.0);
        return s.record(c.config(
            saw,
            format!(
                "the heartbeat stands still too long for heartbeat_timeout: set \
                 heartbeat_timeout = \"{}\"",
                super::link::lines_ms(wanted.as_secs_f64() * 1e3)
            ),
        ));
    }
    s.record(c.pass(saw))
}

/// Reads the status block every poll for `limit` (and [`MIN_READS`] times at least): when each
/// read came back, s, and its heartbeat.
async fn heartbeats<P: Plc>(
    contract: &mut Contract<P>,
    pace: LinkTiming,
    limit: Duration,
) -> Result<Vec<(f64, u16)>, Failure> {
    let began = Instant::now();
    let mut reads = Vec::new();
    while began.elapsed() < limit || reads.len() < MIN_READS {
        let st = status(contract).await?;
        reads.push((began.elapsed().as_secs_f64(), st.block.heartbeat));
        tokio::time::sleep(pace.poll()).await;
    }
    Ok(reads)
}

/// A host word that is not 0 and not `current`.
fn host_word(current: u16, heartbeat: u16) -> u16 {
    let word = 0xC000 | (heartbeat & 0x0FFF);
    if word == current { word ^ 1 } else { word }
}

/// What a check says when another host writes the host word.
const ANOTHER_HOST: &str = "another host writes the host word: stop `linterpd serve` (or whatever \
                            else talks to this PLC) before commissioning";

/// Writes a host word, waits for its echo, then watches that nobody else writes another.
async fn host_echo<P: Plc>(
    s: &mut Session<'_>,
    contract: &mut Contract<P>,
    pace: LinkTiming,
    first: &StatusBlock,
) -> Result<(), Halt> {
    let layout = s.target.link.layout;
    let host = host_word(first.host, first.heartbeat);
    let c = check(
        "host echo",
        format!(
            "the program copies the host word DT{} into DT{} within a few scans, and no other host \
             (a linterpd serve daemon) writes it while the commission runs",
            layout.command_base + crate::contract::COMMAND_HOST_OFFSET,
            layout.status_base + 20
        ),
    );
    s.findings.host = Some(host);
    if let Err(e) = contract.write_host(host).await {
        return s.record(c.fail(format!("{e:#}"), "the link failed writing the host word"));
    }
    let limit = s.target.link.heartbeat_timeout.max(pace.poll() * 20);
    let echoed = match echo(contract, pace, (host, first.host), limit).await {
        Ok(echoed) => echoed,
        Err((saw, hint)) => return s.record(c.fail(saw, hint)),
    };
    let report = match kept(contract, pace, host, echoed).await {
        Ok(reads) => {
            let before = match first.host {
                0 => "0 before (the PLC restarted since a host last wrote it)".to_owned(),
                h => format!("0x{h:04X} before (a host wrote it earlier)"),
            };
            c.pass(format!(
                "DT{} read {before}; wrote 0x{host:04X}, echoed after {:.1} ms and kept over \
                 {reads} reads in {} ms",
                layout.status_base + 20,
                echoed.as_secs_f64() * 1e3,
                HOST_WATCH.as_millis()
            ))
        }
        Err((saw, hint)) => c.fail(saw, hint),
    };
    s.record(report)
}

/// Reads the status block until it echoes `host` (the word it held before being `was`): how
/// long that took, or what a failed check saw and its hint.
async fn echo<P: Plc>(
    contract: &mut Contract<P>,
    pace: LinkTiming,
    (host, was): (u16, u16),
    limit: Duration,
) -> Result<Duration, (String, &'static str)> {
    let layout = contract.settings().layout;
    let began = Instant::now();
    loop {
        tokio::time::sleep(pace.poll()).await;
        let st = match status(contract).await {
            Ok(st) => st.block,
            Err(e) => return Err((e.to_string(), "the link failed reading the status block")),
        };
        if st.host == host {
            return Ok(began.elapsed());
        }
        let saw = format!(
            "wrote 0x{host:04X}; DT{} reads 0x{:04X} after {} ms",
            layout.status_base + 20,
            st.host,
            began.elapsed().as_millis()
        );
        if st.host != was {
            return Err((saw, ANOTHER_HOST));
        }
        if began.elapsed() > limit {
            let at = layout.command_base + crate::contract::COMMAND_HOST_OFFSET;
            let ours = contract.plc().read_words(at, 1).await;
            let hint = match ours {
                Ok(w) if w[0] != host => ANOTHER_HOST,
                _ => {
                    "the program must copy DT1048 into DT1020 every scan (listing, \"Status \
                      block\")"
                }
            };
            return Err((saw, hint));
        }
    }
}

/// Reads the status block for [`HOST_WATCH`] after the echo: how many reads kept `host`, or
/// what a failed check saw and its hint.
async fn kept<P: Plc>(
    contract: &mut Contract<P>,
    pace: LinkTiming,
    host: u16,
    echoed: Duration,
) -> Result<usize, (String, &'static str)> {
    let watching = Instant::now();
    let mut reads = 0;
    while watching.elapsed() < HOST_WATCH {
        tokio::time::sleep(pace.poll()).await;
        reads += 1;
        match status(contract).await {
            Ok(st) if st.block.host != host => {
                let saw = format!(
                    "wrote 0x{host:04X}, echoed after {:.1} ms, then it read 0x{:04X}",
                    echoed.as_secs_f64() * 1e3,
                    st.block.host
                );
                return Err((saw, ANOTHER_HOST));
            }
            Ok(_) => {}
            Err(e) => return Err((e.to_string(), "the link failed reading the status block")),
        }
    }
    Ok(reads)
}

fn bit(ready: u16, mask: u16) -> &'static str {
    if ready & mask != 0 { "ON" } else { "OFF" }
}

/// The ready bits and the state: homed, e-stop closed, nothing running and no fault.
async fn ready_bits<P: Plc>(
    s: &mut Session<'_>,
    contract: &mut Contract<P>,
) -> Result<StatusBlock, Halt> {
    let c = check(
        "ready bits",
        "bit 0 homed and bit 2 e-stop clear are ON, bit 1 drives ready as wired (OFF with the \
         drives' power off), and the program is idle, done or stopped without a fault"
            .to_owned(),
    );
    let st = match status(contract).await {
        Ok(st) => st,
        Err(e) => {
            s.record(c.fail(e.to_string(), "the link failed reading the status block"))?;
            return Err(Halt);
        }
    };
    let ready = st.block.ready;
    s.findings.ready = Some(ready);
    let saw = format!(
        "ready 0b{ready:03b}: homed {}, drives ready {}, e-stop clear {}; state {}, fault {}",
        bit(ready, READY_HOMED),
        bit(ready, READY_DRIVES),
        bit(ready, READY_ESTOP_CLEAR),
        st.state.name(),
        st.block.fault
    );
    if let Some(hint) = not_ready(&st, s.target.link.layout.command_base) {
        s.record(c.fail(saw, hint))?;
        return Err(Halt);
    }
    if ready & READY_DRIVES != 0 {
        s.record(c.pass_noting(
            saw,
            "drives ready is ON: with the drives' power off it should read OFF; if they are off, \
             check X12's wiring",
        ))?;
    } else {
        s.record(c.pass(saw))?;
    }
    Ok(st.block)
}

/// Why the pulses step cannot start from `st` (what to do about it), or `None`.
fn not_ready(st: &crate::contract::machine::Status, command_base: u16) -> Option<String> {
    let ready = st.block.ready;
    if ready & READY_ESTOP_CLEAR == 0 {
        Some("close the e-stop circuit (X10): a start is refused while it is open".to_owned())
    } else if ready & READY_HOMED == 0 {
        Some(
            "home the robot first (the program's home command, command = 4; with the listing's \
             HOME MODE 0, switch X11 on): starts are refused with fault 6 until the homed bit is \
             set"
            .to_owned(),
        )
    } else if matches!(st.state, State::Running | State::Homing) {
        Some(format!(
            "the PLC is {}: is a linterpd serve daemon still using it? Stop it and wait",
            st.state.name()
        ))
    } else if st.state == State::Fault {
        Some(format!(
            "the program has fault {} ({}) latched: find its cause, then clear it (write 3 to \
             DT{command_base})",
            st.block.fault,
            fault_meaning(st.block.fault),
        ))
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_host_word_is_nonzero_and_new() {
        assert_eq!(host_word(0, 0x1234), 0xC234);
        assert_eq!(host_word(0xC234, 0x1234), 0xC235);
        assert_ne!(host_word(0, 0), 0);
    }
}
