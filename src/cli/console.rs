//! `linterpd console hash-password`: an argon2id hash of a password read from standard input
//! (one line; never an argument, which other users see in the process list), as
//! `[console.users.NAME] password_hash` takes it.
//!
//! ```text
//! $ linterpd console hash-password
//! password: ********
//! $argon2id$v=19$m=19456,t=2,p=1$...$...
//! ```

use std::io::BufRead as _;

use anyhow::anyhow;
use clap::{Args, Subcommand};

use super::Failure;

/// Arguments of `linterpd console`.
#[derive(Debug, Args)]
pub struct ConsoleArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: ConsoleAction,
}

/// `linterpd console` actions.
#[derive(Debug, Subcommand)]
pub enum ConsoleAction {
    /// Read a password (one line of standard input) and print its argon2id hash for
    /// `[console.users.NAME] password_hash`.
    HashPassword,
}

/// Runs `linterpd console`.
pub fn run(args: &ConsoleArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    match args.action {
        ConsoleAction::HashPassword => {
            eprint!("password: ");
            let mut line = String::new();
            std::io::stdin()
                .lock()
                .read_line(&mut line)
                .map_err(|e| Failure::Runtime(e.into()))?;
            let password = line.trim_end_matches(['\n', '\r']);
            if password.len() < 8 {
                return Err(Failure::BadInput(anyhow!(
                    "the password is {} characters; at least 8",
                    password.chars().count()
                )));
            }
            let hash = crate::daemon::console::hash_password(password)
                .map_err(|e| Failure::Runtime(anyhow!("hashing the password: {e}")))?;
            writeln!(out, "{hash}").map_err(|e| Failure::Runtime(e.into()))
        }
    }
}
