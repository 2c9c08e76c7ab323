//! `linterpd pallet show NAME [--svg FILE]`: a pallet's slots from the config, and a picture of
//! its layers.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::anyhow;
use clap::Args;

use super::PalletArgs;
use crate::cli::{Failure, bad_input};
use crate::config::Config;
use crate::pallet::Pattern;

/// Arguments of `linterpd pallet show`.
#[derive(Debug, Args)]
pub struct ShowArgs {
    /// The pallet's name (`[robots.ROBOT.pallets.NAME]`).
    pub name: String,
    /// Also write an SVG of its layers (every slot outlined) to this file.
    #[arg(long)]
    pub svg: Option<PathBuf>,
}

/// Runs `linterpd pallet show`.
pub(super) fn run(
    args: &PalletArgs,
    show: &ShowArgs,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let config = Config::load(&args.config).map_err(bad_input)?;
    let robot = config.robot(args.robot.as_deref()).map_err(bad_input)?;
    let set = config.pallets.get(&robot.name);
    let Some(set) = set.filter(|s| s.layouts.contains_key(&show.name)) else {
        let known: Vec<&str> = set
            .iter()
            .flat_map(|s| s.layouts.keys())
            .map(String::as_str)
            .collect();
        return Err(bad_input(anyhow!(
            "robot {} has no pallet {:?}; {}",
            robot.name,
            show.name,
            if known.is_empty() {
                "it has none".to_owned()
            } else {
                format!("it has {}", known.join(", "))
            }
        )));
    };
    let taught = if set.needs_taught(&show.name) {
        let kept =
            crate::daemon::positions::TaughtPositions::in_state_dir(&config.daemon.state_dir)
                .of(&robot.name);
        // Those kept in a frame where the frame is now, as the daemon lays the pallet out.
        set.world_positions(robot, &kept).map_err(bad_input)?
    } else {
        BTreeMap::new()
    };
    let pattern = set.pattern(&show.name, robot, &taught).map_err(bad_input)?;
    if let Some(file) = &show.svg {
        std::fs::write(file, crate::plot::layers_svg(&pattern, 0))
            .map_err(|e| Failure::Runtime(anyhow!("cannot write {}: {e}", file.display())))?;
    }
    out.write_all(listing(&robot.name, &pattern).as_bytes())
        .map_err(|e| Failure::Runtime(e.into()))
}

/// The slots as a table, layers, rows and columns counted from 1.
fn listing(robot: &str, pattern: &Pattern) -> String {
    let mut text = format!(
        "pallet {:?} of robot {robot}: {} slots in {} layers\n{:>5} {:>6} {:>4} {:>7} {:>9} {:>9} {:>9} {:>7}\n",
        pattern.name(),
        pattern.len(),
        pattern.layers(),
        "slot",
        "layer",
        "row",
        "column",
        "x",
        "y",
        "z",
        "a"
    );
    for s in pattern.slots() {
        let [x, y, z, a] = s.pose.to_mm_deg();
        let _ = writeln!(
            text,
            "{:>5} {:>6} {:>4} {:>7} {x:>9.1} {y:>9.1} {z:>9.1} {a:>7.1}",
            s.index,
            s.layer + 1,
            s.row + 1,
            s.column + 1
        );
    }
    if let Some(program) = &pattern.between_layers {
        let _ = writeln!(text, "between layers: {program}");
    }
    let w = &pattern.when_full;
    let full: Vec<String> = [
        ("signal", &w.signal),
        ("wait for", &w.wait_for),
        ("call", &w.call),
    ]
    .into_iter()
    .filter_map(|(k, v)| v.as_ref().map(|v| format!("{k} {v}")))
    .collect();
    if !full.is_empty() {
        let _ = writeln!(text, "when full: {}", full.join(", "));
    }
    text
}
