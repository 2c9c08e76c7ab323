//! `linterpd pallet`: a robot's pallet patterns (`show`, from the config), and their counts in
//! the daemon (`status`, and the operator's `set`, `reset`, `redo`, `go-on`: `ops.rs`).
//!
//! ```text
//! linterpd pallet show out [--robot R] [--svg out.svg]
//!     -> pallet "out" of robot press-loader: 96 slots in 4 layers
//!        slot  layer  row  column        x        y        z       a
//!           0      1    1       1    700.0      0.0    100.0     0.0
//! linterpd pallet status [out] [--robot R] [--json]
//!     -> press-loader pallet out: slot 7 of 96 next, layer 1 of 4; 31 parts, 1 pallet done
//! linterpd pallet set out 12 | reset out | redo out | go-on out
//! ```
//! `show` works offline from the config file (no daemon): a pallet whose frame or corners name
//! taught positions is laid out with the positions in the config's state directory.

mod ops;
mod show;

use std::path::PathBuf;

use clap::{Args, Subcommand};

use super::{DaemonArgs, Failure};

/// Arguments of `linterpd pallet`.
#[derive(Debug, Args)]
pub struct PalletArgs {
    /// What to do.
    #[command(subcommand)]
    pub action: PalletAction,
    /// The robot (needed when the config has several).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// The configuration file.
    #[arg(
        long,
        global = true,
        env = "LINTERPD_CONFIG",
        default_value = "/etc/linterpd/linterpd.toml"
    )]
    pub config: PathBuf,
    /// The daemon and output options (all but `show`).
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// `linterpd pallet` actions: one on the config, the others on the daemon's counts.
#[derive(Debug, Subcommand)]
pub enum PalletAction {
    /// List a pallet's slots in fill order (index, layer, row, column, x y z a), from the config.
    Show(show::ShowArgs),
    /// The counts in the daemon (`status`, `set`, `reset`, `redo`, `go-on`), each a
    /// subcommand of `pallet` itself.
    #[command(flatten)]
    Counts(ops::CountAction),
}

/// Runs `linterpd pallet`.
pub fn run(args: &PalletArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    match &args.action {
        PalletAction::Show(show) => show::run(args, show, out),
        PalletAction::Counts(action) => ops::run(args, action, out),
    }
}
