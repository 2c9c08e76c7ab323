//! `linterpd mock-plc`: serve the mock PLC over MEWTOCOL-COM or Modbus, on a TCP listener or a
//! serial port, until SIGINT or SIGTERM; with `--cell FILE`, a simulated cell (a press, a stack,
//! sensors: `crate::mock::cell`) drives its inputs; with `--control PATH`, a Unix socket takes
//! `linterpd io force` requests for them.
//!
//! ```text
//!  stdout, first line:  listening on 127.0.0.1:40123     (the bound port; or the serial path)
//!  stderr:              tracing log of connections, starts, stops, injected faults, forces
//!  exit:                0 after a signal; 2 for bad arguments; 1 when serving fails
//! ```

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, anyhow};
use clap::{Args, ValueEnum};
use tokio::net::TcpListener;
use tokio::task::JoinHandle;
use tokio_serial::SerialPortBuilderExt;

use super::plan::ModelArg;
use super::{Failure, bad_input};
use crate::config::parse_duration_s;
use crate::mock::cell::{Cell, Description};
use crate::mock::{
    FaultScript, MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, MockVariant,
    ModbusServer, ModbusServerOptions, SharedMock, StationFilter, control, write_csv,
};
use crate::table::FrequencyModel;

/// Baud rate a serial port opens at when `--baud` is not given.
const DEFAULT_SERIAL_BAUD: u32 = 9600;

/// Arguments of `linterpd mock-plc`.
#[derive(Debug, Args)]
pub struct MockPlcArgs {
    /// TCP address to listen on, e.g. `127.0.0.1:9094` (port 0: any free port).
    #[arg(long, conflicts_with = "serial", required_unless_present = "serial")]
    pub listen: Option<String>,
    /// Serial port to serve on (a real port or a pty), opened 8 data bits, odd parity, 1 stop.
    #[arg(long)]
    pub serial: Option<String>,
    /// Protocol: over TCP `modbus` is Modbus TCP, over a serial port Modbus RTU.
    #[arg(long, value_enum, default_value = "mewtocol")]
    pub protocol: ProtocolArg,
    /// Station (MEWTOCOL-COM 1-99) or unit id (Modbus 1-247) answered (default: every station
    /// for MEWTOCOL-COM, 1 for Modbus).
    #[arg(long)]
    pub station: Option<String>,
    /// Line speed: emulated on TCP (11-bit characters, replies at the end of a scan); over
    /// serial, the port's speed, also emulated for MEWTOCOL-COM (default: none over TCP, 9600).
    #[arg(long)]
    pub baud: Option<String>,
    /// Scan time, e.g. `2ms`.
    #[arg(long, default_value = "2ms")]
    pub scan: String,
    /// What the pulse channels really output.
    #[arg(long, value_enum)]
    pub frequency_model: Option<ModelArg>,
    /// Write every pulse as CSV (`time_s,channel,count`) here at exit.
    #[arg(long)]
    pub trace: Option<PathBuf>,
    /// Fault script, items separated by commas, e.g. `drop@3,corrupt@1%,prog@t=5,seed=7`.
    /// `ACTION@K` at command number K (the first is 1), `ACTION@t=S` at S seconds (core actions
    /// only), `ACTION@P%` on each command with probability P percent (link actions only),
    /// `seed=N`. Link actions: drop, corrupt, close, `delay<ms>`, `error<NN>` (MEWTOCOL-COM),
    /// `exception<N>` (Modbus). Core actions: freeze, thaw (the heartbeat), prog, run (the mode),
    /// restart (a power cycle: counts 0, homed bit clear, first scan; e.g. `restart@t=2`).
    #[arg(long, allow_hyphen_values = true)]
    pub faults: Option<String>,
    /// Start with the homed bit clear, as a PLC does at power-up: moves are refused until
    /// `linterpd home` (default: homed, as a machine homed before linterpd came).
    #[arg(long)]
    pub unhomed: bool,
    /// Behave like the reference listing, or misbehave in one way `linterpd commission` must
    /// find.
    #[arg(long, value_enum, default_value = "listing")]
    pub variant: VariantArg,
    /// A cell description (TOML: signals, a press, a stack, sensors, constants) whose models
    /// drive the inputs every scan, e.g. config/examples/cells/press.toml.
    #[arg(long)]
    pub cell: Option<PathBuf>,
    /// A Unix socket taking `linterpd io force|release|cell --mock PATH` requests: force an
    /// input on or off, release it, show the cell.
    #[arg(long)]
    pub control: Option<PathBuf>,
}

