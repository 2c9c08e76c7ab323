//! `linterpd io`: the PLC's other registers through the daemon's register gateway
//! (`GET` / `PUT /v1/robots/{name}/registers/{address}`), as the robot's access list allows.
//! `read ADDR [--count N]` and `write ADDR VALUE...`; addresses as Panasonic writes them (`DT100`,
//! `X1F`, `Y7`, `R0010`), DT words as numbers -32768..=65535 (or `0x` hex), bits as 1/0,
//! true/false or on/off. `force`, `release` and `cell` reach a mock PLC's simulated cell instead,
//! never the daemon (`io_mock.rs`).
//!
//! ```text
//!  stdout:  a line per address, `DT100 = 1234`, `R10 = 1` (or the API's answer, --json)
//!  exit:    0 done; 2 a bad address, count or value, or one the access list does not let
//!           through (400/403/404); 4 no daemon, or its PLC link is down (503); 1 the PLC
//!           refused or failed the exchange (502)
//! ```

use anyhow::anyhow;
use clap::{Args, Subcommand};
use hyper::Method;
use serde_json::Value;

use super::client::{Client, Received};
use super::positions::Robot;
use super::{Failure, bad_input};
use crate::daemon::api::{RegisterWrite, Registers};
use crate::daemon::{Values, values_from_json};
use crate::gateway::{Address, Area};

/// Arguments of `linterpd io`.
#[derive(Debug, Args)]
pub struct IoArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: IoAction,
    /// The robot and the daemon (before or after the action; `force`, `release` and `cell` reach
    /// a mock, never the daemon).
    #[command(flatten)]
    pub robot: Robot,
}

/// The `io` subcommands.
#[derive(Debug, Subcommand)]
pub enum IoAction {
    /// Read DT words or X, Y, R bits from ADDR on.
    Read(ReadArgs),
    /// Write DT words or Y, R bits from ADDR on, one VALUE per address.
    Write(WriteArgs),
    /// On a mock PLC only (`linterpd mock-plc --control PATH`): force an input of its simulated
    /// cell on or off until released.
    Force(super::io_mock::ForceArgs),
    /// On a mock PLC only: release a forced input (`all`: every one); its model takes it back.
    Release(super::io_mock::ReleaseArgs),
    /// On a mock PLC only: its simulated cell's state and what is forced.
    Cell(super::io_mock::MockSocket),
}

/// Arguments of `linterpd io read`.
#[derive(Debug, Args)]
pub struct ReadArgs {
    /// The first address: DT100, X1F (word 1, bit F), Y7, R0010.
    pub address: String,
    /// How many words or bits.
    #[arg(long, default_value_t = 1)]
    pub count: u32,
}

/// Arguments of `linterpd io write`.
#[derive(Debug, Args)]
pub struct WriteArgs {
    /// The first address: DT100, Y7, R0010 (X, the inputs, cannot be written).
    pub address: String,
    /// A value per address: DT words -32768..=65535 (or 0x hex), bits 1/0, true/false, on/off.
    #[arg(required = true, num_args = 1.., allow_negative_numbers = true)]
    pub values: Vec<String>,
}

/// Runs `linterpd io`.
pub fn run(args: &IoArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    match &args.action {
        IoAction::Read(a) => {
            let start = parse_address(&a.address)?;
            let query = format!("?count={}", a.count);
            registers(start, &args.robot, (Method::GET, query, None), out)
        }
        IoAction::Write(a) => {
            let start = parse_address(&a.address)?;
            let values = parse_values(start.area, &a.values)?;
            let body = serde_json::to_value(RegisterWrite { values })
                .map_err(|e| Failure::Runtime(e.into()))?;
            registers(
                start,
                &args.robot,
                (Method::PUT, String::new(), Some(body)),
                out,
            )
        }
        IoAction::Force(a) => super::io_mock::force(a, out),
        IoAction::Release(a) => super::io_mock::release(a, out),
        IoAction::Cell(a) => super::io_mock::cell(a, out),
    }
}

/// Reads or writes registers from `start` through the daemon's gateway, printing them.
fn registers(
    start: Address,
    target: &Robot,
    (method, query, body): (Method, String, Option<Value>),
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let daemon = &target.daemon;
    daemon.block_on(async {
        let client = Client::new(&daemon.socket);
        let robot = client
            .robot(target.robot.as_deref())
            .await
            .map_err(Failure::from_client)?;
        let path = format!("/v1/robots/{robot}/registers/{start}{query}");
        let answer = client.expect(method, &path, body.as_ref()).await?;
        let registers: Received<Registers> =
            Received::read(answer, "registers").map_err(Failure::Runtime)?;
        let text = lines(start, &registers.value);
        super::print(out, daemon.json, &registers.json, &text)
    })
}

/// An address as typed, or bad input naming it.
fn parse_address(text: &str) -> Result<Address, Failure> {
    text.parse()
        .map_err(|e: crate::gateway::AddressError| bad_input(anyhow!("address {e}")))
}

