//! The `linterpd` binary: parse the command line, set up logging, run, map failures to exit codes
//! (see the module docs of `linterpd::cli`: 0 ok, 1 runtime failure, 2 bad input, 3 not done, 4
//! daemon or PLC not reachable; clap's own usage errors also exit 2). Output to a closed pipe
//! ends quietly with 0.

use std::process::ExitCode;

use clap::Parser;
use linterpd::cli::{Cli, EXIT_OK, logging, run};

fn main() -> ExitCode {
    let cli = Cli::parse();
    logging::init(cli.command.default_log_level());
    let stdout = std::io::stdout();
    match run(cli, &mut stdout.lock()) {
        Ok(()) => ExitCode::from(EXIT_OK),
        Err(failure) if failure.is_broken_pipe() => ExitCode::from(EXIT_OK),
        Err(failure) => {
            if let Some(e) = failure.error() {
                eprintln!("error: {e:#}");
            }
            ExitCode::from(failure.exit_code())
        }
    }
}
