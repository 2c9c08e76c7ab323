//! The `linterpd` command line: one module per subcommand. `anyhow` lives here and in `main.rs`
//! only; every failure is sorted into bad input (exit 2) or a runtime failure (exit 1).

pub mod args;
pub mod logging;
pub mod mock_plc;
pub mod plan;
pub mod serve;

use std::fmt;

use clap::{Parser, Subcommand};

/// linterpd: straight-line moves for PLC-driven robots.
#[derive(Debug, Parser)]
#[command(name = "linterpd", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Plan one straight-line move and print its pulse tables and accuracy figures.
    Plan(plan::PlanArgs),
    /// Serve the mock PLC (MEWTOCOL-COM or Modbus, TCP or serial) until SIGINT / SIGTERM.
    MockPlc(mock_plc::MockPlcArgs),
    /// Run the daemon: a worker per robot on its PLC link, the HTTP/JSON API on a Unix socket
    /// (docs/API.md), until SIGINT / SIGTERM.
    Serve(serve::ServeArgs),
}

impl Command {
    /// The log level when `RUST_LOG` gives none: the daemon and the mock PLC log their work.
    #[must_use]
    pub fn default_log_level(&self) -> &'static str {
        match self {
            Self::Plan(_) => "error",
            Self::MockPlc(_) | Self::Serve(_) => "info",
        }
    }
}

/// Exit code for a run that worked.
pub const EXIT_OK: u8 = 0;
/// Exit code for a failure that is not the input's fault (IO, a bug).
pub const EXIT_FAILURE: u8 = 1;
/// Exit code for bad input: config, arguments, an impossible move. Nothing was done.
pub const EXIT_BAD_INPUT: u8 = 2;

/// A failed run: what went wrong and whose fault it was.
#[derive(Debug)]
pub enum Failure {
    /// The input is wrong (exit 2).
    BadInput(anyhow::Error),
    /// Something else failed (exit 1).
    Runtime(anyhow::Error),
}

impl Failure {
    /// The process exit code for this failure.
    #[must_use]
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::BadInput(_) => EXIT_BAD_INPUT,
            Self::Runtime(_) => EXIT_FAILURE,
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (Self::BadInput(e) | Self::Runtime(e)) = self;
        write!(f, "{e:#}")
    }
}

/// Bad input from anything that converts into an `anyhow::Error`.
pub fn bad_input(e: impl Into<anyhow::Error>) -> Failure {
    Failure::BadInput(e.into())
}

/// Runs a parsed command line, writing its output to `out`.
pub fn run(cli: Cli, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    match cli.command {
        Command::Plan(args) => plan::run(&args, out),
        Command::MockPlc(args) => mock_plc::run(&args, out),
        Command::Serve(args) => serve::run(&args),
    }
}
