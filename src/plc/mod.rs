//! IO. Talking to a PLC: one [`Plc`] trait over the operations linterpd needs (DT words, R relays,
//! the PLC's mode), implemented by the MEWTOCOL-COM and Modbus clients over any byte stream,
//! and the register contract's flow on top of it.
//!
//! # Layout
//! ```text
//! settings.rs  LinkSettings: protocol, transport, station, timeouts, contract layout (pure data)
//! link.rs      opening a serial port or a TCP stream; SharedStream; drain
//! mewtocol.rs  MewtocolClient: MEWTOCOL-COM over any byte stream
//! modbus.rs    ModbusClient: Modbus RTU / TCP through tokio-modbus, reattached after timeouts
//! any.rs       AnyPlc and connect(): the client a config's [robots.NAME.plc] section names
//! ```

mod any;
mod counts;
mod link;
mod mewtocol;
mod modbus;
mod settings;

use std::future::Future;

pub mod exchange;

use thiserror::Error;

use crate::gateway::Area;

pub use any::{AnyPlc, connect};
pub use counts::ExchangeCounts;
pub use link::{
    BoxedLink, ByteStream, ReadFilter, ReadFiltered, SharedStream, drain, open_hint, open_serial,
    open_tcp,
};
pub use mewtocol::{EXCHANGE_BUDGET, MewtocolClient, MewtocolOptions, STATION_ANY, relay_name};
pub use modbus::{ModbusClient, ModbusFraming, ModbusOptions, RELAY_COIL_BASE, exception_meaning};
pub use settings::{
    HeaderChoice, LinkSettings, MAX_READ_REGISTERS, MAX_WRITE_REGISTERS, Parity, Protocol, R9020,
    SerialSettings, TcpSettings, Timing, Transport,
};

/// How much one exchange carries: the most DT words one read and one write, and the most bits
/// one read of X, Y or R.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExchangeSizes {
    /// DT words one read carries.
    pub read_words: u16,
    /// DT words one write carries.
    pub write_words: u16,
    /// Bits one read carries.
    pub read_bits: u16,
}

pub use crate::contract::PlcMode;

/// Why the PLC answered "no": a different thing from a failed link.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum Refusal {
    /// A MEWTOCOL-COM `!` error reply.
    #[error("MEWTOCOL error {code}: {meaning}")]
    Mewtocol {
        /// The two-digit error code.
        code: u8,
        /// Its meaning (PLC.md §1, "Error codes").
        meaning: &'static str,
    },
    /// A Modbus exception response.
    #[error("Modbus exception {code:#04x}: {meaning}")]
    Modbus {
        /// The exception code.
        code: u8,
        /// Its meaning.
        meaning: &'static str,
    },
}

/// A failed PLC operation.
#[derive(Debug, Error)]
pub enum PlcError {
    /// The PLC answered and refused.
    #[error("the PLC refused {operation}: {refusal}")]
    Refused {
        /// What was asked, e.g. `write DT2000..=DT2023`.
        operation: String,
        /// What it said.
        refusal: Refusal,
    },
    /// No (complete) reply in time.
    #[error("no reply to {operation} within {timeout_ms} ms")]
    Timeout {
        /// What was asked.
        operation: String,
        /// The timeout.
        timeout_ms: u64,
    },
    /// The link itself failed (closed, IO error).
    #[error("link failed during {operation}")]
    Link {
        /// What was asked.
        operation: String,
        /// The IO error.
        #[source]
        source: std::io::Error,
    },
    /// A reply that does not answer the request (bad checksum, wrong station, wrong length...).
    #[error("bad reply to {operation}: {detail}")]
    BadReply {
        /// What was asked.
        operation: String,
        /// What was wrong with it.
        detail: String,
    },
    /// A request linterpd must not send (address out of DT, too many words...).
    #[error("invalid request {operation}: {detail}")]
    InvalidRequest {
        /// What was asked.
        operation: String,
        /// Why it is invalid.
        detail: String,
    },
}

impl PlcError {
    /// Whether the link should be considered broken (reconnect before the next exchange).
    #[must_use]
    pub fn is_link_failure(&self) -> bool {
        matches!(
            self,
            Self::Timeout { .. } | Self::Link { .. } | Self::BadReply { .. }
        )
    }
}

/// The operations linterpd needs from a PLC. Implementations chunk requests to their protocol's
/// frame limits, put a timeout on every exchange and retry what is safe to retry.
pub trait Plc: Send {
    /// Reads `count` DT words from `start`.
    fn read_words(
        &mut self,
        start: u16,
        count: u16,
    ) -> impl Future<Output = Result<Vec<u16>, PlcError>> + Send;
    /// Writes `words` to DT from `start`.
    fn write_words(
        &mut self,
        start: u16,
        words: &[u16],
    ) -> impl Future<Output = Result<(), PlcError>> + Send;
    /// Writes a few words (one request) and sends it once: a lost or garbled reply is never
    /// retried, because a repeated write may not be safe (a start command). Any error but
    /// [`PlcError::Refused`] leaves it unknown whether the PLC took it; the caller must learn that
    /// from the PLC.
    fn write_words_once(
        &mut self,
        start: u16,
        words: &[u16],
    ) -> impl Future<Output = Result<(), PlcError>> + Send;
    /// Reads relay R`relay` (`relay` = word * 16 + bit): one bit of R, whatever the link.
    fn read_relay(&mut self, relay: u16) -> impl Future<Output = Result<bool, PlcError>> + Send {
        async move { Ok(self.read_bits(Area::R, u32::from(relay), 1).await?[0]) }
    }
    /// Writes relay R`relay`: one bit of R, whatever the link.
    fn write_relay(
        &mut self,
        relay: u16,
        on: bool,
    ) -> impl Future<Output = Result<(), PlcError>> + Send {
        self.write_bit(Area::R, u32::from(relay), on)
    }
    /// Reads whether the PLC is in RUN or PROG mode.
    fn mode(&mut self) -> impl Future<Output = Result<PlcMode, PlcError>> + Send;
    /// Reads `count` bits of `area` (X, Y or R) from bit `start` (word * 16 + bit).
    fn read_bits(
        &mut self,
        area: Area,
        start: u32,
        count: u16,
    ) -> impl Future<Output = Result<Vec<bool>, PlcError>> + Send;
    /// Writes bit `bit` (word * 16 + bit) of `area` (Y or R).
    fn write_bit(
        &mut self,
        area: Area,
        bit: u32,
        on: bool,
    ) -> impl Future<Output = Result<(), PlcError>> + Send;
    /// How much one exchange carries (to cut a request into single exchanges).
    fn exchange_sizes(&self) -> ExchangeSizes;
}

/// The refusal of a bit request for an area that holds words.
pub(crate) fn not_bits(operation: String) -> PlcError {
    PlcError::InvalidRequest {
        operation,
        detail: "DT holds words, not bits".to_owned(),
    }
}
