//! `[robots.NAME.plc]` -> [`LinkSettings`]: how to reach the robot's PLC.
//!
//! ```toml
//! [robots.press-loader.plc]
//! protocol = "mewtocol"              # "mewtocol" | "modbus-rtu" | "modbus-tcp"
//! serial = { path = "/dev/ttyUSB0", baud = 19200, data_bits = 8, parity = "odd", stop_bits = 1 }
//! # or: tcp = { address = "192.168.1.5:9094", connect_timeout = "2s" }   (exactly one of them)
//! station = 1                        # MEWTOCOL 1..=99 or 238 (EE); Modbus unit 1..=247
//! header = "auto"                    # MEWTOCOL only: "auto" | "percent" | "angle" [unverified]
//! multi_frame_reads = true           # MEWTOCOL only: % reads past one frame in one RD [practice]
//! read_back = true                  # read every upload back and compare before its start
//! timeout = "300ms"                  # margin per exchange, beyond its wire time and 2 scans
//! scan_time = "10ms"                 # the PLC's longest scan
//! retries = 2                        # 0..=10
//! heartbeat_timeout = "500ms"
//! home_counts = [0, 0, 0, 0]         # per joint: the counts `linterpd home` presets
//! mode_relay = "R9020"               # Modbus only: the RUN flag relay [unverified]
//! modbus_max_write = 123             # Modbus only: registers a write carries, 1..=123 [unverified]
//! modbus_max_read = 125              # Modbus only: registers a read asks for, 1..=125 [unverified]
//! [robots.press-loader.plc.contract] # optional; CONTRACT.md defaults
//! status_base = 1000
//! inputs = ["WX0", "WX1", "WR10", "WR11"]   # the words the program copies to status +22..+25
//! ```

use std::ops::Range;
use std::time::Duration;

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{RawContract, RawPlc, RawSerial, RawTcp};
use super::units::parse_duration_s;
use crate::contract::{DT_LAST, INPUT_WORDS, InputWord, Layout};
use crate::kinematics::JOINTS;
use crate::plc::{
    HeaderChoice, LinkSettings, MAX_READ_REGISTERS, MAX_WRITE_REGISTERS, Parity, Protocol,
    STATION_ANY, SerialSettings, TcpSettings, Transport,
};
use crate::robot::Robot;

/// Most retries a link may take.
const MAX_RETRIES: i64 = 10;
/// Highest Modbus unit id.
const MAX_UNIT: i64 = 247;
/// Highest MEWTOCOL station number.
const MAX_STATION: i64 = 99;

/// The link a plc table describes, for `robot`.
pub(super) fn link(
    at: &At,
    raw: &Spanned<RawPlc>,
    robot: &Robot,
) -> Result<LinkSettings, ConfigError> {
    let area_words = robot.area_words;
    let r = raw.get_ref();
    let protocol = r.protocol;
    let transport = transport(at, raw, protocol)?;
    let mut settings = LinkSettings::new(protocol, transport);
    framing(at, r, &mut settings)?;
    patience(at, r, &mut settings)?;
    requests(at, r, &mut settings)?;
    settings.scan_time = positive_duration(
        &at.child("scan_time"),
        r.scan_time.as_ref(),
        settings.scan_time,
    )?;
    if let Some(v) = &r.home_counts {
        settings.home_counts = home_counts(&at.child("home_counts"), v, robot)?;
    }
    settings.layout = layout(&at.child("contract"), r.contract.as_ref(), area_words)?;
    Ok(settings)
}

/// How frames are addressed and read: `station`, `header`, `multi_frame_reads`, `read_back`.
fn framing(at: &At, r: &RawPlc, settings: &mut LinkSettings) -> Result<(), ConfigError> {
    let protocol = settings.protocol;
    if let Some(v) = &r.station {
        settings.station = station(&at.child("station"), v, protocol)?;
    }
    if let Some(v) = &r.header {
        settings.header = header(&at.child("header"), v, protocol)?;
    }
    if let Some(v) = &r.multi_frame_reads {
        if protocol != Protocol::Mewtocol {
            let at = at.child("multi_frame_reads");
            return Err(at.invalid(v, "only MEWTOCOL replies come in frames"));
        }
        settings.multi_frame_reads = *v.get_ref();
    }
    if let Some(v) = &r.read_back {
        settings.read_back = *v.get_ref();
    }
    Ok(())
}

