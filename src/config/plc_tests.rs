//! `[robots.NAME.plc]`: parsing, defaults, and errors that name key, value and line.

use std::time::Duration;

use super::super::Config;
use super::super::fixture::{MINIMAL, message};
use super::parse_relay;
use crate::contract::Layout;
use crate::plc::{HeaderChoice, Parity, Protocol, R9020, Transport};

/// `MINIMAL` (40 lines) with a plc table from line 41: `[robots.r.plc]`, then `body` from 42.
fn with_plc(body: &str) -> String {
    format!("{MINIMAL}[robots.r.plc]\n{body}\n")
}

#[test]
fn serial_mewtocol_section_fills_defaults() {
    let text = with_plc("protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyUSB0\" }");
    let config = Config::from_toml(&text).unwrap();
    let link = config.link("r").unwrap();
    assert_eq!(link.protocol, Protocol::Mewtocol);
    let Transport::Serial(serial) = &link.transport else {
        panic!("serial expected")
    };
    assert_eq!(
        (serial.path.as_str(), serial.baud),
        ("/dev/ttyUSB0", 19_200)
    );
    assert_eq!(
        (serial.data_bits, serial.parity, serial.stop_bits),
        (8, Parity::Odd, 1)
    );
    assert_eq!(
        (link.station, link.header, link.retries),
        (1, HeaderChoice::Auto, 2)
    );
    assert_eq!(link.timeout, Duration::from_millis(300));
    assert_eq!(link.heartbeat_timeout, Duration::from_millis(500));
    assert_eq!(link.layout, Layout::default());
    assert_eq!((link.modbus_max_write, link.modbus_max_read), (123, 125));
    assert!(config.link("other").is_none());
}

#[test]
fn tcp_modbus_section_with_every_key() {
    let text = with_plc(
        "protocol = \"modbus-tcp\"\n\
         tcp = { address = \"192.168.1.5:502\", connect_timeout = \"1s\" }\n\
         station = 247\ntimeout = \"1s\"\nretries = 0\nheartbeat_timeout = \"2s\"\n\
         mode_relay = \"R12A\"\nmodbus_max_write = 100\nmodbus_max_read = 64\n\
         [robots.r.plc.contract]\nstatus_base = 100\ncommand_base = 140\n",
    );
    let link = Config::from_toml(&text).unwrap().links["r"].clone();
    let Transport::Tcp(tcp) = &link.transport else {
        panic!("tcp expected")
    };
    assert_eq!(
        (tcp.address.as_str(), tcp.connect_timeout),
        ("192.168.1.5:502", Duration::from_secs(1))
    );
    assert_eq!(
        (link.station, link.retries, link.mode_relay),
        (247, 0, 12 * 16 + 10)
    );
    assert_eq!(
        (link.layout.status_base, link.layout.command_base),
        (100, 140)
    );
    assert_eq!(link.layout.table_base, 2_000);
    assert_eq!((link.modbus_max_write, link.modbus_max_read), (100, 64));
}

#[test]
fn config_without_plc_has_no_links() {
    assert!(Config::from_toml(MINIMAL).unwrap().links.is_empty());
}

#[test]
fn bad_station_names_key_value_and_line() {
    let text =
        with_plc("protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\nstation = 120");
    assert_eq!(
        message(&text),
        "config line 44: robots.r.plc.station = 120: must be within 1..=99, or 238 for EE"
    );
}

#[test]
fn bad_baud_lists_the_allowed_rates() {
    let text =
        with_plc("protocol = \"modbus-rtu\"\nserial = { path = \"/dev/ttyS0\", baud = 12345 }");
    let m = message(&text);
    assert!(
        m.starts_with("config line 43: robots.r.plc.serial.baud = 12345: must be one of 2400,"),
        "{m}"
    );
}

#[test]
fn header_with_modbus_is_refused() {
    let text = with_plc(
        "protocol = \"modbus-rtu\"\nserial = { path = \"/dev/ttyS0\" }\nheader = \"angle\"",
    );
    assert_eq!(
        message(&text),
        "config line 44: robots.r.plc.header = \"angle\": only MEWTOCOL has a header"
    );
}

