//! IO. The Modbus client: [`Plc`] through tokio-modbus (never Modbus by hand), RTU or TCP, over
//! any byte stream.
//!
//! ```text
//!  DT n      <-> holding register n        read 03 <= 125 registers, write 16 <= 123 a request
//!                                          (fewer if ModbusOptions says so: some peers take less)
//!  R w.b     <-> coil 2048 + 16 w + b      read 01, write 05
//!  RUN flag  <-  a configurable relay      default R9020 [unverified]: FP-X documents no
//!                                          Modbus register for RUN / PROG
//! ```
//! (PLC.md §2; FP-X user's manual, "Modbus RTU communication", address map.)
//!
//! tokio-modbus has no timeouts of its own: every call is wrapped in [`tokio::time::timeout`].
//! RTU has no transaction id, and tokio-modbus's RTU client takes a late reply to a timed-out call
//! for the answer to the next one. So after any timeout (or garbled reply, or IO error) the client
//! drops its tokio-modbus context, and before the next call drains the stream until it stays quiet
//! for one timeout and attaches a fresh context. The stream is held in a [`SharedStream`], so the
//! client gets it back from tokio-modbus without reopening it.

use std::fmt;
use std::io;
use std::sync::Arc;
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite};
use tokio_modbus::client::{Client, Context, rtu, tcp};
use tokio_modbus::{ExceptionCode, Request, Response, Slave};

use super::link::{SharedStream, drain};
use super::settings::{LinkSettings, MAX_READ_REGISTERS, MAX_WRITE_REGISTERS, Protocol, Timing};
use super::{ExchangeCounts, ExchangeSizes, Plc, PlcError, PlcMode, Refusal};
use crate::contract::DT_LAST;
use crate::gateway::{Address, Area};

/// Coil of relay R0 (PLC.md §2: coil 2048 + 16 w + b = R w.b).
pub const RELAY_COIL_BASE: u16 = 2048;
/// Highest relay number: R999F.
const RELAY_MAX: u16 = 999 * 16 + 15;
/// Coils or inputs one read (01, 02) asks for at most (Modbus spec).
const MAX_READ_BITS: u16 = 2000;

/// The framing on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModbusFraming {
    /// Modbus RTU (binary, CRC; no transaction id).
    Rtu,
    /// Modbus TCP (MBAP header with transaction id).
    Tcp,
}

/// How the client talks: framing, unit id, timeout, retries, the RUN relay and request sizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModbusOptions {
    /// RTU or TCP.
    pub framing: ModbusFraming,
    /// The PLC's unit id (1..=247).
    pub unit: u8,
    /// The margin one call may take beyond its wire time and two scans.
    pub timeout: Duration,
    /// One character's time on a serial line (`None`: a network link or a test stream).
    pub char_time: Option<Duration>,
    /// The PLC's longest scan.
    pub scan_time: Duration,
    /// Further attempts after a timeout or a garbled reply.
    pub retries: u8,
    /// Relay whose state is the RUN flag (default R9020, \[unverified\]).
    pub mode_relay: u16,
    /// Registers one read (03) asks for at most: 1..=[`MAX_READ_REGISTERS`] (taken as the
    /// nearest bound when outside).
    pub max_read_registers: u16,
    /// Registers one write (16) carries at most: 1..=[`MAX_WRITE_REGISTERS`] (taken as the
    /// nearest bound when outside). Some peers take fewer than the spec's 123.
    pub max_write_registers: u16,
}

impl ModbusOptions {
    /// Options for a network link: a 300 ms margin, a 10 ms scan, 2 retries, R9020 as the RUN
    /// relay and the Modbus spec's request sizes.
    #[must_use]
    pub fn new(framing: ModbusFraming, unit: u8) -> Self {
        let timing = Timing::network(Duration::from_millis(300));
        Self {
            framing,
            unit,
            timeout: timing.margin,
            char_time: timing.char_time,
            scan_time: timing.scan_time,
            retries: 2,
            mode_relay: super::settings::R9020,
            max_read_registers: MAX_READ_REGISTERS,
            max_write_registers: MAX_WRITE_REGISTERS,
        }
    }

    /// The options a link's settings describe.
    #[must_use]
    pub fn from_settings(settings: &LinkSettings) -> Self {
        let framing = match settings.protocol {
            Protocol::ModbusTcp => ModbusFraming::Tcp,
            Protocol::ModbusRtu | Protocol::Mewtocol => ModbusFraming::Rtu,
        };
        let timing = settings.timing();
        Self {
            framing,
            unit: settings.station,
            timeout: timing.margin,
            char_time: timing.char_time,
            scan_time: timing.scan_time,
            retries: settings.retries,
            mode_relay: settings.mode_relay,
            max_read_registers: settings.modbus_max_read,
            max_write_registers: settings.modbus_max_write,
        }
    }

