//! `linterpd demo`: the seed's move and a few others through the daemon against a mock PLC in
//! process (the work is in [`crate::demo`]); prints a report and writes the picture.
//!
//! ```text
//!  stdout:  the report, then where the picture went
//!  exit:    0 every move done; 1 anything failed (one line on stderr); 2 bad arguments
//! ```

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::Failure;
use super::plan::ModelArg;
use crate::demo::{DEFAULT_BAUD, DemoLink, DemoOptions, run as run_demo, write_report};

/// Arguments of `linterpd demo`.
#[allow(clippy::struct_excessive_bools)] // each is a flag on the command line
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Write the picture (paths and deviation along the line) to this file.
    #[arg(long, value_name = "FILE", default_value = "linterpd-demo.svg")]
    pub svg: PathBuf,
    /// Do not draw the picture.
    #[arg(long, conflicts_with = "svg")]
    pub no_svg: bool,
    /// What the pulse channels really output (the planner plans for it, the mock plays it).
    #[arg(long, value_enum, default_value = "fpx-divider")]
    pub frequency_model: ModelArg,
    /// Speed of the emulated serial line to the mock, baud.
    #[arg(long, default_value_t = DEFAULT_BAUD, value_parser = clap::value_parser!(u32).range(300..))]
    pub baud: u32,
    /// Speak MEWTOCOL-COM in `<` frames (up to 2048 characters) rather than `%` frames (118).
    #[arg(long)]
    pub long_frames: bool,
    /// Speak Modbus RTU (binary frames) rather than MEWTOCOL-COM.
    #[arg(long, conflicts_with = "long_frames")]
    pub modbus_rtu: bool,
    /// Do not read uploads back before their start (a config's `read_back = false`).
    #[arg(long)]
    pub no_read_back: bool,
    /// Run the press-loading cycle program (config/examples/cycles/press-load.toml) 10 times
    /// against a simulated press instead, with one hold of the press's guard mid-cycle.
    #[arg(long)]
    pub cycle: bool,
    /// Serve the operator's console on the seed's robot in the simulated press cell instead, on
    /// `--listen` (loopback), until Ctrl-C; log in as operator / operator-demo (or viewer /
    /// viewer-demo, admin / admin-demo).
    #[arg(long, conflicts_with = "cycle")]
    pub console: bool,
    /// Build a pallet of 4 interlocked layers of 6 cases to full with a cycle program instead,
    /// and draw its layers (`--pallet-svg`).
    #[arg(long, conflicts_with_all = ["cycle", "console"])]
    pub pallet: bool,
    /// Where `--pallet` draws the pallet's layers.
    #[arg(long, value_name = "FILE", default_value = "linterpd-pallet.svg")]
    pub pallet_svg: PathBuf,
    /// Where `--console` listens.
    #[arg(long, default_value = "127.0.0.1:8470", requires = "console")]
    pub listen: std::net::SocketAddr,
}

/// What the flags ask of the demo's rig.
fn demo_options(args: &DemoArgs) -> DemoOptions {
    DemoOptions {
        baud: Some(args.baud),
        frequency_model: args.frequency_model.into(),
        svg: !args.no_svg,
        link: if args.modbus_rtu {
            DemoLink::ModbusRtu
        } else {
            DemoLink::Mewtocol {
                long_frames: args.long_frames,
            }
        },
        read_back: !args.no_read_back,
    }
}

/// Runs `linterpd demo`.
pub fn run(args: &DemoArgs, out: &mut dyn Write) -> Result<(), Failure> {
    let options = demo_options(args);
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")
        .map_err(Failure::Runtime)?;
    if args.console {
        return runtime.block_on(console(args, out));
    }
    if args.cycle {
        let demo = runtime
            .block_on(crate::demo::press::run(options))
            .context("demo --cycle")
            .map_err(Failure::Runtime)?;
        return crate::demo::press::write_press_report(&demo, out)
            .context("cannot write to stdout")
            .map_err(Failure::Runtime);
    }
    if args.pallet {
        return runtime.block_on(pallet(args, options, out));
    }
    let demo = runtime
        .block_on(run_demo(options))
        .context("demo")
        .map_err(Failure::Runtime)?;
    write_report(&demo, out)
        .context("cannot write to stdout")
        .map_err(Failure::Runtime)?;
    if let Some(svg) = &demo.svg {
        std::fs::write(&args.svg, svg)
            .with_context(|| format!("cannot write the picture to {}", args.svg.display()))
            .map_err(Failure::Runtime)?;
        writeln!(out, "Picture: {}", args.svg.display())
            .context("cannot write to stdout")
            .map_err(Failure::Runtime)?;
    }
    Ok(())
}

/// `demo --pallet`: the pallet built to full, its report, its picture.
async fn pallet(args: &DemoArgs, options: DemoOptions, out: &mut dyn Write) -> Result<(), Failure> {
    let demo = crate::demo::pallet::run(options)
        .await
        .context("demo --pallet")
        .map_err(Failure::Runtime)?;
    let svg = (!args.no_svg).then_some(args.pallet_svg.as_path());
    if let Some(path) = svg {
        std::fs::write(path, &demo.svg)
            .with_context(|| format!("cannot write the picture to {}", path.display()))
            .map_err(Failure::Runtime)?;
    }
    crate::demo::pallet::write_pallet_report(&demo, svg, out)
        .context("cannot write to stdout")
        .map_err(Failure::Runtime)
}

/// `demo --console`: the console on the mock until Ctrl-C.
async fn console(args: &DemoArgs, out: &mut dyn Write) -> Result<(), Failure> {
    if !args.listen.ip().is_loopback() {
        return Err(Failure::BadInput(anyhow::anyhow!(
            "--listen {}: the demo's console listens on loopback only (its passwords are known)",
            args.listen
        )));
    }
    let options = crate::demo::console::ConsoleOptions {
        listen: args.listen,
        baud: Some(args.baud),
        ..crate::demo::console::ConsoleOptions::default()
    };
    let rig = crate::demo::console::ConsoleRig::start(options)
        .await
        .context("demo --console")
        .map_err(Failure::Runtime)?;
    let users: Vec<String> = crate::demo::console::USERS
        .iter()
        .map(|(name, role, password)| format!("{name} / {password} ({})", role.name()))
        .collect();
    writeln!(
        out,
        "the console: http://{}/ (log in as {}); the robot on a mock PLC in a simulated press \
         cell; Ctrl-C ends it",
        rig.addr,
        users.join(", ")
    )
    .and_then(|()| out.flush())
    .map_err(|e| Failure::Runtime(e.into()))?;
    let _ = tokio::signal::ctrl_c().await;
    rig.stop().await;
    Ok(())
}
