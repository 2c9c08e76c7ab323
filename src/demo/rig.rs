//! IO. The demo's test rig: a mock FP-X in process, its channels preset to a start pose, and a
//! [`Connector`] that reaches it over an emulated serial line (MEWTOCOL-COM over `duplex`).

use std::time::Duration;

use tokio::task::JoinHandle;

use super::DemoError;
use crate::daemon::{Connector, RobotHandle};
use crate::kinematics::Kinematics;
use crate::mewtocol::Station;
use crate::mock::{MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, SharedMock};
use crate::plc::{AnyPlc, BoxedLink, HeaderChoice, MewtocolClient, MewtocolOptions};
use crate::robot::Robot;
use crate::table::FrequencyModel;

/// Bytes the in-process pipe buffers each way (a MEWTOCOL-COM frame is at most 2 KB).
const PIPE_BYTES: usize = 4_096;
/// The longest wait for the daemon's first status read.
const CONNECT_LIMIT: Duration = Duration::from_secs(5);

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
    /// as the pipe), spoken in `<` frames if `long_frames`, else `%` frames.
    pub(super) fn connector(&self, baud: Option<u32>, long_frames: bool) -> Connector {
        let header = if long_frames {
            HeaderChoice::Angle
        } else {
            HeaderChoice::Percent
        };
        let shared = self.mock.clone();
        Box::new(move || {
            let shared = shared.clone();
            Box::pin(async move {
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
                    char_time: baud.map(|b| Duration::from_secs_f64(11.0 / f64::from(b))),
                    ..MewtocolOptions::new(station, header)
                };
                Ok(AnyPlc::Mewtocol(MewtocolClient::new(
                    Box::new(ours) as BoxedLink,
                    options,
                )))
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
