//! IO. The Modbus client: [`Plc`] through tokio-modbus (never Modbus by hand), RTU or TCP, over
//! any byte stream.
//!
//! ```text
//!  DT n      <-> holding register n        read 03 <= 125 registers, write 16 <= 123 a request
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
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite};
use tokio_modbus::client::{Client, Context, rtu, tcp};
use tokio_modbus::{ExceptionCode, Request, Response, Slave};

use super::link::{SharedStream, drain};
use super::mewtocol::relay_name;
use super::settings::{LinkSettings, Protocol};
use super::{Plc, PlcError, PlcMode, Refusal};
use crate::contract::DT_LAST;

/// Coil of relay R0 (PLC.md §2: coil 2048 + 16 w + b = R w.b).
pub const RELAY_COIL_BASE: u16 = 2048;
/// Registers one read (function 03) asks for at most (Modbus spec; FP-X maxima \[unverified\]).
const MAX_READ_REGISTERS: usize = 125;
/// Registers one write (function 16) carries at most.
const MAX_WRITE_REGISTERS: usize = 123;
/// Highest relay number: R999F.
const RELAY_MAX: u16 = 999 * 16 + 15;

/// The framing on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModbusFraming {
    /// Modbus RTU (binary, CRC; no transaction id).
    Rtu,
    /// Modbus TCP (MBAP header with transaction id).
    Tcp,
}

/// How the client talks: framing, unit id, timeout, retries and the RUN relay.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModbusOptions {
    /// RTU or TCP.
    pub framing: ModbusFraming,
    /// The PLC's unit id (1..=247).
    pub unit: u8,
    /// Longest wait for one call.
    pub timeout: Duration,
    /// Further attempts after a timeout or a garbled reply.
    pub retries: u8,
    /// Relay whose state is the RUN flag (default R9020, \[unverified\]).
    pub mode_relay: u16,
}

impl ModbusOptions {
    /// Options with a 300 ms timeout, 2 retries and R9020 as the RUN relay.
    #[must_use]
    pub fn new(framing: ModbusFraming, unit: u8) -> Self {
        Self {
            framing,
            unit,
            timeout: Duration::from_millis(300),
            retries: 2,
            mode_relay: super::settings::R9020,
        }
    }