#[test]
fn unknown_header_is_refused() {
    let text =
        with_plc("protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\nheader = \"<\"");
    assert!(message(&text).ends_with("header = \"<\": must be \"auto\", \"percent\" or \"angle\""));
}

#[test]
fn missing_transport_names_the_table_line() {
    let text = with_plc("protocol = \"mewtocol\"");
    assert_eq!(
        message(&text),
        "config line 41: robots.r.plc.serial is missing: a plc table needs either serial = { ... } \
         or tcp = { ... }"
    );
}

#[test]
fn modbus_tcp_over_serial_is_refused() {
    let text = with_plc("protocol = \"modbus-tcp\"\nserial = { path = \"/dev/ttyS0\" }");
    assert!(message(&text).starts_with("config line 43: robots.r.plc.serial = { ... }: protocol"));
}

#[test]
fn zero_timeout_and_bad_address_are_refused() {
    let text =
        with_plc("protocol = \"mewtocol\"\ntcp = { address = \"plc:9094\" }\ntimeout = \"0ms\"");
    assert_eq!(
        message(&text),
        "config line 44: robots.r.plc.timeout = \"0ms\": must be longer than 0 s"
    );
    let text = with_plc("protocol = \"mewtocol\"\ntcp = { address = \"plc\" }");
    assert!(message(&text).contains("robots.r.plc.tcp.address = \"plc\": must be host:port"));
}

#[test]
fn unknown_key_and_protocol_are_refused_with_their_line() {
    let text = with_plc("protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\nbaud = 9600");
    assert!(message(&text).starts_with("config line 44: robots.r.plc.baud: unknown field `baud`"));
    let text = with_plc("protocol = \"profibus\"\nserial = { path = \"/dev/ttyS0\" }");
    assert!(message(&text).starts_with("config line 42: robots.r.plc.protocol: unknown variant"));
}

#[test]
fn overlapping_contract_is_refused_by_layout_check() {
    let text = with_plc(
        "protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\n\
         [robots.r.plc.contract]\ncommand_base = 1010",
    );
    let m = message(&text);
    assert!(
        m.starts_with("config line 44: robots.r.plc.contract = { status_base = 1000"),
        "{m}"
    );
    assert!(m.contains("overlaps"), "{m}");
}

#[test]
fn mode_relay_is_for_modbus_and_spelled_as_panasonic_does() {
    let text = with_plc(
        "protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\nmode_relay = \"R9020\"",
    );
    assert!(message(&text).contains("mode_relay is for Modbus"));
    assert_eq!(parse_relay("R9020"), Some(R9020));
    assert_eq!(parse_relay("R5"), Some(5));
    assert_eq!(parse_relay("R999F"), Some(999 * 16 + 15));
    for bad in ["R", "X9020", "R10000", "R+12", "R12G", "R9020 "] {
        assert_eq!(parse_relay(bad), None, "{bad}");
    }
}

#[test]
fn modbus_request_sizes_name_key_value_and_limit() {
    let rtu = "protocol = \"modbus-rtu\"\nserial = { path = \"/dev/ttyS0\" }\n";
    let text = with_plc(&format!("{rtu}modbus_max_write = 124"));
    assert_eq!(
        message(&text),
        "config line 44: robots.r.plc.modbus_max_write = 124: must be within 1..=123"
    );
    let text = with_plc(&format!("{rtu}retries = 1\nmodbus_max_read = 0"));
    assert_eq!(
        message(&text),
        "config line 45: robots.r.plc.modbus_max_read = 0: must be within 1..=125"
    );
    let text = with_plc(&format!("{rtu}modbus_max_write = 1\nmodbus_max_read = 125"));
    let link = Config::from_toml(&text).unwrap().links["r"].clone();
    assert_eq!((link.modbus_max_write, link.modbus_max_read), (1, 125));
}

#[test]
fn modbus_request_sizes_are_refused_for_mewtocol() {
    let mewtocol = "protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\n";
    let text = with_plc(&format!("{mewtocol}modbus_max_write = 100"));
    assert_eq!(
        message(&text),
        "config line 44: robots.r.plc.modbus_max_write = 100: modbus_max_write is for Modbus; \
         MEWTOCOL sizes its frames by the header"
    );
    let text = with_plc(&format!("{mewtocol}modbus_max_read = 100"));
    assert!(
        message(&text).contains("plc.modbus_max_read = 100: modbus_max_read is for Modbus"),
        "{}",
        message(&text)
    );
}

