//! The `linterpd` binary: parse the command line, set up logging, run, map failures to exit codes
//! (0 ok, 1 runtime failure, 2 bad input, 3 a move ended stopped or failed, 4 daemon not
//! reachable; clap's own usage errors also exit 2).

use std::process::ExitCode;

use clap::Parser;
use linterpd::cli::{Cli, EXIT_OK, logging, run};

fn main() -> ExitCode {
    let cli = Cli::parse();
    logging::init(cli.command.default_log_level());
    let stdout = std::io::stdout();
    match run(cli, &mut stdout.lock()) {
        Ok(()) => ExitCode::from(EXIT_OK),
        Err(failure) => {
            eprintln!("error: {failure}");
            ExitCode::from(failure.exit_code())
        }
    }
}
