//! `linterpd io force | release | cell --mock PATH`: an operator's hand on a mock PLC's simulated
//! cell, through the control socket of `linterpd mock-plc --control PATH`
//! (`crate::mock::control`). A real PLC is never written this way: these requests go to a mock's
//! socket only, never to the daemon.
//!
//! ```text
//!  linterpd io force press_open off --mock /tmp/mock.sock   -> X5 forced off
//!  linterpd io release all --mock /tmp/mock.sock            -> released X5
//!  linterpd io cell --mock /tmp/mock.sock                   -> press[0] open, 3 strokes; ...
//!  exit:  0 done; 2 the mock refused the request (it names why); 4 no mock at PATH
//! ```

use std::path::{Path, PathBuf};

use anyhow::{Context, anyhow};
use clap::Args;
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::net::UnixStream;

use super::{Failure, bad_input};

/// The mock's control socket.
#[derive(Debug, Args)]
pub struct MockSocket {
    /// The control socket of `linterpd mock-plc --control PATH` (a mock only: a real PLC's
    /// inputs are its wiring's).
    #[arg(long, required = true)]
    pub mock: PathBuf,
}

/// Arguments of `linterpd io force`.
#[derive(Debug, Args)]
pub struct ForceArgs {
    /// The input: a signal's name in the mock's cell description, or an X or R bit (X5, R10).
    pub input: String,
    /// on or off (1/0, true/false).
    pub value: String,
    /// The mock.
    #[command(flatten)]
    pub mock: MockSocket,
}

/// Arguments of `linterpd io release`.
#[derive(Debug, Args)]
pub struct ReleaseArgs {
    /// The input forced before, or `all`.
    pub input: String,
    /// The mock.
    #[command(flatten)]
    pub mock: MockSocket,
}

/// Forces an input on a mock.
pub fn force(args: &ForceArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    let value = match args.value.to_ascii_lowercase().as_str() {
        "on" | "1" | "true" => "on",
        "off" | "0" | "false" => "off",
        _ => {
            return Err(bad_input(anyhow!(
                "value {:?}: an input is forced on or off (1/0, true/false)",
                args.value
            )));
        }
    };
    request(
        &args.mock.mock,
        &format!("force {} {value}", args.input),
        out,
    )
}

/// Releases a forced input (or all).
pub fn release(args: &ReleaseArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    request(&args.mock.mock, &format!("release {}", args.input), out)
}

/// Shows the mock's cell.
pub fn cell(args: &MockSocket, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    request(&args.mock, "status", out)
}

/// Sends one request line and prints the reply (an `error` reply is bad input).
fn request(socket: &Path, line: &str, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    if line.contains('\n') {
        return Err(bad_input(anyhow!("{line:?}: one line only")));
    }
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| Failure::Runtime(e.into()))?;
    let reply = runtime.block_on(exchange(socket, line))?;
    match reply.split_once(' ') {
        Some(("ok", text)) => writeln!(out, "{text}").map_err(|e| Failure::Runtime(e.into())),
        Some(("error", text)) => Err(bad_input(anyhow!("the mock refused: {text}"))),
        _ => Err(Failure::Runtime(anyhow!(
            "{} answered {reply:?}: is it a mock's control socket?",
            socket.display()
        ))),
    }
}

async fn exchange(socket: &Path, line: &str) -> Result<String, Failure> {
    let stream = UnixStream::connect(socket)
        .await
        .with_context(|| {
            format!(
                "cannot reach a mock at {} (start one with `linterpd mock-plc --control {}`)",
                socket.display(),
                socket.display()
            )
        })
        .map_err(Failure::Unreachable)?;
    let (read, mut write) = stream.into_split();
    write
        .write_all(format!("{line}\n").as_bytes())
        .await
        .map_err(|e| Failure::Runtime(e.into()))?;
    let mut reply = String::new();
    BufReader::new(read)
        .read_line(&mut reply)
        .await
        .map_err(|e| Failure::Runtime(e.into()))?;
    Ok(reply.trim_end().to_owned())
}