#[test]
fn multi_frame_reads_are_on_by_default_can_be_turned_off_and_are_refused_for_modbus() {
    let mewtocol = "protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\n";
    let link = |text: &str| Config::from_toml(text).unwrap().link("r").unwrap().clone();
    assert!(link(&with_plc(mewtocol)).multi_frame_reads);
    let off = with_plc(&format!("{mewtocol}multi_frame_reads = false"));
    assert!(!link(&off).multi_frame_reads);
    let modbus = "protocol = \"modbus-rtu\"\nserial = { path = \"/dev/ttyS0\" }\n";
    let text = with_plc(&format!("{modbus}multi_frame_reads = true"));
    assert_eq!(
        message(&text),
        "config line 44: robots.r.plc.multi_frame_reads = true: only MEWTOCOL replies come in \
         frames"
    );
    let text = with_plc(&format!("{mewtocol}multi_frame_reads = \"yes\""));
    assert!(
        message(&text).contains("multi_frame_reads"),
        "{}",
        message(&text)
    );
}

#[test]
fn read_back_is_on_by_default_can_be_turned_off_and_reaches_the_contract() {
    let mewtocol = "protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyUSB0\" }\n";
    let modbus = "protocol = \"modbus-tcp\"\ntcp = { address = \"10.0.0.2:502\" }\n";
    let link = |text: &str| Config::from_toml(text).unwrap().link("r").unwrap().clone();
    for plc in [mewtocol, modbus] {
        let on = link(&with_plc(plc));
        assert!(on.read_back);
        assert!(crate::daemon::service::contract_settings(&on).verify);
        let off = link(&with_plc(&format!("{plc}read_back = false")));
        assert!(!off.read_back);
        assert!(!crate::daemon::service::contract_settings(&off).verify);
    }
    let text = with_plc(&format!("{mewtocol}read_back = 1"));
    assert!(message(&text).contains("read_back"), "{}", message(&text));
}

#[test]
fn shipped_file_has_a_valid_press_loader_plc_section() {
    let config = Config::from_toml(include_str!("../../config/linterpd.toml")).unwrap();
    let link = config.link("press-loader").unwrap();
    assert_eq!(link.protocol, Protocol::Mewtocol);
    assert_eq!(link.header, HeaderChoice::Auto);
    assert!(link.multi_frame_reads);
    assert_eq!(link.layout, Layout::default());
    assert!(matches!(&link.transport, Transport::Serial(s) if s.path == "/dev/ttyUSB0"));
}

#[test]
fn home_counts_scan_time_are_read_and_checked_against_the_joints() {
    let serial = "protocol = \"mewtocol\"\nserial = { path = \"/dev/ttyS0\" }\n";
    let text = with_plc(&format!(
        "{serial}scan_time = \"5ms\"\nhome_counts = [100, -200, 0, 4]"
    ));
    let link = Config::from_toml(&text).unwrap().links["r"].clone();
    assert_eq!(link.home_counts, [100, -200, 0, 4]);
    assert_eq!(link.scan_time, Duration::from_millis(5));
    let defaults = Config::from_toml(&with_plc(serial)).unwrap().links["r"].clone();
    assert_eq!(defaults.home_counts, [0; 4]);
    assert_eq!(defaults.scan_time, Duration::from_millis(10));
    let m = message(&with_plc(&format!(
        "{serial}home_counts = [0, 20000, 0, 0]"
    )));
    assert!(
        m.starts_with("config line 44: robots.r.plc.home_counts")
            && m.contains("= 20000: puts joint")
            && m.contains("at 500.000 mm, outside its limits -50.000..=400.000 mm"),
        "{m}"
    );
    let m = message(&with_plc(&format!("{serial}home_counts = [0, 0]")));
    assert_eq!(
        m,
        "config line 44: robots.r.plc.home_counts = [0, 0]: needs 4 counts, one per joint in the joints' order"
    );
    let m = message(&with_plc(&format!("{serial}scan_time = \"0ms\"")));
    assert!(
        m.contains("scan_time = \"0ms\": must be longer than 0 s"),
        "{m}"
    );
}
