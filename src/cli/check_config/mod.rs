//! `linterpd check-config`: read a configuration file as the daemon would and say what it holds
//! (text, or with `--json` one document: `{"config", "robots": [{"name", "kinematics",
//! "joints": [{"name", "channel"}], "link"}]}`), or the first thing wrong with it (line, key,
//! value, limit) on stderr with exit 2. Needs no daemon.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;
use serde_json::{Value, json};

use super::{Failure, bad_input};
use crate::config::Config;
use crate::kinematics::Kinematics;
use crate::plc::{LinkSettings, Parity, Protocol, Transport};

/// Arguments of `linterpd check-config`.
#[derive(Debug, Args)]
pub struct CheckConfigArgs {
    /// The configuration file.
    #[arg(
        long,
        env = "LINTERPD_CONFIG",
        default_value = "/etc/linterpd/linterpd.toml"
    )]
    pub config: PathBuf,
    /// Print one JSON document instead of text.
    #[arg(long)]
    pub json: bool,
}

/// A link in a line: protocol, transport, station.
fn describe(link: &LinkSettings) -> String {
    let protocol = match link.protocol {
        Protocol::Mewtocol => "MEWTOCOL-COM",
        Protocol::ModbusRtu => "Modbus RTU",
        Protocol::ModbusTcp => "Modbus TCP",
    };
    let transport = match &link.transport {
        Transport::Serial(s) => {
            let parity = match s.parity {
                Parity::None => 'N',
                Parity::Odd => 'O',
                Parity::Even => 'E',
            };
            format!(
                "serial {} at {} {}{parity}{}",
                s.path, s.baud, s.data_bits, s.stop_bits
            )
        }
        Transport::Tcp(t) => format!("TCP {}", t.address),
    };
    let read_back = if link.read_back {
        ""
    } else {
        "; uploads not read back (read_back = false)"
    };
    format!(
        "{protocol} on {transport}, station {}{read_back}",
        link.station
    )
}

/// Runs `linterpd check-config`.
pub fn run(args: &CheckConfigArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let config = Config::load(&args.config).map_err(bad_input)?;
    let written = if args.json {
        writeln!(out, "{}", document(args, &config))
    } else {
        out.write_all(text(args, &config).as_bytes())
    };
    written.map_err(|e| Failure::Runtime(e.into()))
}

fn link_of(config: &Config, robot: &str) -> Option<String> {
    config.link(robot).map(describe)
}

fn text(args: &CheckConfigArgs, config: &Config) -> String {
    let mut text = format!(
        "{}: {} robot(s)\n",
        args.config.display(),
        config.robots.len()
    );
    for robot in &config.robots {
        let joints: Vec<String> = robot
            .joints
            .iter()
            .map(|j| format!("{} on channel {}", j.name, j.channel))
            .collect();
        let link = link_of(config, &robot.name).unwrap_or_else(|| "no PLC link".to_owned());
        let _ = writeln!(
            text,
            "  {} ({}): {}; {link}",
            robot.name,
            robot.kinematics.name(),
            joints.join(", ")
        );
    }
    text
}

fn document(args: &CheckConfigArgs, config: &Config) -> Value {
    let robots: Vec<Value> = config
        .robots
        .iter()
        .map(|robot| {
            let joints: Vec<Value> = robot
                .joints
                .iter()
                .map(|j| json!({ "name": j.name, "channel": j.channel }))
                .collect();
            json!({
                "name": robot.name,
                "kinematics": robot.kinematics.name(),
                "joints": joints,
                "link": link_of(config, &robot.name),
            })
        })
        .collect();
    json!({ "config": args.config.display().to_string(), "robots": robots })
}
