//! `linterpd completions SHELL` and `linterpd man [--dir DIR]`: shell completion scripts and man
//! pages generated from the CLI's own clap definitions (`clap_complete`, `clap_mangen`), so they never
//! drift from the flags. A package installs their output (docs/CLI.md, "Shell completions and man
//! pages").
//!
//! Every page ends with an EXIT STATUS section: the codes every command shares
//! (`crate::cli`'s module docs) and what its own command adds (`status`, `cycle status`, Ctrl-C
//! on an attached `move`, `run` or `cycle run --follow`).
//!
//! ```text
//!  stdout:  the script, or linterpd(1) in roff (without --dir)
//!  exit:    0; 1 when a page cannot be written
//! ```

use std::fmt::Write as _;
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
        Some(dir) => {
            let mut cmd = command();
            cmd.build();
            write_pages(&cmd, dir)
                .with_context(|| format!("writing man pages into {}", dir.display()))
        }
        None => page(&command(), out).context("writing the man page"),
    }
    .map_err(Failure::Runtime)
}

/// A page for `cmd` and one for each of its subcommands, as `clap_mangen::generate_to` names
/// them (`linterpd-cycle-status.1`).
fn write_pages(cmd: &clap::Command, dir: &std::path::Path) -> std::io::Result<()> {
    for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set()) {
        write_pages(sub, dir)?;
    }
    let name = clap_mangen::Man::new(cmd.clone()).get_filename();
    let mut file = std::fs::File::create(dir.join(name))?;
    page(cmd, &mut file)
}

/// `cmd`'s page: `clap_mangen`'s sections, then EXIT STATUS.
fn page(cmd: &clap::Command, out: &mut dyn std::io::Write) -> std::io::Result<()> {
    clap_mangen::Man::new(cmd.clone()).render(out)?;
    let name = cmd.get_display_name().unwrap_or(cmd.get_name());
    out.write_all(exit_status(name).as_bytes())
}

/// The codes every command shares.
const EXIT_CODES: [(&str, &str); 5] = [
    ("0", "done"),
    (
        "1",
        "any other failure (the PLC refused or failed a command)",
    ),
    (
        "2",
        "bad input, nothing done: arguments, the config, a move or cycle program the daemon \
         refuses as impossible, a register outside the gateway's access list",
    ),
    (
        "3",
        "the robot did not do it: refused for its state now, a move that ended stopped, failed \
         or cancelled, a followed cycle that faulted or was stopped, move --timeout ran out",
    ),
    (
        "4",
        "the daemon cannot be reached, or it cannot reach the PLC now",
    ),
];

/// What a command's own page adds, by its page name.
fn own_codes(name: &str) -> Vec<(&'static str, &'static str)> {
    let mut own = Vec::new();
    if name == "linterpd" || name == "linterpd-status" {
        own.push((
            "status",
            "0 when every robot's link is up, no fault is latched and no cycle is faulted; 1 \
             when a robot reports a fault or its cycle is faulted; 3 when a robot's PLC link is \
             down or stalled",
        ));
    }
    if name == "linterpd" || name.starts_with("linterpd-cycle") {
        own.push((
            "cycle status",
            "1 when the cycle is faulted, else 0 (running, waiting, paused, stopped or done)",
        ));
        own.push((
            "cycle run --follow",
            "0 once the count is done; 3 when the cycle faults or is stopped, naming the step and \
             what it waited for",
        ));
    }
    if name == "linterpd"
        || name.starts_with("linterpd-cycle")
        || name == "linterpd-move"
        || name == "linterpd-run"
    {
        own.push((
            "130",
            "Ctrl-C on an attached move, run or cycle run --follow: it stopped what it started \
             first (the robot; the cycle and the robot at once). With --detach, Ctrl-C leaves \
             it running and exits 0",
        ));
    }
    own
}

/// The EXIT STATUS section of page `name`, in roff.
fn exit_status(name: &str) -> String {
    let mut roff = String::from(".SH \"EXIT STATUS\"\n");
    for (code, meaning) in EXIT_CODES.iter().chain(&own_codes(name)) {
        let _ = write!(roff, ".TP\n\\fB{}\\fR\n{}\n", escape(code), escape(meaning));
    }
    roff
}

/// Text as roff takes it: backslashes and hyphens escaped, no line starting with a dot.
fn escape(text: &str) -> String {
    let text = text.replace('\\', "\\e").replace('-', "\\-");
    if text.starts_with(['.', '\'']) {
        format!("\\&{text}")
    } else {
        text
    }
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
        let cycle_status = std::fs::read_to_string(dir.join("linterpd-cycle-status.1"));
        let status = std::fs::read_to_string(dir.join("linterpd-status.1"));
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(found, [true; 3]);
        let cycle_status = cycle_status.unwrap();
        assert!(
            cycle_status.contains(".SH \"EXIT STATUS\"")
                && cycle_status.contains("1 when the cycle is faulted"),
            "{cycle_status}"
        );
        let status = status.unwrap();
        assert!(
            status.contains("1 when a robot reports a fault or its cycle is faulted")
                && !status.contains("1 when the cycle is faulted"),
            "{status}"
        );
    }

    #[test]
    fn man_pages_exit_status_tells_a_faulted_robot_or_cycle_apart() {
        let mut out = Vec::new();
        man(&ManArgs { dir: None }, &mut out).unwrap();
        let page = String::from_utf8(out).unwrap();
        let section = page
            .split(".SH \"EXIT STATUS\"")
            .nth(1)
            .expect("an EXIT STATUS section");
        for said in [
            "\\fB130\\fR",
            "1 when a robot reports a fault or its cycle is faulted",
            "1 when the cycle is faulted",
            "cycle run \\-\\-follow",
        ] {
            assert!(section.contains(said), "{said:?} in\n{section}");
        }
        assert_eq!(escape("-x \\ y"), "\\-x \\e y");
        assert_eq!(escape(".TH"), "\\&.TH");
    }
}
