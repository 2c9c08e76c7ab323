//! The `linterpd` binary: parse the command line, set up logging, run, map failures to exit codes
//! (0 ok, 1 runtime failure, 2 bad input; clap's own usage errors also exit 2).

use std::process::ExitCode;

use clap::Parser;
use linterpd::cli::{Cli, EXIT_OK, run};

fn main() -> ExitCode {
    let cli = Cli::parse();
    // The mock PLC logs its connections, starts, stops and faults unless RUST_LOG says otherwise.
    let default_level = match cli.command {
        linterpd::cli::Command::MockPlc(_) => "info",
        linterpd::cli::Command::Plan(_) | linterpd::cli::Command::Demo(_) => "error",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_level));
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    let stdout = std::io::stdout();
    match run(cli, &mut stdout.lock()) {
        Ok(()) => ExitCode::from(EXIT_OK),
        Err(failure) => {
            eprintln!("error: {failure}");
            ExitCode::from(failure.exit_code())
        }
    }
}
