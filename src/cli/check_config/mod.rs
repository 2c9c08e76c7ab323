//! `linterpd check-config`: read a configuration file as the daemon would and say what it holds
//! (text, or with `--json` one document: `{"config", "robots": [{"name", "kinematics",
//! "joints": [{"name", "channel"}], "link", "programs"?: {"dir", "checked": [{"name", "number",
//! "ops"}], "positions"}, "pallets"?: [line]}]}`), or what is wrong with it on stderr with exit 2: the first fault of
//! the file (the file, line, key path, value, limit, and the nearest valid key of an unknown
//! one), or every cycle program of a robot's `programs` directory that does not check (each as
//! `cycle run` would say it; `programs.rs`). Needs no daemon.

mod programs;

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
    let programs: Vec<Option<programs::Programs>> = config
        .robots
        .iter()
        .map(|robot| programs::check(&config, robot))
        .collect();
    let faults: Vec<String> = programs
        .iter()
        .flatten()
        .flat_map(|p| p.faults.iter().map(|f| format!("  {f}")))
        .collect();
    if !faults.is_empty() {
        return Err(bad_input(anyhow::anyhow!(
            "{}: {} in its cycle programs:\n{}",
            args.config.display(),
            if faults.len() == 1 {
                "one fault".to_owned()
            } else {
                format!("{} faults", faults.len())
            },
            faults.join("\n")
        )));
    }
    let written = if args.json {
        writeln!(out, "{}", document(args, &config, &programs))
    } else {
        out.write_all(text(args, &config, &programs).as_bytes())
    };
    written.map_err(|e| Failure::Runtime(e.into()))
}

fn link_of(config: &Config, robot: &str) -> Option<String> {
    config.link(robot).map(describe)
}

/// A robot's programs in a line.
fn describe_programs(p: &programs::Programs) -> String {
    let names: Vec<String> = p
        .checked
        .iter()
        .map(|c| match c.number {
            Some(n) => format!("{} (number {n})", c.name),
            None => c.name.clone(),
        })
        .collect();
    let mut line = format!(
        "cycle programs in {}: {}",
        p.dir.display(),
        if names.is_empty() {
            "none".to_owned()
        } else {
            format!("{}, each checked", names.join(", "))
        }
    );
    if !p.positions.is_empty() {
        let positions: Vec<&str> = p.positions.iter().map(String::as_str).collect();
        let _ = write!(
            line,
            "; they move to the taught positions {} (`linterpd pos save NAME`; checked when a \
             cycle runs)",
            positions.join(", ")
        );
    }
    line
}

fn text(
    args: &CheckConfigArgs,
    config: &Config,
    programs: &[Option<programs::Programs>],
) -> String {
    let mut text = format!(
        "{}: {} robot(s)\n",
        args.config.display(),
        config.robots.len()
    );
    for (i, robot) in config.robots.iter().enumerate() {
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
        if let Some(p) = programs.get(i).and_then(Option::as_ref) {
            let _ = writeln!(text, "    {}", describe_programs(p));
        }
        for line in pallet_lines(config, robot) {
            let _ = writeln!(text, "    {line}");
        }
    }
    text
}

/// A line per pallet of `robot`: its slots, every one checked against the robot's reach when
/// the config was; or that it waits for its taught points.
fn pallet_lines(config: &Config, robot: &crate::robot::Robot) -> Vec<String> {
    let Some(set) = config.pallets.get(&robot.name) else {
        return Vec::new();
    };
    let none = std::collections::BTreeMap::new();
    set.layouts
        .keys()
        .map(|name| {
            if set.needs_taught(name) {
                return format!(
                    "pallet {name}: on taught points; laid out and checked when they are taught"
                );
            }
            match set.pattern(name, robot, &none) {
                Ok(p) => format!(
                    "pallet {name}: {} slots in {} layers, every slot and waypoint within reach",
                    p.len(),
                    p.layers()
                ),
                Err(e) => format!("pallet {name}: {e}"),
            }
        })
        .collect()
}

fn document(
    args: &CheckConfigArgs,
    config: &Config,
    programs: &[Option<programs::Programs>],
) -> Value {
    let robots: Vec<Value> = config
        .robots
        .iter()
        .zip(programs)
        .map(|(robot, programs)| robot_document(config, robot, programs.as_ref()))
        .collect();
    json!({ "config": args.config.display().to_string(), "robots": robots })
}

/// One robot of the JSON document: its joints, link, pallets and programs.
fn robot_document(
    config: &Config,
    robot: &crate::robot::Robot,
    programs: Option<&programs::Programs>,
) -> Value {
    let joints: Vec<Value> = robot
        .joints
        .iter()
        .map(|j| json!({ "name": j.name, "channel": j.channel }))
        .collect();
    let mut robot_json = json!({
        "name": robot.name,
        "kinematics": robot.kinematics.name(),
        "joints": joints,
        "link": link_of(config, &robot.name),
    });
    let pallets = pallet_lines(config, robot);
    if !pallets.is_empty() {
        robot_json["pallets"] = json!(pallets);
    }
    if let Some(p) = programs {
        let checked: Vec<Value> = p
            .checked
            .iter()
            .map(|c| json!({ "name": c.name, "number": c.number, "ops": c.ops }))
            .collect();
        robot_json["programs"] = json!({
            "dir": p.dir.display().to_string(),
            "checked": checked,
            "positions": p.positions,
        });
    }
    robot_json
}