/// How long the link waits and how often it tries: `timeout`, `retries`, `heartbeat_timeout`.
fn patience(at: &At, r: &RawPlc, settings: &mut LinkSettings) -> Result<(), ConfigError> {
    settings.timeout =
        positive_duration(&at.child("timeout"), r.timeout.as_ref(), settings.timeout)?;
    if let Some(v) = &r.retries {
        settings.retries = at.child("retries").int_within(v, 0, MAX_RETRIES)? as u8;
    }
    let heartbeat = r.heartbeat_timeout.as_ref();
    settings.heartbeat_timeout = positive_duration(
        &at.child("heartbeat_timeout"),
        heartbeat,
        settings.heartbeat_timeout,
    )?;
    Ok(())
}

/// The relay that tells the mode, and the Modbus requests' largest sizes.
fn requests(at: &At, r: &RawPlc, settings: &mut LinkSettings) -> Result<(), ConfigError> {
    let protocol = settings.protocol;
    if let Some(v) = &r.mode_relay {
        settings.mode_relay = mode_relay(&at.child("mode_relay"), v, protocol)?;
    }
    if let Some(v) = &r.modbus_max_write {
        let at = at.child("modbus_max_write");
        settings.modbus_max_write = request_size(&at, v, protocol, MAX_WRITE_REGISTERS)?;
    }
    if let Some(v) = &r.modbus_max_read {
        let at = at.child("modbus_max_read");
        settings.modbus_max_read = request_size(&at, v, protocol, MAX_READ_REGISTERS)?;
    }
    Ok(())
}

/// Exactly one of `serial` and `tcp`; Modbus TCP needs `tcp`.
fn transport(at: &At, raw: &Spanned<RawPlc>, protocol: Protocol) -> Result<Transport, ConfigError> {
    match (&raw.get_ref().serial, &raw.get_ref().tcp) {
        (Some(_), Some(tcp)) => Err(table_invalid(
            &at.child("tcp"),
            &tcp.span(),
            "{ ... }",
            "give either serial or tcp, not both",
        )),
        (None, None) => Err(at.child("serial").missing(
            &raw.span(),
            "a plc table needs either serial = { ... } or tcp = { ... }",
        )),
        (Some(serial), None) if protocol == Protocol::ModbusTcp => Err(table_invalid(
            &at.child("serial"),
            &serial.span(),
            "{ ... }",
            "protocol \"modbus-tcp\" runs over tcp = { ... }",
        )),
        (Some(serial), None) => serial_settings(&at.child("serial"), serial).map(Transport::Serial),
        (None, Some(tcp)) => tcp_settings(&at.child("tcp"), tcp).map(Transport::Tcp),
    }
}

fn serial_settings(at: &At, raw: &Spanned<RawSerial>) -> Result<SerialSettings, ConfigError> {
    let r = raw.get_ref();
    if r.path.get_ref().trim().is_empty() {
        return Err(at.child("path").invalid(&r.path, "needs a device path"));
    }
    let int = |key: &str, v: Option<&Spanned<i64>>, allowed: &[i64], default: i64| {
        v.map_or(Ok(default), |v| one_of(&at.child(key), v, allowed))
    };
    Ok(SerialSettings {
        path: r.path.get_ref().clone(),
        baud: int("baud", r.baud.as_ref(), &BAUDS, 19_200)? as u32,
        data_bits: int("data_bits", r.data_bits.as_ref(), &[7, 8], 8)? as u8,
        parity: r.parity.unwrap_or(Parity::Odd),
        stop_bits: int("stop_bits", r.stop_bits.as_ref(), &[1, 2], 1)? as u8,
    })
}

/// Baud rates of the FP-X's serial ports (FP-X user's manual, communication specifications).
const BAUDS: [i64; 7] = [2_400, 4_800, 9_600, 19_200, 38_400, 57_600, 115_200];

fn one_of(at: &At, value: &Spanned<i64>, allowed: &[i64]) -> Result<i64, ConfigError> {
    if allowed.contains(value.get_ref()) {
        return Ok(*value.get_ref());
    }
    let list: Vec<String> = allowed.iter().map(ToString::to_string).collect();
    Err(at.invalid(value, format!("must be one of {}", list.join(", "))))
}

