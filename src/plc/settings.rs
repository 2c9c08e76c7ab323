//! PURE. How to reach one robot's PLC: protocol, transport, station, timeouts and the register
//! contract's layout, as the config's `[robots.NAME.plc]` section describes them (checked there).

use std::time::Duration;

use crate::contract::Layout;

/// Relay R9020 as a relay number (word 902, bit 0): the RUN-mode special relay of the FP series.
/// Its Modbus coil on an FP-X is \[unverified\] (PLC.md §2); [`LinkSettings::mode_relay`] makes it
/// configurable.
pub const R9020: u16 = 902 * 16;

/// Which protocol the PLC's port speaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Protocol {
    /// MEWTOCOL-COM (PLC.md §1).
    Mewtocol,
    /// Modbus RTU (PLC.md §2).
    ModbusRtu,
    /// Modbus TCP (PLC.md §2; on FP-X \[unverified\]).
    ModbusTcp,
}

/// Serial parity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parity {
    /// No parity bit.
    None,
    /// Odd parity (the FP-X default in practice, PLC.md §1).
    Odd,
    /// Even parity.
    Even,
}

/// A serial port's settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SerialSettings {
    /// Device path (`/dev/ttyUSB0`).
    pub path: String,
    /// Baud rate.
    pub baud: u32,
    /// Data bits, 7 or 8.
    pub data_bits: u8,
    /// Parity.
    pub parity: Parity,
    /// Stop bits, 1 or 2.
    pub stop_bits: u8,
}

/// A TCP peer's settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TcpSettings {
    /// `host:port` (MEWTOCOL has no fixed port; 9094 is common \[practice\]).
    pub address: String,
    /// Longest wait for the connection.
    pub connect_timeout: Duration,
}

/// Where the PLC's bytes travel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Transport {
    /// A serial port.
    Serial(SerialSettings),
    /// A TCP connection.
    Tcp(TcpSettings),
}

/// The MEWTOCOL-COM header to send with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum HeaderChoice {
    /// Probe `<` once with a 1-word read; fall back to `%` on no reply or an error.
    #[default]
    Auto,
    /// `%`: frames up to 118 characters.
    Percent,
    /// `<`: frames up to 2048 characters (accepted by FP-X: \[unverified\]).
    Angle,
}

/// Everything needed to open and talk to one PLC.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LinkSettings {
    /// The protocol.
    pub protocol: Protocol,
    /// The transport.
    pub transport: Transport,
    /// MEWTOCOL station (1..=99, or 238 = `EE`) or Modbus unit id (1..=247).
    pub station: u8,
    /// MEWTOCOL header (ignored by Modbus).
    pub header: HeaderChoice,
    /// Longest wait for one exchange's reply.
    pub timeout: Duration,
    /// How often a failed exchange is tried again (timeouts, garbled replies, BCC/format errors).
    pub retries: u8,
    /// Longest the contract's heartbeat may stand still before the PLC program counts as gone.
    pub heartbeat_timeout: Duration,
    /// Relay read as the RUN flag over Modbus (default [`R9020`], \[unverified\]).
    pub mode_relay: u16,
    /// Where the register contract sits in DT memory.
    pub layout: Layout,
}

impl LinkSettings {
    /// Settings with every default, for `protocol` over `transport`.
    #[must_use]
    pub fn new(protocol: Protocol, transport: Transport) -> Self {
        Self {
            protocol,
            transport,
            station: 1,
            header: HeaderChoice::Auto,
            timeout: Duration::from_millis(300),
            retries: 2,
            heartbeat_timeout: Duration::from_millis(500),
            mode_relay: R9020,
            layout: Layout::default(),
        }
    }
}
