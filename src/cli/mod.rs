//! The `linterpd` command line: one module per subcommand. `anyhow` lives here and in `main.rs`
//! only; every failure is sorted into one of the exit codes below.
//!
//! ```text
//!  0  done (for `status`: every robot's link is up and no fault is latched)
//!  1  any other failure (IO, the PLC refused or failed a command: a 502); `status`: a robot
//!     reports a fault
//!  2  bad input, nothing was done: arguments, config, a move the daemon refuses as impossible,
//!     a register outside the robot's gateway access list (400, 403, 404, 422)
//!  3  the robot did not do it: refused for its state now (409: not-homed, homing, faulted,
//!     not-ready, busy, no fault to clear), a move that ended stopped, failed or cancelled, or
//!     `move --timeout` ran out; `status`: a robot's PLC link is down or stalled (as
//!     `systemctl status` exits 3 for a unit that is not running)
//!  4  the daemon cannot be reached (not running, wrong socket, no permission on it), or it
//!     cannot reach the PLC now (503: link-down, stalled, shutting-down)
//!  130  Ctrl-C ended an attached `move`, `run` or `cycle run --follow`, which stopped what it
//!     started first (`--detach`: left it running, exit 0)
//! ```
//! `status` and `cycle status` also exit 1 for a faulted cycle. `--socket`, `--json` and
//! `--robot` are taken before or after a subcommand's action (`cycle --json run X`, `cycle run X
//! --json`).
//! A refusal's message ends with the API's `reason` word, e.g. `(reason: not-homed)`. Output to a
//! closed pipe (`linterpd plan ... | head -1`) ends quietly with 0.

pub mod args;
pub mod check_config;
pub mod clear_fault;
pub mod client;
pub mod commission;
pub mod completions;
pub mod console;
pub mod cycle;
pub mod demo;
mod failure;
pub mod home;
mod interrupt;
pub mod io;
pub mod io_mock;
pub mod log;
pub mod logging;
pub mod mock_plc;
pub mod mode;
pub mod moves;
pub mod pallet;
pub mod plan;
pub mod positions;
pub mod serve;
pub mod status;
pub mod stop;

use clap::{Parser, Subcommand};

pub use failure::{
    EXIT_BAD_INPUT, EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_NOT_DONE, EXIT_OK, EXIT_UNREACHABLE,
    Failure, bad_input,
};

/// What `--version` prints after the name: the package version and the commit it was built
/// from (`unknown` when built outside a git checkout; see build.rs).
pub const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (commit ",
    env!("LINTERPD_COMMIT"),
    ")"
);