fn tcp_settings(at: &At, raw: &Spanned<RawTcp>) -> Result<TcpSettings, ConfigError> {
    let r = raw.get_ref();
    let address = r.address.get_ref();
    let port_ok = address
        .rsplit_once(':')
        .is_some_and(|(host, port)| !host.is_empty() && port.parse::<u16>().is_ok_and(|p| p > 0));
    if !port_ok {
        let reason = "must be host:port, as in \"192.168.1.5:9094\"";
        return Err(at.child("address").invalid(&r.address, reason));
    }
    let connect = r.connect_timeout.as_ref();
    Ok(TcpSettings {
        address: address.clone(),
        connect_timeout: positive_duration(
            &at.child("connect_timeout"),
            connect,
            Duration::from_secs(2),
        )?,
    })
}

fn station(at: &At, value: &Spanned<i64>, protocol: Protocol) -> Result<u8, ConfigError> {
    let v = *value.get_ref();
    let ok = match protocol {
        Protocol::Mewtocol => (1..=MAX_STATION).contains(&v) || v == i64::from(STATION_ANY),
        Protocol::ModbusRtu | Protocol::ModbusTcp => (1..=MAX_UNIT).contains(&v),
    };
    if ok {
        return Ok(v as u8);
    }
    let reason = match protocol {
        Protocol::Mewtocol => format!("must be within 1..={MAX_STATION}, or {STATION_ANY} for EE"),
        _ => format!("a Modbus unit id must be within 1..={MAX_UNIT}"),
    };
    Err(at.invalid(value, reason))
}

fn header(
    at: &At,
    value: &Spanned<String>,
    protocol: Protocol,
) -> Result<HeaderChoice, ConfigError> {
    if protocol != Protocol::Mewtocol {
        return Err(at.invalid(value, "only MEWTOCOL has a header"));
    }
    match value.get_ref().as_str() {
        "auto" => Ok(HeaderChoice::Auto),
        "percent" => Ok(HeaderChoice::Percent),
        "angle" => Ok(HeaderChoice::Angle),
        _ => Err(at.invalid(value, "must be \"auto\", \"percent\" or \"angle\"")),
    }
}

/// `R` + word in decimal (0..=999) + bit in hex: `R9020` is word 902, bit 0.
fn mode_relay(at: &At, value: &Spanned<String>, protocol: Protocol) -> Result<u16, ConfigError> {
    if protocol == Protocol::Mewtocol {
        return Err(at.invalid(
            value,
            "MEWTOCOL reads the mode with RT; mode_relay is for Modbus",
        ));
    }
    parse_relay(value.get_ref())
        .ok_or_else(|| at.invalid(value, "must be a relay R0..R999F, as in \"R9020\""))
}

/// Registers one Modbus request may hold, `1..=limit` (the Modbus spec's; the FP-X's own limit is
/// unverified).
fn request_size(
    at: &At,
    value: &Spanned<i64>,
    protocol: Protocol,
    limit: u16,
) -> Result<u16, ConfigError> {
    if protocol == Protocol::Mewtocol {
        let key = at.key().rsplit('.').next().unwrap_or_default();
        let reason = format!("{key} is for Modbus; MEWTOCOL sizes its frames by the header");
        return Err(at.invalid(value, reason));
    }
    Ok(at.int_within(value, 1, i64::from(limit))? as u16)
}

/// One count per joint, in the joints' order, each putting its joint inside its limits.
fn home_counts(
    at: &At,
    value: &Spanned<Vec<Spanned<i64>>>,
    robot: &Robot,
) -> Result<[i64; JOINTS], ConfigError> {
    let counts = value.get_ref();
    if counts.len() != JOINTS {
        let reason = format!("needs {JOINTS} counts, one per joint in the joints' order");
        return Err(at.invalid(value, reason));
    }
    let mut out = [0; JOINTS];
    for (j, (count, joint)) in counts.iter().zip(&robot.joints).enumerate() {
        let c = *count.get_ref();
        let v = joint.value_of(c);
        if c < i64::from(i32::MIN) || c > i64::from(i32::MAX) || v < joint.min || v > joint.max {
            let unit = joint.kind.user_unit();
            let reason = format!(
                "puts joint {} at {:.3} {unit}, outside its limits {:.3}..={:.3} {unit}",
                joint.name,
                joint.user(v),
                joint.user(joint.min),
                joint.user(joint.max)
            );
            return Err(at.index(j).invalid(count, reason));
        }
        out[j] = c;
    }
    Ok(out)
}

