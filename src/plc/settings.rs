//! PURE. How to reach one robot's PLC: protocol, transport, station, timeouts and the register
//! contract's layout, as the config's `[robots.NAME.plc]` section describes them (checked there).

use std::time::Duration;

use serde::Deserialize;

use crate::contract::Layout;

/// Registers one read (function 03) may ask for (Modbus Application Protocol v1.1b3, §6.3; the
/// FP-X's own maximum is \[unverified\]).
pub const MAX_READ_REGISTERS: u16 = 125;
/// Registers one write (function 16) may carry (Modbus Application Protocol v1.1b3, §6.12; the
/// FP-X's own maximum is \[unverified\]).
pub const MAX_WRITE_REGISTERS: u16 = 123;

/// Relay R9020 as a relay number (word 902, bit 0): the RUN-mode special relay of the FP series.
/// Its Modbus coil on an FP-X is \[unverified\] (PLC.md §2); [`LinkSettings::mode_relay`] makes it
/// configurable.
pub const R9020: u16 = 902 * 16;

/// Which protocol the PLC's port speaks (`plc.protocol` in the config, kebab-case).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Protocol {
    /// MEWTOCOL-COM (PLC.md §1).
    Mewtocol,
    /// Modbus RTU (PLC.md §2).
    ModbusRtu,
    /// Modbus TCP (PLC.md §2; on FP-X \[unverified\]).
    ModbusTcp,
}

/// Serial parity (`plc.serial.parity` in the config, kebab-case).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
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

impl SerialSettings {
    /// Bits one character takes on the line: start, data, parity, stop.
    #[must_use]
    pub fn bits_per_char(&self) -> u32 {
        let parity = u32::from(self.parity != Parity::None);
        1 + u32::from(self.data_bits) + parity + u32::from(self.stop_bits)
    }

    /// The time one character takes at the baud rate.
    #[must_use]
    pub fn char_time(&self) -> Duration {
        Duration::from_secs_f64(f64::from(self.bits_per_char()) / f64::from(self.baud.max(1)))
    }
}

/// How long one exchange may take: the wire time of the request and the reply (on a serial
/// line), the PLC's scan twice (a request that arrives just after a scan began is answered at
/// the end of the next), and a margin.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// One character's time on the line (`None`: a network link, no wire time counted).
    pub char_time: Option<Duration>,
    /// The PLC's longest scan.
    pub scan_time: Duration,
    /// Added to every exchange (the configured `timeout`).
    pub margin: Duration,
}

impl Timing {
    /// A network link's timing: no wire time, a 10 ms scan, `margin`.
    #[must_use]
    pub fn network(margin: Duration) -> Self {
        Self {
            char_time: None,
            scan_time: Duration::from_millis(10),
            margin,
        }
    }

    /// The wire time of `chars` characters.
    #[must_use]
    pub fn wire(&self, chars: usize) -> Duration {
        self.char_time.map_or(Duration::ZERO, |c| {
            c * u32::try_from(chars).unwrap_or(u32::MAX)
        })
    }

    /// The longest an exchange of `request` and `reply` characters may take.
    #[must_use]
    pub fn exchange(&self, request: usize, reply: usize) -> Duration {
        self.wire(request + reply) + self.scan_time * 2 + self.margin
    }

