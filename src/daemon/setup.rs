//! What the daemon is started with: each robot's setup (the robot, its contract settings, its
//! link, its home counts, its gateway) and what every robot of one daemon shares (the host word,
//! move ids, `start_within`, taught positions).

use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::time::Duration;

use super::ids::MoveIds;
use super::pallets::Pallets;
use super::positions::TaughtPositions;
use crate::config::CellSettings;
use crate::gateway::GatewaySettings;
use crate::journal::Journal;
use crate::kinematics::JOINTS;
use crate::plc::exchange::ContractSettings;
use crate::plc::{AnyPlc, PlcError};
use crate::robot::Robot;

/// Opens the robot's PLC link (called again after every link failure).
pub type Connector =
    Box<dyn FnMut() -> Pin<Box<dyn Future<Output = Result<AnyPlc, PlcError>> + Send>> + Send>;

/// One robot as the daemon runs it.
pub struct RobotSetup {
    /// The robot.
    pub robot: Robot,
    /// How its contract is run.
    pub settings: ContractSettings,
    /// Opens its PLC link (again after every failure).
    pub connect: Connector,
    /// The count each joint is set to at its home position.
    pub home_counts: [i64; JOINTS],
    /// What the cell may reach of the PLC's registers through the daemon.
    pub gateway: GatewaySettings,
    /// Its cell: signal names, cycle programs.
    pub cell: CellSettings,
}

/// What every robot of one daemon shares.
#[derive(Debug, Clone)]
pub struct DaemonOptions {
    /// The word this daemon writes into every PLC's `host` word (nonzero).
    pub host: u16,
    /// Where move ids come from.
    pub ids: Arc<MoveIds>,
    /// A queued order that could not start for this long after its turn came ends failed.
    pub start_within: Duration,
    /// The robots' taught positions (by default in memory only).
    pub positions: Arc<TaughtPositions>,
    /// The cell's journal (by default off: nothing recorded).
    pub journal: Journal,
    /// The robots' frames, pallets and pallet counters (by default none, counters in memory).
    pub pallets: Arc<Pallets>,
}

impl Default for DaemonOptions {
    fn default() -> Self {
        Self {
            host: host_word(),
            ids: Arc::new(MoveIds::counting_from(1)),
            start_within: Duration::from_secs(10),
            positions: Arc::new(TaughtPositions::in_memory()),
            journal: Journal::off(),
            pallets: Arc::new(Pallets::default()),
        }
    }
}

/// A nonzero word that differs from run to run (the clock and the process id, mixed).
#[must_use]
pub fn host_word() -> u16 {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    let mut x = nanos ^ (u64::from(std::process::id()) << 32);
    x ^= x >> 33;
    x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    x ^= x >> 33;
    (x as u16).max(1)
}
