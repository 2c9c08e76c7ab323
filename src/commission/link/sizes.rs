//! The search for the largest read and write one request may hold, over any client, and the
//! Modbus sizes check. Every probe reads, or writes back what was just read, inside bank 1's
//! channel 0 table area: nothing in the PLC changes.

use std::time::Duration;

use tokio::time::Instant;

use super::{MULTI_FRAME_CHECKS, check};
use crate::commission::judge::Bisect;
use crate::commission::report::{CheckReport, RequestSizes};
use crate::commission::{Check, Halt, Session};
use crate::plc::{
    AnyPlc, BoxedLink, LinkSettings, MAX_READ_REGISTERS, MAX_WRITE_REGISTERS, ModbusClient,
    ModbusOptions, Parity, Plc, PlcError, Transport,
};

/// Longest Modbus RTU frame, bytes (Modbus over serial line v1.02, §2.5.1).
const MODBUS_FRAME_BYTES: usize = 256;

/// One size search and why its smallest refused size failed.
#[derive(Debug, Clone)]
pub(super) struct Search {
    pub bisect: Bisect,
    refused: Option<String>,
    /// How long the largest accepted size took.
    took: Duration,
}

impl Search {
    fn new(max: usize) -> Self {
        Self {
            bisect: Bisect::new(max),
            refused: None,
            took: Duration::ZERO,
        }
    }

    fn record(&mut self, size: usize, outcome: Result<(), PlcError>, took: Duration) {
        match outcome {
            Ok(()) => {
                if size > self.bisect.largest() {
                    self.took = took;
                }
                self.bisect.record(size, true);
            }
            Err(e) => {
                let why = match e {
                    PlcError::Refused { refusal, .. } => refusal.to_string(),
                    PlcError::Timeout { timeout_ms, .. } => {
                        format!("no reply within {timeout_ms} ms")
                    }
                    other => format!("{other:#}"),
                };
                tracing::info!(words = size, %why, "commission: request size not taken");
                if self.bisect.smallest_refused().is_none_or(|n| size < n) {
                    self.refused = Some(why);
                }
                self.bisect.record(size, false);
            }
        }
    }

    /// `, in 12.3 ms (400: refused ...)`.
    pub(super) fn refused_at(&self) -> String {
        let took = format!(" in {:.1} ms", self.took.as_secs_f64() * 1e3);
        match (self.bisect.smallest_refused(), &self.refused) {
            (Some(n), Some(why)) => format!("{took} ({n}: {why})"),
            _ => took,
        }
    }

    /// Whether linterpd's frames of `size` fit: taken, and within linterpd's timeout.
    pub(super) fn carries(&self, size: usize, timeout: Duration) -> bool {
        self.bisect.largest() >= size && self.took <= timeout
    }

    pub(super) fn sizes(
        &self,
        write: &Search,
        framing: &str,
        frame: Option<usize>,
    ) -> RequestSizes {
        RequestSizes {
            framing: framing.to_owned(),
            read_words: self.bisect.largest(),
            read_refused: self.bisect.smallest_refused(),
            write_words: write.bisect.largest(),
            write_refused: write.bisect.smallest_refused(),
            largest_frame_chars: frame,
        }
    }
}

/// The timeout of a size probe: linterpd's own, plus a command and a reply of `frame_chars`
/// characters each on a serial line (start bit, data bits, parity, stop bits a character) and a
/// scan. A probe that gets no reply within it got none at all (never a late one), and how long
/// an accepted one took is judged against linterpd's own timeout separately.
pub(super) fn probe_timeout(settings: &LinkSettings, frame_chars: usize) -> Duration {
    let wire_s = match &settings.transport {
        Transport::Serial(serial) => {
            let bits =
                1 + serial.data_bits + u8::from(serial.parity != Parity::None) + serial.stop_bits;
            2.0 * frame_chars as f64 * f64::from(bits) / f64::from(serial.baud.max(1))
        }
        Transport::Tcp(_) => 0.0,
    };
    settings.timeout + settings.scan_time + Duration::from_secs_f64(wire_s)
}