/// `--variant`: the listing, or one defect a real FP-X might have.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum VariantArg {
    /// The reference listing as deploy/plc/README.md expects it.
    Listing,
    /// The busy relays never rise: busy word 0, fault 2 never; segments end by the count.
    BusyNeverRises,
    /// A stop only pauses F174; the next start on the channel resumes the stopped table.
    StopPauses,
    /// `<` frames get no answer.
    AngleRefused,
    /// MEWTOCOL replies longer than one frame get no answer (no multi-frame replies).
    OneFrameReplies,
    /// MEWTOCOL reads/writes above 64 words get `! 41`, Modbus requests above 100 registers
    /// exception 03.
    SmallRequests,
    /// The channels follow the fpx-divider model, whatever --frequency-model says.
    DividerClock,
    /// The channels output exactly the value written, whatever --frequency-model says.
    IdealClock,
    /// Version 2's logic reporting version 3: the permit is never checked (no fault 8 or 9).
    IgnoresPermit,
}

impl VariantArg {
    /// The mock's variant.
    #[must_use]
    pub fn variant(self) -> MockVariant {
        match self {
            Self::Listing => MockVariant::Listing,
            Self::BusyNeverRises => MockVariant::BusyNeverRises,
            Self::StopPauses => MockVariant::StopPauses,
            Self::AngleRefused => MockVariant::AngleRefused,
            Self::OneFrameReplies => MockVariant::OneFrameReplies,
            Self::SmallRequests => MockVariant::SmallRequests,
            Self::DividerClock => MockVariant::DividerClock,
            Self::IdealClock => MockVariant::IdealClock,
            Self::IgnoresPermit => MockVariant::IgnoresPermit,
        }
    }
}

/// `--protocol`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ProtocolArg {
    /// MEWTOCOL-COM.
    Mewtocol,
    /// Modbus TCP over `--listen`, Modbus RTU over `--serial`.
    Modbus,
}

impl std::fmt::Display for ProtocolArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Mewtocol => "mewtocol",
            Self::Modbus => "modbus",
        })
    }
}

/// Where the mock listens.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Endpoint {
    Tcp(String),
    Serial(String),
}

/// The arguments, checked.
#[derive(Debug)]
struct Settings {
    endpoint: Endpoint,
    protocol: ProtocolArg,
    station: StationFilter,
    baud: Option<u32>,
    config: MockConfig,
    trace: Option<PathBuf>,
    faults: FaultScript,
    cell: Option<Description>,
    control: Option<PathBuf>,
}

/// Reads and checks the cell description at `path`, naming the file in any error.
pub fn read_cell(path: &std::path::Path) -> anyhow::Result<Description> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read the cell description {}", path.display()))?;
    Description::from_toml(&text).with_context(|| format!("cell description {}", path.display()))
}

fn parse_station(text: &str, protocol: ProtocolArg) -> anyhow::Result<StationFilter> {
    let max = match protocol {
        ProtocolArg::Mewtocol => 99,
        ProtocolArg::Modbus => 247,
    };
    match text.trim().parse::<u8>() {
        Ok(n) if (1..=max).contains(&n) => Ok(StationFilter::Only(n)),
        _ => Err(anyhow!(
            "--station '{text}' is not a station number 1..={max}"
        )),
    }
}

fn parse_baud(text: &str) -> anyhow::Result<u32> {
    match text.trim().parse::<u32>() {
        Ok(n) if (300..=10_000_000).contains(&n) => Ok(n),
        _ => Err(anyhow!("--baud '{text}' is not a baud rate 300..=10000000")),
    }
}

