//! `linterpd completions SHELL` and `linterpd man [--dir DIR]`: shell completion scripts and man
//! pages generated from the CLI's own clap definitions (`clap_complete`, `clap_mangen`), so they never
//! drift from the flags. A package installs their output (docs/CLI.md, "Shell completions and man
//! pages").
//!
//! ```text
//!  stdout:  the script, or linterpd(1) in roff (without --dir)
//!  exit:    0; 1 when a page cannot be written
//! ```

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, CommandFactory};
use clap_complete::Shell;

use super::{Cli, Failure};

/// Arguments of `linterpd completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell to complete for.
    #[arg(value_enum)]
    pub shell: Shell,
}

/// Arguments of `linterpd man`.
#[derive(Debug, Args)]
pub struct ManArgs {
    /// Write linterpd.1 and a page per subcommand (linterpd-move.1, ...) into this directory
    /// instead of printing linterpd.1.
    #[arg(long, value_name = "DIR")]
    pub dir: Option<PathBuf>,
}

/// The command line as clap describes it, without the `help` subcommand.
fn command() -> clap::Command {
    Cli::command().disable_help_subcommand(true)
}

/// Runs `linterpd completions`.
pub fn run(args: &CompletionsArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    // Into memory first: the generators panic on a failed write (a closed pipe).
    let mut script = Vec::new();
    clap_complete::generate(args.shell, &mut command(), "linterpd", &mut script);
    out.write_all(&script)
        .context("writing the completion script")
        .map_err(Failure::Runtime)
}

/// Runs `linterpd man`.
pub fn man(args: &ManArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    match &args.dir {
        Some(dir) => clap_mangen::generate_to(command(), dir)
            .with_context(|| format!("writing man pages into {}", dir.display())),
        None => clap_mangen::Man::new(command())
            .render(out)
            .context("writing the man page"),
    }
    .map_err(Failure::Runtime)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bash_completion_offers_every_subcommand() {
        let mut out = Vec::new();
        run(&CompletionsArgs { shell: Shell::Bash }, &mut out).unwrap();
        let script = String::from_utf8(out).unwrap();
        for sub in ["move", "home", "clear-fault", "status", "check-config"] {
            assert!(script.contains(sub), "{sub} missing");
        }
        assert!(script.contains("--tolerance") && script.contains("--timeout"));
    }

    #[test]
    fn man_page_is_roff_naming_the_subcommands() {
        let mut out = Vec::new();
        man(&ManArgs { dir: None }, &mut out).unwrap();
        let page = String::from_utf8(out).unwrap();
        assert!(page.starts_with(".ie") || page.contains(".TH"), "{page}");
        assert!(page.contains("clear\\-fault"), "{page}");
    }

    #[test]
    fn man_dir_gets_a_page_per_subcommand() {
        let dir = std::env::temp_dir().join(format!("linterpd-man-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        man(
            &ManArgs {
                dir: Some(dir.clone()),
            },
            &mut Vec::new(),
        )
        .unwrap();
        let pages = ["linterpd.1", "linterpd-move.1", "linterpd-clear-fault.1"];
        let found = pages.map(|p| dir.join(p).is_file());
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(found, [true; 3]);
    }
}