    /// The exchange timing.
    #[must_use]
    pub fn timing(&self) -> Timing {
        Timing {
            char_time: self.char_time,
            scan_time: self.scan_time,
            margin: self.timeout,
        }
    }

    /// Registers one read asks for at most, within the spec's bounds.
    fn read_size(&self) -> u16 {
        self.max_read_registers.clamp(1, MAX_READ_REGISTERS)
    }

    /// Registers one write carries at most, within the spec's bounds.
    fn write_size(&self) -> u16 {
        self.max_write_registers.clamp(1, MAX_WRITE_REGISTERS)
    }
}

/// The Modbus spec's meaning of exception `code`.
#[must_use]
pub fn exception_meaning(code: u8) -> &'static str {
    match code {
        0x01 => "illegal function",
        0x02 => "illegal data address",
        0x03 => "illegal data value",
        0x04 => "server device failure",
        0x05 => "acknowledge",
        0x06 => "server device busy",
        0x08 => "memory parity error",
        0x0A => "gateway path unavailable",
        0x0B => "gateway target device failed to respond",
        _ => "unknown exception code",
    }
}

/// Why one call failed.
#[derive(Debug)]
enum CallFailure {
    Exception(ExceptionCode),
    Garbled(String),
    Timeout,
    Link(io::Error),
}

impl CallFailure {
    fn is_retryable(&self) -> bool {
        matches!(self, Self::Garbled(_) | Self::Timeout)
    }

    fn into_error(self, operation: &str, timeout: Duration) -> PlcError {
        let operation = operation.to_owned();
        match self {
            Self::Exception(code) => {
                let code = u8::from(code);
                PlcError::Refused {
                    operation,
                    refusal: Refusal::Modbus {
                        code,
                        meaning: exception_meaning(code),
                    },
                }
            }
            Self::Garbled(detail) => PlcError::BadReply { operation, detail },
            Self::Timeout => PlcError::Timeout {
                operation,
                timeout_ms: timeout.as_millis() as u64,
            },
            Self::Link(source) => PlcError::Link { operation, source },
        }
    }
}

impl fmt::Display for CallFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Exception(code) => write!(f, "exception {:#04x}", u8::from(*code)),
            Self::Garbled(detail) => write!(f, "garbled reply: {detail}"),
            Self::Timeout => write!(f, "no reply in time"),
            Self::Link(e) => write!(f, "link failed: {e}"),
        }
    }
}

/// A Modbus master over the stream `T`.
pub struct ModbusClient<T> {
    stream: SharedStream<T>,
    context: Option<Context>,
    options: ModbusOptions,
    reattached: usize,
    counts: Arc<ExchangeCounts>,
}

impl<T: fmt::Debug> fmt::Debug for ModbusClient<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ModbusClient")
            .field("stream", &self.stream)
            .field("attached", &self.context.is_some())
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

fn attach<T>(stream: &SharedStream<T>, options: &ModbusOptions) -> Context
where
    T: AsyncRead + AsyncWrite + Unpin + Send + fmt::Debug + 'static,
{
    let slave = Slave(options.unit);
    match options.framing {
        ModbusFraming::Rtu => rtu::attach_slave(stream.clone(), slave),
        ModbusFraming::Tcp => tcp::attach_slave(stream.clone(), slave),
    }
}

