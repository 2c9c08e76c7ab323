//! The robot in its cell, as the daemon keeps it: the signals' names and the input words the
//! PLC copies, who drives the robot (the [`Mode`]), and the cell face the line drives it through
//! (`face.rs`).
//!
//! ```text
//!  local:  API / CLI --owned_by(Local)--> submit, paths, cycles, home, clear-fault
//!  remote: cell face --owned_by(Remote)--> select, start (run / resume), pause, reset, home
//!  both:   stop (CLI, API, the face's stop and stop-now)
//!  set_mode: only while no cycle is under way and no move is queued or running
//! ```
//! The mode is held (a read lock, across the order's planning and its queueing) while an order is
//! taken, and changed under the write lock, so an order is taken in the mode it was checked in:
//! of two controllers racing, exactly one wins.

mod face;
mod mirror;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use tokio::sync::{OwnedRwLockReadGuard, RwLock};

use thiserror::Error;

pub(crate) use face::FaceCell;
pub use mirror::{MIRROR_EVERY, mirror_face};

use super::RobotHandle;
use crate::cell::Mode;
use crate::config::CellSettings;
use crate::contract::{INPUT_WORDS, InputWord};

/// What a robot's handle knows of its cell.
#[derive(Debug)]
pub(crate) struct Cell {
    pub inputs: [InputWord; INPUT_WORDS],
    /// Taken to hold the mode while an order is taken, and to change it.
    mode: Arc<RwLock<Mode>>,
    /// The mode as last set, read without the lock (`RobotHandle::mode`), so code that holds
    /// the mode may read it again.
    remote: AtomicBool,
    pub face: Option<FaceCell>,
}

impl Cell {
    pub(crate) fn new(settings: &CellSettings, inputs: [InputWord; INPUT_WORDS]) -> Self {
        let mode = settings.face.as_ref().map_or(Mode::Local, |f| f.mode);
        let face = settings.face.clone().map(FaceCell::new);
        Self {
            inputs,
            mode: Arc::new(RwLock::new(mode)),
            remote: AtomicBool::new(mode == Mode::Remote),
            face,
        }
    }
}

/// Why a request was refused by the mode.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ModeError {
    /// The other controller drives the robot.
    #[error("{}", not_yours(*mode))]
    NotYours {
        /// The robot's mode.
        mode: Mode,
    },
    /// The mode changes only while the robot is idle.
    #[error("the mode changes only while nothing runs: {what}")]
    Busy {
        /// What runs.
        what: String,
    },
    /// Remote needs a cell face.
    #[error(
        "robot {robot} has no cell face ([robots.{robot}.cell.face]): it is driven locally only"
    )]
    NoFace {
        /// The robot.
        robot: String,
    },
}

fn not_yours(mode: Mode) -> &'static str {
    match mode {
        Mode::Remote => {
            "the robot is in remote mode: the cell face drives it (`linterpd mode local` takes it \
             back; `linterpd stop` works in both modes)"
        }
        Mode::Local => {
            "the robot is in local mode: the CLI and the API drive it (`linterpd mode remote` \
             gives it to the cell face)"
        }
    }
}

/// The mode held while an order is taken: it cannot change until this is dropped.
#[derive(Debug)]
pub struct Owner(#[allow(dead_code, reason = "held, not read")] OwnedRwLockReadGuard<Mode>);

impl RobotHandle {
    /// Who drives the robot.
    #[must_use]
    pub fn mode(&self) -> Mode {
        if self.cell.remote.load(Ordering::SeqCst) {
            Mode::Remote
        } else {
            Mode::Local
        }
    }

    /// The mode, held, when `who` drives the robot; refused otherwise. Hold it while the order
    /// is taken (never taken twice by one caller: a mode change waiting between would wait for
    /// ever).
    pub async fn owned_by(&self, who: Mode) -> Result<Owner, ModeError> {
        let mode = Arc::clone(&self.cell.mode).read_owned().await;
        if *mode == who {
            Ok(Owner(mode))
        } else {
            Err(ModeError::NotYours { mode: *mode })
        }
    }

    /// Sets who drives the robot: refused while a cycle is under way or a move is queued or
    /// running, and `remote` without a cell face.
    pub async fn set_mode(&self, to: Mode) -> Result<Mode, ModeError> {
        let mut mode = self.cell.mode.write().await;
        if *mode == to {
            return Ok(to);
        }
        if to == Mode::Remote && self.cell.face.is_none() {
            return Err(ModeError::NoFace {
                robot: self.robot().name.clone(),
            });
        }
        if let Some(c) = self.cycle().filter(|c| !c.state.is_final()) {
            let state = serde_json::to_value(c.state).unwrap_or_default();
            return Err(ModeError::Busy {
                what: format!(
                    "cycle {} is {}: stop it first (linterpd cycle stop)",
                    c.program,
                    state.as_str().unwrap_or_default()
                ),
            });
        }
        let state = self.shared.snapshot().state;
        let running = state.current_move.or_else(|| state.queued.first().copied());
        if let Some(id) = running {
            return Err(ModeError::Busy {
                what: format!("move {id} is queued or running: wait for it, or stop the robot"),
            });
        }
        tracing::info!(robot = %self.robot().name, from = %*mode, to = %to, "mode changed");
        *mode = to;
        self.cell.remote.store(to == Mode::Remote, Ordering::SeqCst);
        if let Some(face) = &self.cell.face {
            face.mode_changed();
        }
        Ok(to)
    }
}