fn validate(args: &MockPlcArgs) -> anyhow::Result<Settings> {
    let endpoint = match (&args.listen, &args.serial) {
        (Some(address), None) => Endpoint::Tcp(address.clone()),
        (None, Some(path)) => Endpoint::Serial(path.clone()),
        _ => {
            return Err(anyhow!(
                "give exactly one of --listen ADDR and --serial PATH"
            ));
        }
    };
    let station = match (&args.station, args.protocol) {
        (Some(text), protocol) => parse_station(text, protocol)?,
        (None, ProtocolArg::Mewtocol) => StationFilter::Any,
        (None, ProtocolArg::Modbus) => StationFilter::Only(1),
    };
    let baud = args.baud.as_deref().map(parse_baud).transpose()?;
    let scan_s = parse_duration_s(&args.scan).with_context(|| format!("--scan '{}'", args.scan))?;
    let model = match args.frequency_model {
        Some(ModelArg::FpxDivider) => FrequencyModel::FpxDivider,
        Some(ModelArg::Ideal) => FrequencyModel::Ideal,
        None => FrequencyModel::default(),
    };
    let config = MockConfig {
        scan_s,
        model,
        homed: !args.unhomed,
        variant: args.variant.variant(),
        ..MockConfig::default()
    };
    MockPlc::new(config).with_context(|| format!("--scan '{}'", args.scan))?;
    let faults = FaultScript::parse(args.faults.as_deref().unwrap_or(""))
        .with_context(|| format!("--faults '{}'", args.faults.as_deref().unwrap_or("")))?;
    let cell = args.cell.as_deref().map(read_cell).transpose()?;
    Ok(Settings {
        endpoint,
        protocol: args.protocol,
        station,
        baud,
        config,
        trace: args.trace.clone(),
        faults,
        cell,
        control: args.control.clone(),
    })
}

/// Runs `linterpd mock-plc` until SIGINT or SIGTERM.
pub fn run(args: &MockPlcArgs, out: &mut dyn Write) -> Result<(), Failure> {
    let settings = validate(args).map_err(bad_input)?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")
        .map_err(Failure::Runtime)?;
    runtime.block_on(serve(settings, out))
}

fn new_mock(settings: &Settings) -> anyhow::Result<SharedMock> {
    let mut mock = MockPlc::new(settings.config)?;
    mock.set_faults(settings.faults.clone());
    mock.record_pulses(settings.trace.is_some());
    if let Some(description) = &settings.cell {
        mock.set_cell(Cell::new(description.clone()));
    }
    Ok(SharedMock::new(mock))
}

async fn serve(settings: Settings, out: &mut dyn Write) -> Result<(), Failure> {
    let shared = new_mock(&settings).map_err(bad_input)?;
    shared.with(|_| ()); // scan 0: the status block is live (magic, RUN) before anyone connects
    let driver = tokio::spawn(shared.clone().run_scans());
    let control = serve_control(&settings, &shared)?;
    // Before "listening on" is printed: a SIGTERM sent as soon as that line is read ends it.
    let shutdown = crate::daemon::service::shutdown_signal();
    let (server, shown) = start_server(&settings, &shared).await?;
    writeln!(out, "listening on {shown}")
        .and_then(|()| out.flush())
        .context("cannot write to stdout")
        .map_err(Failure::Runtime)?;
    log_started(&settings, &shared, &shown);
    let outcome = tokio::select! {
        () = shutdown => Ok(()),
        ended = server => Err(anyhow!("the server stopped: {}", match ended {
            Ok(Ok(())) => "its link closed".to_owned(),
            Ok(Err(e)) => format!("{e:#}"),
            Err(e) => e.to_string(),
        })),
    };
    driver.abort();
    if let Some(task) = control {
        task.abort();
    }
    if let Some(path) = &settings.control {
        let _ = std::fs::remove_file(path);
    }
    tracing::info!("mock PLC stopping");
    if let Some(path) = &settings.trace {
        write_trace(&shared, path).map_err(Failure::Runtime)?;
    }
    outcome.map_err(Failure::Runtime)
}

