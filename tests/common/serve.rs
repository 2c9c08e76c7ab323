//! A real `linterpd mock-plc` and a real `linterpd serve` on it, as a line PC would run them.

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;

use super::process::{Spawned, TempDir};

/// How long a process may take to say it is ready.
pub const READY: Duration = Duration::from_secs(20);

const SHIPPED: &str = include_str!("../../config/linterpd.toml");

/// The shipped config's robot, with a TCP link to `address` and the API socket at `socket`.
pub fn config_for(address: &str, socket: &std::path::Path) -> String {
    let dir = socket.parent().expect("the socket is in a directory");
    config_with_state_dir(address, socket, dir)
}

/// As [`config_for`], the daemon's state in `state_dir`.
pub fn config_with_state_dir(
    address: &str,
    socket: &std::path::Path,
    state_dir: &std::path::Path,
) -> String {
    let robot = SHIPPED
        .split("[robots.press-loader.plc]")
        .next()
        .expect("the shipped config has a robot");
    format!(
        "{robot}[robots.press-loader.plc]\nprotocol = \"mewtocol\"\ntcp = {{ address = \"{address}\" }}\n\
         [daemon]\nsocket = \"{}\"\nstate_dir = \"{}\"\n",
        socket.display(),
        state_dir.display()
    )
}

/// The mock PLC and the daemon on it, both running; the daemon connected.
pub struct Running {
    /// `linterpd mock-plc`.
    pub mock: Spawned,
    /// `linterpd serve`.
    pub serve: Spawned,
    /// The daemon's API socket.
    pub socket: PathBuf,
    /// Its config file.
    pub config: PathBuf,
    _dir: TempDir,
}

/// Starts `linterpd mock-plc` on a free port and `linterpd serve` on it.
pub fn start() -> Running {
    start_with(&[])
}

/// As [`start`], with more `linterpd mock-plc` arguments (`--unhomed`, `--faults ...`).
pub fn start_with(mock_args: &[&str]) -> Running {
    start_with_config(mock_args, "")
}

/// As [`start_with`], with `extra` TOML at the end of the daemon's config (a robot's gateway).
pub fn start_with_config(mock_args: &[&str], extra: &str) -> Running {
    start_in(mock_args, extra, None)
}

/// As [`start`], the daemon's state directory at `state_dir` under its temp dir (which need
/// not exist).
pub fn start_with_state_dir(state_dir: &str) -> Running {
    start_in(&[], "", Some(state_dir))
}

fn start_in(mock_args: &[&str], extra: &str, state_dir: Option<&str>) -> Running {
    let bin = env!("CARGO_BIN_EXE_linterpd");
    let mut mock_command = Command::new(bin);
    mock_command.args([
        "mock-plc",
        "--listen",
        "127.0.0.1:0",
        "--protocol",
        "mewtocol",
    ]);
    mock_command.args(mock_args);
    let mut mock = Spawned::spawn("linterpd mock-plc", mock_command);
    let address = mock.first_line_after("listening on ", READY);
    let dir = TempDir::new("serve");
    let socket = dir.path().join("api.sock");
    let config = dir.path().join("linterpd.toml");
    let state_dir = state_dir.map_or_else(|| dir.path().to_owned(), |s| dir.path().join(s));
    let text = config_with_state_dir(&address, &socket, &state_dir) + extra;
    std::fs::write(&config, text).unwrap();
    let mut serve_command = Command::new(bin);
    serve_command.arg("serve").arg("--config").arg(&config);
    let mut serve = Spawned::spawn("linterpd serve", serve_command);
    serve.wait_for_stderr("API listening", READY);
    serve.wait_for_stderr("press-loader: connected", READY);
    Running {
        mock,
        serve,
        socket,
        config,
        _dir: dir,
    }
}