impl<T: AsyncRead + AsyncWrite + Unpin + Send + fmt::Debug + 'static> ModbusClient<T> {
    /// A client over `stream`, attached at once.
    pub fn new(stream: T, options: ModbusOptions) -> Self {
        let stream = SharedStream::new(stream);
        let context = Some(attach(&stream, &options));
        Self {
            stream,
            context,
            options,
            reattached: 0,
            counts: Arc::default(),
        }
    }

    /// Counts this client's retries and timeouts into `counts` (shared with the link's owner).
    pub fn set_exchange_counts(&mut self, counts: Arc<ExchangeCounts>) {
        self.counts = counts;
    }

    /// How often the client has drained its stream and attached a fresh context.
    #[must_use]
    pub fn reattach_count(&self) -> usize {
        self.reattached
    }

    /// The attached context; after a failure, drain the stream and attach a fresh one first.
    async fn context(&mut self) -> Result<&mut Context, CallFailure> {
        if self.context.is_none() {
            let mut handle = self.stream.clone();
            drain(&mut handle, self.options.timing().quiet())
                .await
                .map_err(CallFailure::Link)?;
            self.reattached += 1;
        }
        let (stream, options) = (&self.stream, &self.options);
        Ok(self.context.get_or_insert_with(|| attach(stream, options)))
    }

    async fn attempt(&mut self, request: Request<'_>) -> Result<Response, CallFailure> {
        let timeout = self.call_timeout(&request);
        let context = self.context().await?;
        let outcome = match tokio::time::timeout(timeout, context.call(request)).await {
            Err(_) => {
                self.counts.timed_out();
                Err(CallFailure::Timeout)
            }
            Ok(Err(tokio_modbus::Error::Transport(e)))
                if e.kind() == io::ErrorKind::InvalidData =>
            {
                Err(CallFailure::Garbled(e.to_string()))
            }
            Ok(Err(tokio_modbus::Error::Transport(e))) => Err(CallFailure::Link(e)),
            Ok(Err(tokio_modbus::Error::Protocol(e))) => Err(CallFailure::Garbled(e.to_string())),
            Ok(Ok(Err(code))) => Err(CallFailure::Exception(code)),
            Ok(Ok(Ok(response))) => Ok(response),
        };
        if matches!(
            outcome,
            Err(CallFailure::Timeout | CallFailure::Garbled(_) | CallFailure::Link(_))
        ) {
            self.context = None;
        }
        outcome
    }

    /// The longest `request` may take: its RTU frames on the wire (with their silent intervals),
    /// two scans, the margin. (Over TCP there is no wire time.)
    fn call_timeout(&self, request: &Request<'_>) -> Duration {
        let (out, back) = rtu_bytes(request);
        // 3.5 characters of silence end each RTU frame.
        self.options.timing().exchange(out + 4, back + 4)
    }

    /// One request with retries; exceptions and IO errors are never retried.
    async fn call(&mut self, operation: &str, request: Request<'_>) -> Result<Response, PlcError> {
        self.call_tries(operation, request, self.options.retries)
            .await
    }

    /// One request, tried again up to `retries` times after a timeout or a garbled reply.
    async fn call_tries(
        &mut self,
        operation: &str,
        request: Request<'_>,
        retries: u8,
    ) -> Result<Response, PlcError> {
        let mut attempt = 0;
        loop {
            let failure = match self.attempt(request.clone()).await {
                Ok(response) => return Ok(response),
                Err(failure) => failure,
            };
            if !failure.is_retryable() || attempt >= retries {
                let timeout = self.call_timeout(&request);
                return Err(failure.into_error(operation, timeout));
            }
            attempt += 1;
            self.counts.retried();
            tracing::warn!(operation, attempt, %failure, "retrying a Modbus call");
        }
    }

    async fn read_chunk(&mut self, start: u16, count: u16) -> Result<Vec<u16>, PlcError> {
        let operation = dt_operation("read", start, usize::from(count));
        let request = Request::ReadHoldingRegisters(start, count);
        match self.call(&operation, request).await? {
            Response::ReadHoldingRegisters(words) if words.len() == usize::from(count) => Ok(words),
            other => Err(unexpected(&operation, &other)),
        }
    }

    async fn write_chunk(
        &mut self,
        start: u16,
        words: &[u16],
        retries: u8,
    ) -> Result<(), PlcError> {
        let operation = dt_operation("write", start, words.len());
        let request = Request::WriteMultipleRegisters(start, words.into());
        match self.call_tries(&operation, request, retries).await? {
            Response::WriteMultipleRegisters(..) => Ok(()),
            other => Err(unexpected(&operation, &other)),
        }
    }
}