    /// How long a line must stay quiet before the next request, after a failed exchange: a
    /// late reply still on its way is drained first.
    #[must_use]
    pub fn quiet(&self) -> Duration {
        self.margin
    }
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
    /// MEWTOCOL under `%`: read more words than one frame holds with one `RD` whose reply comes
    /// in several frames (PLC.md §1, \[practice\]), falling back to one frame a read for the
    /// rest of the connection the first time such a read is not answered (ignored by Modbus).
    pub multi_frame_reads: bool,
    /// Read back every word an upload writes (tables, directories, command block) and compare
    /// before a start (CONTRACT.md: configurable, on by default). Off, a write is trusted on the
    /// PLC's acknowledgement alone: the PLC checks each frame's BCC (MEWTOCOL) or CRC (Modbus
    /// RTU) before it writes, and Modbus TCP has TCP's checksum.
    pub read_back: bool,
    /// The margin every exchange may take beyond its wire time and two PLC scans (see
    /// [`Timing`]).
    pub timeout: Duration,
    /// How often a failed exchange is tried again (timeouts, garbled replies, BCC/format errors).
    pub retries: u8,
    /// Longest the contract's heartbeat may stand still before the PLC program counts as gone.
    pub heartbeat_timeout: Duration,
    /// Relay read as the RUN flag over Modbus (default [`R9020`], \[unverified\]).
    pub mode_relay: u16,
    /// Registers one Modbus read (03) asks for at most (default and limit 125; the FP-X's own
    /// limit is \[unverified\]).
    pub modbus_max_read: u16,
    /// Registers one Modbus write (16) carries at most (default and limit 123; the FP-X's own
    /// limit is \[unverified\], and some peers take at most 100).
    pub modbus_max_write: u16,
    /// Where the register contract sits in DT memory.
    pub layout: Layout,
    /// The PLC's longest scan: allowed on top of the wire time of every exchange (a PLC answers
    /// at the end of a scan).
    pub scan_time: Duration,
    /// The count each joint is set to at its home position (`linterpd home`), per joint.
    pub home_counts: [i64; crate::kinematics::JOINTS],
}

impl LinkSettings {
    /// The exchange timing these settings imply.
    #[must_use]
    pub fn timing(&self) -> Timing {
        Timing {
            char_time: match &self.transport {
                Transport::Serial(serial) => Some(serial.char_time()),
                Transport::Tcp(_) => None,
            },
            scan_time: self.scan_time,
            margin: self.timeout,
        }
    }

    /// Settings with every default, for `protocol` over `transport`.
    #[must_use]
    pub fn new(protocol: Protocol, transport: Transport) -> Self {
        Self {
            protocol,
            transport,
            station: 1,
            header: HeaderChoice::Auto,
            multi_frame_reads: true,
            read_back: true,
            timeout: Duration::from_millis(300),
            retries: 2,
            heartbeat_timeout: Duration::from_millis(500),
            mode_relay: R9020,
            modbus_max_read: MAX_READ_REGISTERS,
            modbus_max_write: MAX_WRITE_REGISTERS,
            layout: Layout::default(),
            scan_time: Duration::from_millis(10),
            home_counts: [0; crate::kinematics::JOINTS],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exchange_at_19200_baud_takes_its_wire_time_two_scans_and_the_margin() {
        let serial = SerialSettings {
            path: "/dev/ttyUSB0".into(),
            baud: 19_200,
            data_bits: 8,
            parity: Parity::Odd,
            stop_bits: 1,
        };
        assert_eq!(serial.bits_per_char(), 11);
        let mut link = LinkSettings::new(Protocol::Mewtocol, Transport::Serial(serial));
        link.timeout = Duration::from_millis(300);
        let timing = link.timing();
        // A 340-word `<` read: 20 characters out, 6 + 3 + 1360 back.
        let t = timing.exchange(20, 1_369);
        let wire_s = 1_389.0 * 11.0 / 19_200.0;
        assert!(
            (t.as_secs_f64() - (wire_s + 0.020 + 0.300)).abs() < 1e-6,
            "{t:?}"
        );
        assert!(t > Duration::from_millis(1_100), "{t:?}");
        let tcp = LinkSettings::new(
            Protocol::Mewtocol,
            Transport::Tcp(TcpSettings {
                address: "h:1".into(),
                connect_timeout: Duration::from_secs(1),
            }),
        );
        assert_eq!(tcp.timing().exchange(20, 1_369), Duration::from_millis(320));
    }
}