/// The control socket (`--control`), served by a task of its own.
fn serve_control(
    settings: &Settings,
    shared: &SharedMock,
) -> Result<Option<JoinHandle<()>>, Failure> {
    let Some(path) = &settings.control else {
        return Ok(None);
    };
    let listener = control::bind(path)
        .with_context(|| format!("cannot listen on --control '{}'", path.display()))
        .map_err(bad_input)?;
    Ok(Some(tokio::spawn(control::serve(listener, shared.clone()))))
}

/// The log's line that the mock PLC runs, listening on `shown`, and its cell if it simulates one.
fn log_started(settings: &Settings, shared: &SharedMock, shown: &str) {
    tracing::info!(
        protocol = %settings.protocol,
        station = %settings.station,
        baud = %settings.baud.map_or_else(|| "none".to_owned(), |b| b.to_string()),
        scan_s = settings.config.scan_s,
        variant = settings.config.variant.name(),
        "mock PLC in RUN, listening on {shown}"
    );
    if settings.cell.is_some() {
        tracing::info!(cell = %shared.with(|m| m.cell().describe()), "simulated cell");
    }
}

type ServerTask = JoinHandle<anyhow::Result<()>>;

async fn start_server(
    settings: &Settings,
    shared: &SharedMock,
) -> Result<(ServerTask, String), Failure> {
    match &settings.endpoint {
        Endpoint::Tcp(address) => {
            let listener = TcpListener::bind(address)
                .await
                .with_context(|| format!("cannot listen on --listen '{address}'"))
                .map_err(bad_input)?;
            let local = listener
                .local_addr()
                .map_err(|e| Failure::Runtime(e.into()))?;
            Ok((spawn_tcp(settings, shared, listener), local.to_string()))
        }
        Endpoint::Serial(path) => {
            let baud = settings.baud.unwrap_or(DEFAULT_SERIAL_BAUD);
            let port = tokio_serial::new(path, baud)
                .parity(tokio_serial::Parity::Odd)
                .open_native_async()
                .with_context(|| format!("cannot open --serial '{path}' at {baud} baud"))
                .map_err(bad_input)?;
            Ok((spawn_serial(settings, shared, port), path.clone()))
        }
    }
}

fn spawn_tcp(settings: &Settings, shared: &SharedMock, listener: TcpListener) -> ServerTask {
    let (station, baud) = (settings.station, settings.baud);
    match settings.protocol {
        ProtocolArg::Mewtocol => {
            let server =
                MewtocolServer::new(shared.clone(), MewtocolServerOptions { station, baud });
            tokio::spawn(async move { Ok(server.serve_tcp(listener).await?) })
        }
        ProtocolArg::Modbus => {
            let options = ModbusServerOptions {
                unit: station,
                baud,
            };
            let server = ModbusServer::new(shared.clone(), options);
            tokio::spawn(async move { Ok(server.serve_tcp(listener).await?) })
        }
    }
}

fn spawn_serial(
    settings: &Settings,
    shared: &SharedMock,
    port: tokio_serial::SerialStream,
) -> ServerTask {
    let (station, baud) = (settings.station, settings.baud);
    match settings.protocol {
        ProtocolArg::Mewtocol => {
            let server =
                MewtocolServer::new(shared.clone(), MewtocolServerOptions { station, baud });
            tokio::spawn(async move { Ok(server.serve(port).await?) })
        }
        ProtocolArg::Modbus => {
            let options = ModbusServerOptions {
                unit: station,
                baud: None,
            };
            let server = ModbusServer::new(shared.clone(), options);
            tokio::spawn(async move { Ok(server.serve_rtu(port).await?) })
        }
    }
}