fn parse_relay(text: &str) -> Option<u16> {
    let digits = text.strip_prefix('R')?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let (word, bit) = digits.split_at(digits.len() - 1);
    if !word.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let word: u16 = if word.is_empty() {
        0
    } else {
        word.parse().ok()?
    };
    let bit = u16::from_str_radix(bit, 16).ok()?;
    (word <= 999).then_some(word * 16 + bit)
}

fn positive_duration(
    at: &At,
    value: Option<&Spanned<String>>,
    default: Duration,
) -> Result<Duration, ConfigError> {
    let Some(value) = value else {
        return Ok(default);
    };
    let seconds = parse_duration_s(value.get_ref()).map_err(|e| at.invalid(value, e.problem))?;
    if seconds <= 0.0 {
        return Err(at.invalid(value, "must be longer than 0 s"));
    }
    Ok(Duration::from_secs_f64(seconds))
}

fn layout(
    at: &At,
    raw: Option<&Spanned<RawContract>>,
    area_words: usize,
) -> Result<Layout, ConfigError> {
    let mut layout = Layout {
        area_words: area_words as u16,
        ..Layout::default()
    };
    let Some(raw) = raw else {
        return Ok(layout);
    };
    let r = raw.get_ref();
    let fields = [
        ("status_base", &r.status_base, &mut layout.status_base),
        ("command_base", &r.command_base, &mut layout.command_base),
        ("table_base", &r.table_base, &mut layout.table_base),
        ("bank_stride", &r.bank_stride, &mut layout.bank_stride),
        (
            "channel_stride",
            &r.channel_stride,
            &mut layout.channel_stride,
        ),
    ];
    for (key, value, slot) in fields {
        if let Some(v) = value {
            *slot = at.child(key).int_within(v, 0, i64::from(DT_LAST))? as u16;
        }
    }
    if let Some(inputs) = &r.inputs {
        layout.inputs = input_words(&at.child("inputs"), inputs)?;
    }
    layout
        .check()
        .map_err(|e| table_invalid(at, &raw.span(), &shown(&layout), e))?;
    Ok(layout)
}

/// `inputs`: the four words the PLC program copies into the status block, in its order.
fn input_words(
    at: &At,
    raw: &Spanned<Vec<Spanned<String>>>,
) -> Result<[InputWord; INPUT_WORDS], ConfigError> {
    let list = raw.get_ref();
    if list.len() != INPUT_WORDS {
        let shown: Vec<&str> = list.iter().map(|w| w.get_ref().as_str()).collect();
        return Err(ConfigError::Invalid {
            line: at.line(&raw.span()),
            key: at.key().to_owned(),
            value: format!("{shown:?}"),
            reason: format!(
                "names {} words; the status block holds {INPUT_WORDS} (repeat one the program \
                 copies twice, or name an unused relay word)",
                list.len()
            ),
        });
    }
    let mut words = InputWord::DEFAULTS;
    for (i, text) in list.iter().enumerate() {
        words[i] = text
            .get_ref()
            .parse()
            .map_err(|e: crate::contract::InputWordError| at.index(i).invalid(text, e))?;
    }
    Ok(words)
}

fn shown(l: &Layout) -> String {
    format!(
        "{{ status_base = {}, command_base = {}, table_base = {}, bank_stride = {}, \
         channel_stride = {} }}",
        l.status_base, l.command_base, l.table_base, l.bank_stride, l.channel_stride
    )
}

/// A whole table refused.
fn table_invalid(
    at: &At,
    span: &Range<usize>,
    value: &str,
    reason: impl std::fmt::Display,
) -> ConfigError {
    ConfigError::Invalid {
        line: at.line(span),
        key: at.key().to_owned(),
        value: value.to_owned(),
        reason: reason.to_string(),
    }
}

#[cfg(test)]
#[path = "plc_tests.rs"]
mod tests;
