//! The link step, over the raw stream: which MEWTOCOL-COM headers the PLC answers, the largest
//! read and write one request may hold (and the longest frame), the round trip, the scan time
//! from the heartbeat's rate, and the RUN/PROG read. It builds its own clients (one per header
//! tried) on the stream and hands back the one it settled on.
//!
//! The request-size probes read and write inside bank 1's channel 0 table area, and every write
//! puts back the words just read there: nothing in the PLC changes.
//!
//! ```text
//! mod.rs       the step; round trip, scan time, RUN/PROG read
//! mewtocol.rs  MEWTOCOL-COM: headers %, <, then the sizes with each header that answered
//! sizes.rs     the size search over any client; Modbus sizes
//! ```

mod mewtocol;
mod sizes;

use std::time::Duration;

use tokio::time::Instant;

use super::judge::{ScanRate, scan_rate, spread};
use super::report::CheckReport;
use super::{Check, Halt, LINK_CHECKS, LinkTiming, Session, Step};
use crate::plc::{AnyPlc, BoxedLink, LinkSettings, Plc, PlcError, PlcMode, Protocol, relay_name};

/// Exchanges timed per kind for the round trip.
const ROUND_TRIPS: usize = 10;
/// How long the heartbeat is watched for the scan time, s.
const SCAN_WINDOW_S: f64 = 0.5;

/// Fewest heartbeat reads a scan time is judged from, however slow the link.
const MIN_READS: usize = 3;

/// What the link step hands on.
pub(super) struct Linked {
    /// The client to go on with.
    pub plc: AnyPlc,
    /// The link's pace.
    pub pace: LinkTiming,
}

/// What the multi-frame read check looks at (MEWTOCOL `%`; skipped otherwise).
const MULTI_FRAME_CHECKS: &str = "whether a MEWTOCOL-COM % read of more words than one frame \
     holds is answered in several frames, each asked for with %01**& (two frames' words of bank \
     1's channel 0 table area)";

fn check(name: &'static str, checks: &str) -> Check {
    debug_assert!(LINK_CHECKS.contains(&name));
    Check::new(Step::Link, name, checks)
}

/// The link step.
pub(super) async fn step(s: &mut Session<'_>, link: BoxedLink) -> Result<Linked, Halt> {
    let settings = s.target.link.clone();
    let mut plc = match settings.protocol {
        Protocol::Mewtocol => mewtocol::step(s, link, &settings).await?,
        Protocol::ModbusRtu | Protocol::ModbusTcp => sizes::modbus(s, link, &settings).await?,
    };
    let pace_status_s = round_trip(s, &mut plc, &settings).await?;
    let scan_s = scan_time(s, &mut plc, &settings).await?;
    run_prog(s, &mut plc, &settings).await?;
    Ok(Linked {
        plc,
        pace: LinkTiming {
            status_s: pace_status_s,
            scan_s,
        },
    })
}

/// Times 1-word reads and status-block reads; the status read's median is the pace.
async fn round_trip(
    s: &mut Session<'_>,
    plc: &mut AnyPlc,
    settings: &LinkSettings,
) -> Result<f64, Halt> {
    let c = check(
        "round trip",
        format!(
            "how long one exchange takes: {ROUND_TRIPS} 1-word reads and {ROUND_TRIPS} reads of \
             the {}-word status block",
            crate::contract::STATUS_WORDS
        )
        .as_str(),
    );
    let (word, status) = match time_reads(plc, settings.layout.status_base).await {
        Ok(times) => times,
        Err(e) => {
            s.record(c.fail(format!("{e:#}"), "the link failed while timing exchanges"))?;
            return Err(Halt);
        }
    };
    let (Some(word), Some(status)) = (spread(&word), spread(&status)) else {
        return Err(Halt);
    };
    s.findings.round_trip_word = Some(word);
    s.findings.round_trip_status = Some(status);
    let timeout_ms = settings.timeout.as_secs_f64() * 1e3;
    let saw = format!(
        "1 word: {:.1} / {:.1} / {:.1} ms; status block: {:.1} / {:.1} / {:.1} ms \
         (least / median / most); the config's timeout is {timeout_ms:.0} ms",
        word.min_ms, word.median_ms, word.max_ms, status.min_ms, status.median_ms, status.max_ms
    );
    if status.max_ms * 2.0 > timeout_ms {
        s.record(c.config(
            saw,
            format!(
                "the timeout leaves less than twice the longest round trip: set timeout = \"{}\"",
                lines_ms(3.0 * status.max_ms)
            ),
        ))?;
    } else {
        s.record(c.pass(saw))?;
    }
    Ok(status.median_ms / 1e3)
}

/// [`ROUND_TRIPS`] times a 1-word read and a status-block read, in turn: their round trips, s.
async fn time_reads(plc: &mut AnyPlc, base: u16) -> Result<(Vec<f64>, Vec<f64>), PlcError> {
    let mut word = Vec::new();
    let mut status = Vec::new();
    for _ in 0..ROUND_TRIPS {
        for (count, into) in [(1, &mut word), (crate::contract::STATUS_WORDS, &mut status)] {
            let began = Instant::now();
            plc.read_words(base, count as u16).await?;
            into.push(began.elapsed().as_secs_f64());
        }
    }
    Ok((word, status))
}

