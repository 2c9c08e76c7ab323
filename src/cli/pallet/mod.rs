//! `linterpd pallet`: a robot's pallet patterns.
//!
//! ```text
//! linterpd pallet show out [--robot R] [--svg out.svg]
//!     -> pallet "out" of robot press-loader: 96 slots in 4 layers
//!        slot  layer  row  column        x        y        z       a
//!           0      1    1       1    700.0      0.0    100.0     0.0
//! ```
//! `show` works offline from the config file (no daemon): a pallet whose frame or corners name
//! taught positions is laid out with the positions in the config's state directory.

mod show;

use std::path::PathBuf;

use clap::{Args, Subcommand};

use super::Failure;

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
}

/// `linterpd pallet` actions.
#[derive(Debug, Subcommand)]
pub enum PalletAction {
    /// List a pallet's slots in fill order (index, layer, row, column, x y z a), from the config.
    Show(show::ShowArgs),
}

/// Runs `linterpd pallet`.
pub fn run(args: &PalletArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    match &args.action {
        PalletAction::Show(show) => show::run(args, show, out),
    }
}
