//! `linterpd check-config`: read a configuration file as the daemon would and say what it holds,
//! or the first thing wrong with it (line, key, value, limit). Needs no daemon.

use std::fmt::Write as _;
use std::path::PathBuf;

use clap::Args;

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
    format!("{protocol} on {transport}, station {}", link.station)
}

/// Runs `linterpd check-config`.
pub fn run(args: &CheckConfigArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let config = Config::load(&args.config).map_err(bad_input)?;
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
        let link = config
            .link(&robot.name)
            .map_or("no PLC link".to_owned(), describe);
        let _ = writeln!(
            text,
            "  {} ({}): {}; {link}",
            robot.name,
            robot.kinematics.name(),
            joints.join(", ")
        );
    }
    out.write_all(text.as_bytes())
        .map_err(|e| Failure::Runtime(e.into()))
}
