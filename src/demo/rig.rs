//! IO. The demo's test rig: a mock FP-X in process, its channels preset to a start pose, and a
//! [`Connector`] that reaches it over an emulated serial line (MEWTOCOL-COM over `duplex`).

use std::time::Duration;

use tokio::task::JoinHandle;

use super::DemoError;
use crate::daemon::{Connector, RobotHandle};
use crate::kinematics::Kinematics;
use crate::mewtocol::Station;
use crate::mock::{
    MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, ModbusServer, ModbusServerOptions,
    SharedMock,
};
use crate::plc::{
    AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions, ModbusClient, ModbusFraming,
    ModbusOptions, PlcError,
};
use crate::robot::Robot;
use crate::table::FrequencyModel;

/// Bytes the in-process pipe buffers each way (a MEWTOCOL-COM frame is at most 2 KB).
const PIPE_BYTES: usize = 4_096;
/// The longest wait for the daemon's first status read.
const CONNECT_LIMIT: Duration = Duration::from_secs(5);

/// How the demo's daemon speaks to the mock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DemoLink {
    /// MEWTOCOL-COM, in `<` frames (up to 2048 characters) if `long_frames`, else `%` (118).
    Mewtocol {
        /// `<` frames.
        long_frames: bool,
    },
    /// Modbus RTU (binary frames, up to 125 registers a read, 123 a write).
    ModbusRtu,
}

impl DemoLink {
    /// How the report names it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Mewtocol { long_frames: true } => "MEWTOCOL-COM (< frames)",
            Self::Mewtocol { long_frames: false } => "MEWTOCOL-COM (% frames)",
            Self::ModbusRtu => "Modbus RTU",
        }
    }
}

/// One 11-bit character's time at `baud`, as the mock's line emulation counts it.
fn char_time(baud: Option<u32>) -> Option<Duration> {
    baud.map(|b| Duration::from_secs_f64(11.0 / f64::from(b)))
}

/// MEWTOCOL-COM over an in-process pipe, the mock serving it at `baud`.
fn mewtocol(shared: SharedMock, baud: Option<u32>, long_frames: bool) -> AnyPlc {
    let header = if long_frames {
        HeaderChoice::Angle
    } else {
        HeaderChoice::Percent
    };
    let (ours, theirs) = tokio::io::duplex(PIPE_BYTES);
    let options = MewtocolServerOptions {
        baud,
        ..MewtocolServerOptions::default()
    };
    let server = MewtocolServer::new(shared, options);
    tokio::spawn(async move { server.serve(theirs).await });
    let station = Station::new(1).expect("station 1 exists");
    // As a serial config's client: its timeouts count the frames' wire time (11-bit
    // characters, as the mock emulates) and `<` frames are cut to fit the line.
    let options = MewtocolOptions {
        char_time: char_time(baud),
        ..MewtocolOptions::new(station, header)
    };
    AnyPlc::Mewtocol(MewtocolClient::new(Box::new(ours) as BoxedLink, options))
}

/// Modbus RTU framing over a loopback TCP connection (tokio-modbus serves RTU on nothing else
/// but a serial port), the mock serving it at `baud`.
async fn modbus_rtu(shared: SharedMock, baud: Option<u32>) -> Result<AnyPlc, PlcError> {
    let link_error = |e: std::io::Error| PlcError::Link {
        operation: "open the demo's Modbus RTU link".into(),
        source: e,
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .map_err(link_error)?;
    let address = listener.local_addr().map_err(link_error)?;
    let server = ModbusServer::new(
        shared,
        ModbusServerOptions {
            baud,
            ..ModbusServerOptions::default()
        },
    );
    tokio::spawn(server.serve_rtu_over_tcp(listener));
    let stream = tokio::net::TcpStream::connect(address)
        .await
        .map_err(link_error)?;
    let _ = stream.set_nodelay(true);
    let options = ModbusOptions {
        char_time: char_time(baud),
        ..ModbusOptions::new(ModbusFraming::Rtu, 1)
    };
    Ok(AnyPlc::Modbus(ModbusClient::new(
        Box::new(stream) as BoxedLink,
        options,
    )))
}

/// A running mock PLC: the shared mock and its scan driver.
pub(super) struct Rig {
    /// The mock, for its pulse trace.
    pub(super) mock: SharedMock,
    driver: JoinHandle<()>,
}

impl Rig {
    /// A mock in RUN whose channels stand at the counts of `at` (mm, wrist at 0), recording every
    /// pulse, its scans running in real time.
    pub(super) fn start(
        robot: &Robot,
        at: [f64; 3],
        model: FrequencyModel,
    ) -> Result<Self, DemoError> {
        let config = MockConfig {
            model,
            ..MockConfig::default()
        };
        let mut mock = MockPlc::new(config).map_err(|e| DemoError::Rig(e.to_string()))?;
        for (j, count) in start_counts(robot, at)?.into_iter().enumerate() {
            mock.set_count(usize::from(robot.joints[j].channel), count);
        }
        mock.record_pulses(true);
        let mock = SharedMock::new(mock);
        let driver = tokio::spawn(mock.clone().run_scans());
        Ok(Self { mock, driver })
    }

    /// Opens a fresh pipe to the mock for every (re)connection, served at `baud` (`None`: as fast
    /// as the pipe), spoken as `link` says.
    pub(super) fn connector(&self, baud: Option<u32>, link: DemoLink) -> Connector {
        let shared = self.mock.clone();
        Box::new(move || {
            let shared = shared.clone();
            Box::pin(async move {
                match link {
                    DemoLink::Mewtocol { long_frames } => Ok(mewtocol(shared, baud, long_frames)),
                    DemoLink::ModbusRtu => modbus_rtu(shared, baud).await,
                }
            })
        })
    }

    /// Stops the scan driver.
    pub(super) fn stop(self) {
        self.driver.abort();
    }
}

/// Counts per joint of the pose at `at` (mm) with the wrist at 0.
pub(super) fn start_counts(robot: &Robot, at: [f64; 3]) -> Result<[i64; 4], DemoError> {
    let pose = robot
        .pose_with_wrist_at_zero(at[0], at[1], at[2])
        .map_err(|e| DemoError::Rig(format!("start pose: {e}")))?;
    let q = robot
        .kinematics
        .ik(&pose, None)
        .map_err(|e| DemoError::Rig(format!("start pose: {e}")))?;
    Ok(robot.counts_of(&q))
}

/// Waits until the daemon has read the PLC's counts.
pub(super) async fn connected(handle: &RobotHandle) -> Result<(), DemoError> {
    let wait = async {
        while handle.state().counts.is_none() {
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    };
    tokio::time::timeout(CONNECT_LIMIT, wait)
        .await
        .map_err(|_| {
            let why = handle.state().link.error.unwrap_or_default();
            DemoError::Rig(format!("the daemon never reached the mock PLC: {why}"))
        })
}