fn write_trace(shared: &SharedMock, path: &PathBuf) -> anyhow::Result<()> {
    let pulses = shared.with(MockPlc::take_pulses);
    let file = std::fs::File::create(path)
        .with_context(|| format!("cannot create trace file {}", path.display()))?;
    write_csv(&pulses, std::io::BufWriter::new(file))
        .with_context(|| format!("cannot write trace file {}", path.display()))?;
    tracing::info!(pulses = pulses.len(), path = %path.display(), "pulse trace written");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn parse(line: &[&str]) -> anyhow::Result<Settings> {
        let cli = crate::cli::Cli::try_parse_from(line)?;
        let crate::cli::Command::MockPlc(args) = cli.command else {
            panic!("not mock-plc")
        };
        validate(&args)
    }

    #[test]
    fn defaults_answer_every_mewtocol_station_and_modbus_unit_1() {
        let s = parse(&["linterpd", "mock-plc", "--listen", "127.0.0.1:0"]).unwrap();
        assert_eq!(s.station, StationFilter::Any);
        assert_eq!(s.baud, None);
        assert!((s.config.scan_s - 0.002).abs() < 1e-12);
        let line = [
            "linterpd",
            "mock-plc",
            "--serial",
            "/dev/x",
            "--protocol",
            "modbus",
        ];
        let s = parse(&line).unwrap();
        assert_eq!(s.station, StationFilter::Only(1));
        assert_eq!(s.endpoint, Endpoint::Serial("/dev/x".into()));
        assert!(s.config.homed);
    }

    #[test]
    fn unhomed_clears_the_homed_bit_and_restart_faults_parse() {
        let line = [
            "linterpd",
            "mock-plc",
            "--listen",
            "127.0.0.1:0",
            "--unhomed",
            "--faults",
            "restart@t=2,restart@5",
        ];
        let s = parse(&line).unwrap();
        assert!(!s.config.homed);
    }

    #[test]
    fn every_variant_is_offered_by_its_own_name() {
        for v in MockVariant::ALL {
            let line = [
                "linterpd",
                "mock-plc",
                "--listen",
                "127.0.0.1:0",
                "--variant",
                v.name(),
            ];
            assert_eq!(parse(&line).unwrap().config.variant, v);
        }
        let s = parse(&["linterpd", "mock-plc", "--listen", "127.0.0.1:0"]).unwrap();
        assert_eq!(s.config.variant, MockVariant::Listing);
    }

    #[test]
    fn a_cell_description_is_read_and_a_bad_one_names_its_file_and_key() {
        let base = ["linterpd", "mock-plc", "--listen", "127.0.0.1:0", "--cell"];
        let shipped = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/config/examples/cells/press.toml"
        );
        let s = parse(&[&base[..], &[shipped]].concat()).unwrap();
        assert_eq!(s.cell.unwrap().models.len(), 2);
        let dir = std::env::temp_dir().join(format!("linterpd-cellarg-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad.toml");
        std::fs::write(
            &bad,
            "[[press]]\ngo = \"Y0\"\nopen = \"X5\"\nstroke = \"-1s\"\n",
        )
        .unwrap();
        let e = format!(
            "{:#}",
            parse(&[&base[..], &[bad.to_str().unwrap()]].concat()).unwrap_err()
        );
        assert!(
            e.starts_with(&format!(
                "cell description {}: press[0].stroke = \"-1s\"",
                bad.display()
            )),
            "{e}"
        );
        let e = format!(
            "{:#}",
            parse(&[&base[..], &["/nonexistent/cell.toml"]].concat()).unwrap_err()
        );
        assert!(
            e.starts_with("cannot read the cell description /nonexistent/cell.toml"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn bad_values_are_named() {
        let base = ["linterpd", "mock-plc", "--listen", "127.0.0.1:0"];
        let cases: [(&[&str], &str); 4] = [
            (&["--station", "100"], "--station '100'"),
            (&["--baud", "fast"], "--baud 'fast'"),
            (&["--scan", "2 parsecs"], "--scan '2 parsecs'"),
            (&["--faults", "explode@1"], "explode"),
        ];
        for (extra, named) in cases {
            let line: Vec<&str> = base.iter().chain(extra).copied().collect();
            let e = format!("{:#}", parse(&line).unwrap_err());
            assert!(e.contains(named), "{e}");
        }
    }
}