impl<T: AsyncRead + AsyncWrite + Unpin + Send + fmt::Debug + 'static> Plc for ModbusClient<T> {
    async fn read_words(&mut self, start: u16, count: u16) -> Result<Vec<u16>, PlcError> {
        check_dt(start, usize::from(count), "read")?;
        let mut words = Vec::with_capacity(usize::from(count));
        let most = self.options.read_size();
        for offset in (0..count).step_by(usize::from(most)) {
            let len = (count - offset).min(most);
            words.extend(self.read_chunk(start + offset, len).await?);
        }
        Ok(words)
    }

    async fn write_words(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        check_dt(start, words.len(), "write")?;
        let most = usize::from(self.options.write_size());
        for (index, chunk) in words.chunks(most).enumerate() {
            let offset = (index * most) as u16;
            self.write_chunk(start + offset, chunk, self.options.retries)
                .await?;
        }
        Ok(())
    }

    async fn write_words_once(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        check_dt(start, words.len(), "write")?;
        let most = self.options.write_size();
        if words.len() > usize::from(most) {
            return Err(PlcError::InvalidRequest {
                operation: dt_operation("write", start, words.len()),
                detail: format!("a single write carries at most {most} registers"),
            });
        }
        self.write_chunk(start, words, 0).await
    }

    async fn read_bits(
        &mut self,
        area: Area,
        start: u32,
        count: u16,
    ) -> Result<Vec<bool>, PlcError> {
        let mut bits = Vec::with_capacity(usize::from(count));
        let mut at = start;
        let end = start + u32::from(count);
        while at < end {
            let n = (end - at).min(u32::from(MAX_READ_BITS)) as u16;
            let operation = bits_operation("read", area, at, n);
            let first = bit_address(area, at, n, &operation)?;
            let request = match area {
                Area::X => Request::ReadDiscreteInputs(first, n),
                _ => Request::ReadCoils(first, n),
            };
            match self.call(&operation, request).await? {
                Response::ReadCoils(read) | Response::ReadDiscreteInputs(read)
                    if read.len() >= usize::from(n) =>
                {
                    bits.extend(&read[..usize::from(n)]);
                }
                other => return Err(unexpected(&operation, &other)),
            }
            at += u32::from(n);
        }
        Ok(bits)
    }

    async fn write_bit(&mut self, area: Area, bit: u32, on: bool) -> Result<(), PlcError> {
        let operation = format!("write {} = {}", Address { area, index: bit }, u8::from(on));
        if area == Area::X {
            return Err(PlcError::InvalidRequest {
                operation,
                detail: "X inputs cannot be written".to_owned(),
            });
        }
        let coil = bit_address(area, bit, 1, &operation)?;
        match self
            .call(&operation, Request::WriteSingleCoil(coil, on))
            .await?
        {
            Response::WriteSingleCoil(..) => Ok(()),
            other => Err(unexpected(&operation, &other)),
        }
    }

    fn exchange_sizes(&self) -> ExchangeSizes {
        ExchangeSizes {
            read_words: self.options.read_size(),
            write_words: self.options.write_size(),
            read_bits: MAX_READ_BITS,
        }
    }

    async fn mode(&mut self) -> Result<PlcMode, PlcError> {
        let running = self.read_relay(self.options.mode_relay).await?;
        Ok(if running { PlcMode::Run } else { PlcMode::Prog })
    }
}

/// Bytes of an RTU request and of its reply (unit, function, data, CRC).
fn rtu_bytes(request: &Request<'_>) -> (usize, usize) {
    match request {
        Request::ReadHoldingRegisters(_, n) => (8, 5 + 2 * usize::from(*n)),
        Request::WriteMultipleRegisters(_, words) => (9 + 2 * words.len(), 8),
        Request::ReadCoils(_, n) => (8, 5 + usize::from(*n).div_ceil(8)),
        _ => (8, 8),
    }
}

fn dt_operation(verb: &str, start: u16, len: usize) -> String {
    format!("{verb} DT{start}..=DT{}", usize::from(start) + len - 1)
}

/// Refuses a DT range that runs past DT32764 (PLC.md §2: DT n = holding register n, n <= 32764).
fn check_dt(start: u16, len: usize, verb: &str) -> Result<(), PlcError> {
    let last = usize::from(start) + len.max(1) - 1;
    if last <= usize::from(DT_LAST) {
        return Ok(());
    }
    Err(PlcError::InvalidRequest {
        operation: dt_operation(verb, start, len.max(1)),
        detail: format!("DT{last} is past the FP-X DT area's end DT{DT_LAST}"),
    })
}

/// The first coil (Y, R) or discrete input (X) of `count` bits of `area` from `bit` (PLC.md §2:
/// coil 16 w + b = Y w.b below 2048, coil 2048 + 16 w + b = R w.b, input 16 w + b = X w.b).
fn bit_address(area: Area, bit: u32, count: u16, operation: &str) -> Result<u16, PlcError> {
    let last = bit + u32::from(count.max(1)) - 1;
    let (base, limit) = match area {
        Area::X => (0, u32::from(u16::MAX)),
        Area::Y => (0, u32::from(RELAY_COIL_BASE) - 1),
        Area::R => (u32::from(RELAY_COIL_BASE), u32::from(RELAY_MAX)),
        Area::Dt => return Err(super::not_bits(operation.to_owned())),
    };
    if last > limit || base + last > u32::from(u16::MAX) {
        return Err(PlcError::InvalidRequest {
            operation: operation.to_owned(),
            detail: format!(
                "{} is past {}",
                Address { area, index: last },
                Address { area, index: limit }
            ),
        });
    }
    Ok((base + bit) as u16)
}

fn bits_operation(verb: &str, area: Area, start: u32, count: u16) -> String {
    let last = start + u32::from(count.max(1)) - 1;
    format!(
        "{verb} {}..={}",
        Address { area, index: start },
        Address { area, index: last }
    )
}

fn unexpected(operation: &str, response: &Response) -> PlcError {
    PlcError::BadReply {
        operation: operation.to_owned(),
        detail: format!("unexpected response {response:?}"),
    }
}

#[cfg(test)]
#[path = "modbus_tests.rs"]
mod tests;