/// A duration in whole milliseconds, rounded up to 10 ms, as the config writes it.
pub(super) fn lines_ms(ms: f64) -> String {
    format!("{}ms", ((ms / 10.0).ceil() * 10.0).max(10.0) as u64)
}

/// Reads the heartbeat word for [`SCAN_WINDOW_S`]: the mean scan time.
async fn scan_time(
    s: &mut Session<'_>,
    plc: &mut AnyPlc,
    settings: &LinkSettings,
) -> Result<f64, Halt> {
    let heartbeat = settings.layout.status_base + 2;
    let c = check(
        "scan time from heartbeat rate",
        format!(
            "the PLC's mean scan time: the heartbeat (DT{heartbeat}, +1 a scan) read for \
             {SCAN_WINDOW_S} s"
        )
        .as_str(),
    );
    let reads = match heartbeats(plc, heartbeat).await {
        Ok(reads) => reads,
        Err(e) => {
            s.record(c.fail(
                format!("{e:#}"),
                "the link failed while reading the heartbeat",
            ))?;
            return Err(Halt);
        }
    };
    let rate = scan_rate(&reads);
    s.findings.scan = Some(rate);
    let Some(mean_s) = rate.mean_scan_s else {
        s.record(c.fail(
            format!(
                "the heartbeat stood still over {} reads in {:.2} s",
                reads.len(),
                rate.window_s
            ),
            "the PLC is in PROG mode, or the contract's program is not loaded or not at this \
             status_base",
        ))?;
        return Err(Halt);
    };
    s.record(scan_report(
        c,
        &rate,
        (reads.len(), mean_s),
        settings.scan_time,
    ))?;
    Ok(mean_s)
}

/// Reads the heartbeat word for [`SCAN_WINDOW_S`] (and [`MIN_READS`] times at least): when
/// each read came back, s, and what it read.
async fn heartbeats(plc: &mut AnyPlc, heartbeat: u16) -> Result<Vec<(f64, u16)>, PlcError> {
    let began = Instant::now();
    let mut reads = Vec::new();
    while began.elapsed().as_secs_f64() < SCAN_WINDOW_S || reads.len() < MIN_READS {
        let w = plc.read_words(heartbeat, 1).await?;
        reads.push((began.elapsed().as_secs_f64(), w[0]));
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    Ok(reads)
}

/// The scan time check's report: the mean scan `mean_s` over `reads` reads against the
/// config's `scan_time`.
fn scan_report(
    c: Check,
    rate: &ScanRate,
    (reads, mean_s): (usize, f64),
    scan_time: Duration,
) -> CheckReport {
    let configured_ms = scan_time.as_secs_f64() * 1e3;
    let saw = format!(
        "{} scans in {:.3} s over {reads} reads: {:.2} ms a scan on average; the config's \
         scan_time (the longest scan) is {configured_ms:.0} ms",
        rate.scans,
        rate.window_s,
        mean_s * 1e3
    );
    if mean_s * 1e3 > configured_ms {
        c.config(
            saw,
            format!(
                "the scans take longer than scan_time says: set scan_time = \"{}ms\"",
                (2.0 * mean_s * 1e3).ceil() as u64
            ),
        )
    } else {
        c.pass(saw)
    }
}

/// Reads the mode while the heartbeat moves: it must say RUN.
async fn run_prog(
    s: &mut Session<'_>,
    plc: &mut AnyPlc,
    settings: &LinkSettings,
) -> Result<(), Halt> {
    let (how, fix) = match settings.protocol {
        Protocol::Mewtocol => (
            "the RT command's mode flag".to_owned(),
            "linterpd reads RT only to say \"in PROG mode\" when the heartbeat stalls; report \
             this unit's RT reply"
                .to_owned(),
        ),
        Protocol::ModbusRtu | Protocol::ModbusTcp => (
            format!(
                "relay {} as coil {}",
                relay_name(settings.mode_relay),
                crate::plc::RELAY_COIL_BASE + settings.mode_relay
            ),
            "set mode_relay to a relay that reads ON in RUN (linterpd reads it only to say \"in \
             PROG mode\" when the heartbeat stalls)"
                .to_owned(),
        ),
    };
    let c = check(
        "RUN/PROG read",
        format!("that {how} reads RUN while the heartbeat moves").as_str(),
    );
    match plc.mode().await {
        Ok(PlcMode::Run) => {
            s.findings.mode = Some("RUN".to_owned());
            s.record(c.pass(format!("{how}: RUN")))
        }
        Ok(PlcMode::Prog) => {
            s.findings.mode = Some("PROG".to_owned());
            s.record(c.config(format!("{how}: PROG, while the heartbeat moves"), fix))
        }
        Err(e @ PlcError::Refused { .. }) => s.record(c.config(format!("{how}: {e:#}"), fix)),
        Err(e) => s.record(c.fail(format!("{e:#}"), "the link failed while reading the mode")),
    }
}