/// The largest read (`1..=max_read`) and write (`1..=max_write`) `plc` takes in one request
/// (each probe is one frame or request: the limits are the client's own), and how long the
/// largest took. A link failure ends the probes; any other error is the PLC's answer to that
/// size.
pub(super) async fn sizes<P: Plc>(
    plc: &mut P,
    settings: &LinkSettings,
    (max_read, max_write): (usize, usize),
) -> Result<(Search, Search), PlcError> {
    let layout = settings.layout;
    let base = layout.area(1, 0);
    let area = usize::from(layout.area_words);
    let (max_read, max_write) = (max_read.min(area), max_write.min(area));
    let mut read = Search::new(max_read);
    while let Some(n) = read.bisect.next() {
        let began = Instant::now();
        match plc.read_words(base, n as u16).await {
            Err(e @ PlcError::Link { .. }) => return Err(e),
            result => read.record(n, result.map(|_| ()), began.elapsed()),
        }
    }
    let mut write = Search::new(max_write);
    if read.bisect.largest() == 0 {
        write.bisect.record(1, false);
        return Ok((read, write));
    }
    let mut words = Vec::with_capacity(max_write);
    while words.len() < max_write {
        let n = read.bisect.largest().min(max_write - words.len());
        words.extend(plc.read_words(base + words.len() as u16, n as u16).await?);
    }
    while let Some(n) = write.bisect.next() {
        let began = Instant::now();
        match plc.write_words(base, &words[..n]).await {
            Err(e @ PlcError::Link { .. }) => return Err(e),
            result => write.record(n, result, began.elapsed()),
        }
    }
    Ok((read, write))
}

/// Modbus: request sizes with a client allowed the specification's maxima.
pub(super) async fn modbus(
    s: &mut Session<'_>,
    link: BoxedLink,
    settings: &LinkSettings,
) -> Result<AnyPlc, Halt> {
    let c = check("headers %, <", "which MEWTOCOL-COM headers the PLC answers");
    s.record(c.skip("Modbus has no MEWTOCOL-COM header"))?;
    let c = check(
        "largest frame/read/write",
        "the largest read (03) and write (16) one Modbus request may hold (reads and writes back \
         of bank 1's channel 0 table area; the specification's maximum first, then halving)",
    );
    let mut options = ModbusOptions::from_settings(settings);
    options.max_read_registers = MAX_READ_REGISTERS;
    options.max_write_registers = MAX_WRITE_REGISTERS;
    options.timeout = probe_timeout(settings, MODBUS_FRAME_BYTES);
    let mut client = ModbusClient::new(link, options);
    let (max_read, max_write) = (
        usize::from(MAX_READ_REGISTERS),
        usize::from(MAX_WRITE_REGISTERS),
    );
    let (read, write) = match sizes(&mut client, settings, (max_read, max_write)).await {
        Ok(found) => found,
        Err(e) => {
            s.record(c.fail(
                format!("{e:#}"),
                "the link failed while probing request sizes",
            ))?;
            return Err(Halt);
        }
    };
    s.findings.sizes.push(read.sizes(&write, "modbus", None));
    s.record(modbus_sizes_report(
        c,
        (&read, &write),
        (max_read, max_write),
        settings,
    ))?;
    let multi = check("multi-frame read", MULTI_FRAME_CHECKS);
    s.record(multi.skip("Modbus replies are not split into frames"))?;
    Ok(AnyPlc::Modbus(client))
}

/// The Modbus sizes check's report from the searches, against the config's request sizes.
/// Sizes under what linterpd's own requests need stop the procedure.
fn modbus_sizes_report(
    c: Check,
    (read, write): (&Search, &Search),
    (max_read, max_write): (usize, usize),
    settings: &LinkSettings,
) -> CheckReport {
    let (read_most, write_most) = (read.bisect.largest(), write.bisect.largest());
    let saw = format!(
        "reads up to {read_most} of {max_read} registers{}, writes up to {write_most} of \
         {max_write}{}; the config asks for up to {} a read and {} a write",
        read.refused_at(),
        write.refused_at(),
        settings.modbus_max_read,
        settings.modbus_max_write,
    );
    let smallest_needed = crate::contract::STATUS_WORDS;
    if read_most < smallest_needed || write_most < crate::contract::COMMAND_WORDS - 1 {
        return c.fail(
            saw,
            format!(
                "linterpd needs at least {smallest_needed} registers a read and {} a write",
                crate::contract::COMMAND_WORDS - 1
            ),
        );
    }
    let (read_size, write_size) = (
        usize::from(settings.modbus_max_read),
        usize::from(settings.modbus_max_write),
    );
    if !read.carries(read_size, settings.timeout) || !write.carries(write_size, settings.timeout) {
        c.config(
            saw,
            format!(
                "set modbus_max_read = {read_most} and modbus_max_write = {write_most} (or, if \
                 they took longer than the timeout, raise the timeout)"
            ),
        )
    } else {
        c.pass(saw)
    }
}