    /// The options a link's settings describe.
    #[must_use]
    pub fn from_settings(settings: &LinkSettings) -> Self {
        let framing = match settings.protocol {
            Protocol::ModbusTcp => ModbusFraming::Tcp,
            Protocol::ModbusRtu | Protocol::Mewtocol => ModbusFraming::Rtu,
        };
        Self {
            framing,
            unit: settings.station,
            timeout: settings.timeout,
            retries: settings.retries,
            mode_relay: settings.mode_relay,
        }
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
enum Failure {
    Exception(ExceptionCode),
    Garbled(String),
    Timeout,
    Link(io::Error),
}

impl Failure {
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

impl fmt::Display for Failure {
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
        }
    }

    /// How often the client has drained its stream and attached a fresh context.
    #[must_use]
    pub fn reattach_count(&self) -> usize {
        self.reattached
    }

    /// The attached context; after a failure, drain the stream and attach a fresh one first.
    async fn context(&mut self) -> Result<&mut Context, Failure> {
        if self.context.is_none() {
            let mut handle = self.stream.clone();
            drain(&mut handle, self.options.timeout)
                .await
                .map_err(Failure::Link)?;
            self.reattached += 1;
        }
        let (stream, options) = (&self.stream, &self.options);
        Ok(self.context.get_or_insert_with(|| attach(stream, options)))
    }

    async fn attempt(&mut self, request: Request<'_>) -> Result<Response, Failure> {
        let timeout = self.options.timeout;
        let context = self.context().await?;
        let outcome = match tokio::time::timeout(timeout, context.call(request)).await {
            Err(_) => Err(Failure::Timeout),
            Ok(Err(tokio_modbus::Error::Transport(e)))
                if e.kind() == io::ErrorKind::InvalidData =>
            {
                Err(Failure::Garbled(e.to_string()))
            }
            Ok(Err(tokio_modbus::Error::Transport(e))) => Err(Failure::Link(e)),
            Ok(Err(tokio_modbus::Error::Protocol(e))) => Err(Failure::Garbled(e.to_string())),
            Ok(Ok(Err(code))) => Err(Failure::Exception(code)),
            Ok(Ok(Ok(response))) => Ok(response),
        };
        if matches!(
            outcome,
            Err(Failure::Timeout | Failure::Garbled(_) | Failure::Link(_))
        ) {
            self.context = None;
        }
        outcome
    }

    /// One request with retries; exceptions and IO errors are never retried.
    async fn call(&mut self, operation: &str, request: Request<'_>) -> Result<Response, PlcError> {
        let mut attempt = 0;
        loop {
            let failure = match self.attempt(request.clone()).await {
                Ok(response) => return Ok(response),
                Err(failure) => failure,
            };
            if !failure.is_retryable() || attempt >= self.options.retries {
                return Err(failure.into_error(operation, self.options.timeout));
            }
            attempt += 1;
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

    async fn write_chunk(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        let operation = dt_operation("write", start, words.len());
        let request = Request::WriteMultipleRegisters(start, words.into());
        match self.call(&operation, request).await? {
            Response::WriteMultipleRegisters(..) => Ok(()),
            other => Err(unexpected(&operation, &other)),
        }
    }
}

impl<T: AsyncRead + AsyncWrite + Unpin + Send + fmt::Debug + 'static> Plc for ModbusClient<T> {
    async fn read_words(&mut self, start: u16, count: u16) -> Result<Vec<u16>, PlcError> {
        check_dt(start, usize::from(count), "read")?;
        let mut words = Vec::with_capacity(usize::from(count));
        for offset in (0..count).step_by(MAX_READ_REGISTERS) {
            let len = (count - offset).min(MAX_READ_REGISTERS as u16);
            words.extend(self.read_chunk(start + offset, len).await?);
        }
        Ok(words)
    }

    async fn write_words(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        check_dt(start, words.len(), "write")?;
        for (index, chunk) in words.chunks(MAX_WRITE_REGISTERS).enumerate() {
            let offset = (index * MAX_WRITE_REGISTERS) as u16;
            self.write_chunk(start + offset, chunk).await?;
        }
        Ok(())
    }

    async fn read_relay(&mut self, relay: u16) -> Result<bool, PlcError> {
        let operation = format!("read relay {}", relay_name(relay));
        let coil = relay_coil(relay, &operation)?;
        match self.call(&operation, Request::ReadCoils(coil, 1)).await? {
            Response::ReadCoils(bits) if !bits.is_empty() => Ok(bits[0]),
            other => Err(unexpected(&operation, &other)),
        }
    }

    async fn write_relay(&mut self, relay: u16, on: bool) -> Result<(), PlcError> {
        let operation = format!("write relay {} = {}", relay_name(relay), u8::from(on));
        let coil = relay_coil(relay, &operation)?;
        match self
            .call(&operation, Request::WriteSingleCoil(coil, on))
            .await?
        {
            Response::WriteSingleCoil(..) => Ok(()),
            other => Err(unexpected(&operation, &other)),
        }
    }

    async fn mode(&mut self) -> Result<PlcMode, PlcError> {
        let running = self.read_relay(self.options.mode_relay).await?;
        Ok(if running { PlcMode::Run } else { PlcMode::Prog })
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

fn relay_coil(relay: u16, operation: &str) -> Result<u16, PlcError> {
    if relay > RELAY_MAX {
        return Err(PlcError::InvalidRequest {
            operation: operation.to_owned(),
            detail: format!("relay number {relay} is past R999F ({RELAY_MAX})"),
        });
    }
    Ok(RELAY_COIL_BASE + relay)
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