/// linterpd: straight-line moves for PLC-driven robots.
#[derive(Debug, Parser)]
#[command(name = "linterpd", version = VERSION, about, long_about = None)]
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
    /// Plan one straight-line move (or a path of lines, arcs and blends, --path) and print its
    /// pulse tables and accuracy figures.
    Plan(plan::PlanArgs),
    /// Serve the mock PLC (MEWTOCOL-COM or Modbus, TCP or serial) until SIGINT / SIGTERM.
    MockPlc(mock_plc::MockPlcArgs),
    /// Ask the daemon for a move and follow it to its end: a straight line to a pose (--to), to a
    /// taught position (--to @NAME) or by an offset (--by), or a joint-space move (--joints).
    Move(moves::MoveArgs),
    /// Run a path file through the daemon (lines, arcs, blended corners; every section planned
    /// before anything moves) and follow its sections to their ends.
    Run(moves::RunArgs),
    /// Teach and manage the robot's named positions: save (the pose now), list, show, delete.
    Pos(positions::PosArgs),
    /// Show each robot's link, PLC state, pose and moves; exit 3 when a robot's PLC link is
    /// down or stalled, 1 when a robot reports a fault.
    Status(status::StatusArgs),
    /// Read or write the PLC's other registers (DT words; X, Y, R bits) through the daemon's
    /// register gateway, as the robot's access list allows.
    Io(io::IoArgs),
    /// Stop every channel of a robot now (queued moves are cancelled).
    Stop(stop::StopArgs),
    /// Run a cycle program (waits on the cell's inputs, interlocked moves), stop, pause,
    /// resume or watch it.
    Cycle(cycle::CycleArgs),
    /// Show or set who drives a robot: local (the CLI and the API) or remote (the line's PLC or
    /// HMI through the cell face); `stop` works in both.
    Mode(mode::ModeArgs),
    /// The cell's journal: faults, cycles, holds, mode changes, commands and who sent them,
    /// pallets, reloads (`--since`, `--follow`, `--json`), or production counts per shift
    /// (`--counts`).
    Log(log::LogArgs),
    /// Home a robot: the PLC's home routine sets every joint to its home count
    /// (`home_counts` in the config); returns when it has ended.
    Home(home::HomeArgs),
    /// Clear a fault latched on a robot's PLC (refused when there is none, or while it moves).
    ClearFault(clear_fault::ClearFaultArgs),
    /// The operator's console: `hash-password` makes a user's password hash for
    /// `[console.users.NAME]`.
    Console(console::ConsoleArgs),
    /// A robot's pallets: `show` lists a pallet's slots from the config (and draws its layers
    /// with --svg); `status`, `set`, `reset`, `redo`, `go-on` read and change their counts in
    /// the daemon.
    Pallet(pallet::PalletArgs),
    /// Check a configuration file without starting anything.
    CheckConfig(check_config::CheckConfigArgs),
    /// Check a real unit with the drives' power off: the link, the contract, tiny pulse tables
    /// per channel; report what fits and the config lines to paste.
    Commission(commission::CommissionArgs),
    /// Run the daemon: a worker per robot on its PLC link, the HTTP/JSON API on a Unix socket
    /// (docs/API.md), until SIGINT / SIGTERM.
    Serve(serve::ServeArgs),
    /// Print a shell completion script for linterpd (bash, zsh, fish, elvish, powershell).
    Completions(completions::CompletionsArgs),
    /// Print linterpd's man page (roff), or write a page per subcommand into a directory.
    Man(completions::ManArgs),
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

/// How to reach the daemon, and how to print (taken before or after a subcommand's action).
#[derive(Debug, clap::Args)]
pub struct DaemonArgs {
    /// The daemon's API socket.
    #[arg(long, global = true, env = "LINTERPD_SOCKET", default_value = client::DEFAULT_SOCKET)]
    pub socket: std::path::PathBuf,
    /// Print JSON (the API's own answers) instead of text.
    #[arg(long, global = true)]
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

/// Resolves the robot (`robot`, else the daemon's only one), POSTs
/// `/v1/robots/{robot}/{action}` and prints `{robot}: {done}`, or the answer as JSON.
fn robot_command(
    daemon: &DaemonArgs,
    robot: Option<&str>,
    action: &str,
    done: &str,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    daemon.block_on(async {
        let client = client::Client::new(&daemon.socket);
        let robot = client.robot(robot).await.map_err(Failure::from_client)?;
        let answer = client
            .expect(
                hyper::Method::POST,
                &format!("/v1/robots/{robot}/{action}"),
                None,
            )
            .await?;
        print(out, daemon.json, &answer, &format!("{robot}: {done}"))
    })
}

/// Runs a parsed command line, writing its output to `out`.
pub fn run(cli: Cli, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    match cli.command {
        Command::Demo(args) => demo::run(&args, out),
        Command::Plan(args) => plan::run(&args, out),
        Command::MockPlc(args) => mock_plc::run(&args, out),
        Command::Move(args) => moves::run(&args, out),
        Command::Run(args) => moves::run_path(&args, out),
        Command::Pos(args) => positions::run(&args, out),
        Command::Status(args) => status::run(&args, out),
        Command::Io(args) => io::run(&args, out),
        Command::Stop(args) => stop::run(&args, out),
        Command::Cycle(args) => cycle::run(&args, out),
        Command::Mode(args) => mode::run(&args, out),
        Command::Log(args) => log::run(&args, out),
        Command::Home(args) => home::run(&args, out),
        Command::ClearFault(args) => clear_fault::run(&args, out),
        Command::Console(args) => console::run(&args, out),
        Command::CheckConfig(args) => check_config::run(&args, out),
        Command::Pallet(args) => pallet::run(&args, out),
        Command::Commission(args) => commission::run(&args, out),
        Command::Serve(args) => serve::run(&args),
        Command::Completions(args) => completions::run(&args, out),
        Command::Man(args) => completions::man(&args, out),
    }
}