/// Values as typed for `area`, as the API takes them; bad input names the value and the limit.
fn parse_values(area: Area, given: &[String]) -> Result<Vec<Value>, Failure> {
    let values = given
        .iter()
        .map(|text| parse_value(area, text))
        .collect::<Result<Vec<_>, _>>()
        .map_err(bad_input)?;
    // The daemon's own check, so a value out of range is refused before asking.
    values_from_json(area, &values).map_err(|e| bad_input(anyhow!("{e}")))?;
    Ok(values)
}

fn parse_value(area: Area, text: &str) -> anyhow::Result<Value> {
    let t = text.trim().to_ascii_lowercase();
    if area.is_bits() {
        return match t.as_str() {
            "1" | "true" | "on" => Ok(Value::Bool(true)),
            "0" | "false" | "off" => Ok(Value::Bool(false)),
            _ => Err(anyhow!(
                "value {text:?}: {} holds bits: give 1/0, true/false or on/off",
                area.name()
            )),
        };
    }
    let number = match t.strip_prefix("0x") {
        Some(hex) => i64::from_str_radix(hex, 16).ok(),
        None => t.parse::<i64>().ok(),
    };
    number.map(Value::from).ok_or_else(|| {
        anyhow!(
            "value {text:?}: a DT word is a whole number within -32768..=65535 (or 0x0..=0xFFFF)"
        )
    })
}

/// `DT100 = 1234` (or `R10 = 1`) for each value of the answer, from `start` on.
fn lines(start: Address, answer: &Registers) -> String {
    let at = |i: usize| Address {
        area: start.area,
        index: start.index + i as u32,
    };
    let lines: Vec<String> = match &answer.values {
        Values::Words(words) => words
            .iter()
            .enumerate()
            .map(|(i, w)| format!("{} = {w}", at(i)))
            .collect(),
        Values::Bits(bits) => bits
            .iter()
            .enumerate()
            .map(|(i, b)| format!("{} = {}", at(i), u8::from(*b)))
            .collect(),
    };
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use serde_json::json;

    fn args(line: &[&str]) -> IoArgs {
        let cli = crate::cli::Cli::try_parse_from(line).unwrap();
        let crate::cli::Command::Io(args) = cli.command else {
            panic!("not io")
        };
        args
    }

    #[test]
    fn answers_print_a_line_per_address() {
        let read = |json| {
            Received::<Registers>::read(json, "registers")
                .unwrap()
                .value
        };
        let dt = read(json!({"address": "DT100", "count": 2, "values": [1234, 65535]}));
        assert_eq!(
            lines("DT100".parse().unwrap(), &dt),
            "DT100 = 1234\nDT101 = 65535"
        );
        let r = read(json!({"address": "R1F", "count": 2, "values": [true, false]}));
        assert_eq!(lines("R1F".parse().unwrap(), &r), "R1F = 1\nR20 = 0");
    }

    #[test]
    fn values_are_checked_before_asking_naming_the_value_and_the_limit() {
        assert_eq!(
            parse_values(Area::Dt, &["-1".into(), "0x1F".into(), "65535".into()]).unwrap(),
            [json!(-1), json!(31), json!(65535)]
        );
        assert_eq!(
            parse_values(Area::R, &["on".into(), "0".into()]).unwrap(),
            [json!(true), json!(false)]
        );
        for (area, value, says) in [
            (
                Area::Dt,
                "70000",
                "values[0] = 70000: a DT word is a whole number within -32768..=65535",
            ),
            (
                Area::Dt,
                "1.5",
                "value \"1.5\": a DT word is a whole number",
            ),
            (Area::Y, "2", "value \"2\": Y holds bits"),
        ] {
            let e = parse_values(area, &[value.into()]).unwrap_err();
            assert_eq!(e.exit_code(), crate::cli::EXIT_BAD_INPUT);
            assert!(e.to_string().contains(says), "{value}: {e}");
        }
    }

    #[test]
    fn a_bad_address_is_refused_before_asking() {
        let a = args(&["linterpd", "io", "read", "DT1A", "--socket", "/nonexistent"]);
        let e = run(&a, &mut Vec::new()).unwrap_err();
        assert_eq!(e.exit_code(), crate::cli::EXIT_BAD_INPUT);
        assert_eq!(e.to_string(), "address \"DT1A\" has a DT number in decimal");
        let a = args(&[
            "linterpd", "io", "write", "DT100", "-5", "7", "--robot", "r",
        ]);
        let IoAction::Write(w) = &a.action else {
            panic!()
        };
        assert_eq!(w.values, ["-5", "7"]);
        assert_eq!(a.robot.robot.as_deref(), Some("r"));
    }

    #[test]
    fn io_read_accepts_json_socket_and_robot_before_the_action() {
        let a = args(&[
            "linterpd", "io", "--json", "--socket", "/s", "--robot", "r", "read", "DT100",
        ]);
        assert!(a.robot.daemon.json && a.robot.robot.as_deref() == Some("r"));
        assert_eq!(a.robot.daemon.socket, std::path::Path::new("/s"));
    }
}
