//! The `linterpd` command line: one module per subcommand. `anyhow` lives here and in `main.rs`
//! only; every failure is sorted into bad input (exit 2) or a runtime failure (exit 1).

pub mod args;
pub mod check_config;
pub mod client;
pub mod demo;
pub mod logging;
pub mod mock_plc;
pub mod moves;
pub mod plan;
pub mod serve;
pub mod status;
pub mod stop;

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
    /// Run the seed's move and a few others through the daemon against a mock PLC in process,
    /// and report how closely they followed the line (no hardware, no config file).
    Demo(demo::DemoArgs),
    /// Plan one straight-line move and print its pulse tables and accuracy figures.
    Plan(plan::PlanArgs),
    /// Serve the mock PLC (MEWTOCOL-COM or Modbus, TCP or serial) until SIGINT / SIGTERM.
    MockPlc(mock_plc::MockPlcArgs),
    /// Ask the daemon for a straight-line move and follow it to its end.
    Move(moves::MoveArgs),
    /// Show each robot's link, PLC state, pose and moves.
    Status(status::StatusArgs),
    /// Stop every channel of a robot now (queued moves are cancelled).
    Stop(stop::StopArgs),
    /// Check a configuration file without starting anything.
    CheckConfig(check_config::CheckConfigArgs),
    /// Run the daemon: a worker per robot on its PLC link, the HTTP/JSON API on a Unix socket
    /// (docs/API.md), until SIGINT / SIGTERM.
    Serve(serve::ServeArgs),
}

impl Command {
    /// The log level when `RUST_LOG` gives none: the daemon and the mock PLC log their work.
    #[must_use]
    pub fn default_log_level(&self) -> &'static str {
        match self {
            Self::MockPlc(_) | Self::Serve(_) => "info",
            _ => "error",
        }
    }
}

/// How to reach the daemon, and how to print.
#[derive(Debug, clap::Args)]
pub struct DaemonArgs {
    /// The daemon's API socket.
    #[arg(long, env = "LINTERPD_SOCKET", default_value = client::DEFAULT_SOCKET)]
    pub socket: std::path::PathBuf,
    /// Print JSON (the API's own answers) instead of text.
    #[arg(long)]
    pub json: bool,
}

impl DaemonArgs {
    /// Runs a client future on a small runtime of its own.
    pub fn block_on<T>(
        &self,
        f: impl std::future::Future<Output = Result<T, Failure>>,
    ) -> Result<T, Failure> {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| Failure::Runtime(e.into()))?
            .block_on(f)
    }
}

/// Prints `json` or `text`, as asked.
fn print(
    out: &mut dyn std::io::Write,
    json: bool,
    value: &serde_json::Value,
    text: &str,
) -> Result<(), Failure> {
    let written = if json {
        writeln!(out, "{value}")
    } else {
        writeln!(out, "{text}")
    };
    written.map_err(|e| Failure::Runtime(e.into()))
}

/// Exit code for a run that worked.
pub const EXIT_OK: u8 = 0;
/// Exit code for a failure that is not the input's fault (IO, a bug).
pub const EXIT_FAILURE: u8 = 1;
/// Exit code for bad input: config, arguments, an impossible move (a 4xx from the daemon).
/// Nothing was done.
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit code for a move that was accepted but ended stopped or failed.
pub const EXIT_MOVE_ENDED: u8 = 3;
/// Exit code when the daemon cannot be reached (not running, wrong socket).
pub const EXIT_UNREACHABLE: u8 = 4;

/// A failed run: what went wrong and whose fault it was.
#[derive(Debug)]
pub enum Failure {
    /// The input is wrong (exit 2).
    BadInput(anyhow::Error),
    /// Something else failed (exit 1).
    Runtime(anyhow::Error),
    /// The move ended stopped or failed (exit 3).
    MoveEnded(anyhow::Error),
    /// The daemon cannot be reached (exit 4).
    Unreachable(anyhow::Error),
}

impl Failure {
    /// The process exit code for this failure.
    #[must_use]
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::BadInput(_) => EXIT_BAD_INPUT,
            Self::Runtime(_) => EXIT_FAILURE,
            Self::MoveEnded(_) => EXIT_MOVE_ENDED,
            Self::Unreachable(_) => EXIT_UNREACHABLE,
        }
    }

    /// A client error: unreachable if the daemon is not there, else a runtime failure.
    #[must_use]
    pub fn from_client(e: anyhow::Error) -> Self {
        if e.downcast_ref::<client::NotRunning>().is_some() {
            Self::Unreachable(e)
        } else {
            Self::Runtime(e)
        }
    }

    /// A failure for an error answer: 4xx is bad input, anything else a runtime failure.
    #[must_use]
    pub fn from_status(status: hyper::StatusCode, e: anyhow::Error) -> Self {
        if status.is_client_error() {
            Self::BadInput(e)
        } else {
            Self::Runtime(e)
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (Self::BadInput(e) | Self::Runtime(e) | Self::MoveEnded(e) | Self::Unreachable(e)) =
            self;
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
        Command::Demo(args) => demo::run(&args, out),
        Command::Plan(args) => plan::run(&args, out),
        Command::MockPlc(args) => mock_plc::run(&args, out),
        Command::Move(args) => moves::run(&args, out),
        Command::Status(args) => status::run(&args, out),
        Command::Stop(args) => stop::run(&args, out),
        Command::CheckConfig(args) => check_config::run(&args, out),
        Command::Serve(args) => serve::run(&args),
    }
}
