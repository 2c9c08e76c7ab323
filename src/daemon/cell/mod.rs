//! The robot in its cell, as the daemon keeps it: who drives the robot (the [`Mode`]) and the
//! cell face the line drives it through (`face.rs`), owned by one task per robot ([`own`]) that
//! takes the cell requests one at a time and publishes the mode and the face
//! ([`CellView`]); the face mirrored in the PLC's own words (`mirror.rs`).
//!
//! ```text
//!  local:  API / CLI --owned_by(Local)--> submit, paths, cycles, home, clear-fault
//!  remote: cell face --owned_by(Remote)--> select, start (run / resume), pause, reset, home
//!  both:   stop (CLI, API, the face's stop and stop-now)
//!  set_mode: only while no cycle is under way and no move is queued or running
//!
//!  handles --CellRequest--> own(): CellOwner --CellView (watch)--> handles
//!                                     | the face's actions, through its own RobotHandle
//! ```
//! The mode is held (a read lock, across the order's planning and its queueing) while an order is
//! taken, and changed by the owner under the write lock, so an order is taken in the mode it was
//! checked in: of two controllers racing, exactly one wins.

mod face;
mod mirror;

use std::sync::Arc;

use tokio::sync::{RwLock, mpsc, watch};

pub use mirror::{MIRROR_EVERY, mirror_face};

use super::RobotHandle;
use super::request::{CellRequest, ModeError, Owner};
use super::shared::CellView;
use crate::cell::Mode;
use crate::cell::face::Face;
use crate::config::CellSettings;

/// The cell's state as its owner starts with it, and the watch the handles read it from.
pub(crate) fn start(settings: &CellSettings) -> (CellOwner, watch::Receiver<CellView>) {
    let mode = settings.face.as_ref().map_or(Mode::Local, |f| f.mode);
    let view = CellView {
        mode,
        face: settings.face.as_ref().map(|_| Face::new()),
    };
    let (out, published) = watch::channel(view.clone());
    let owner = CellOwner {
        mode: Arc::new(RwLock::new(mode)),
        view,
        out,
    };
    (owner, published)
}

/// What the cell's owner holds: the mode's lock, the mode and the face, and their publisher.
pub(crate) struct CellOwner {
    /// Read-held while an order is taken; written by the owner alone.
    mode: Arc<RwLock<Mode>>,
    /// The mode and the face as they are (and as published).
    view: CellView,
    out: watch::Sender<CellView>,
}

/// Takes the cell requests of `robot` until the daemon shuts down (or is gone).
pub(crate) async fn own(
    mut cell: CellOwner,
    robot: RobotHandle,
    (mut requests, mut shutdown): (mpsc::UnboundedReceiver<CellRequest>, watch::Receiver<bool>),
) {
    loop {
        let request = tokio::select! {
            request = requests.recv() => request,
            changed = shutdown.changed() => {
                if changed.is_err() || *shutdown.borrow() {
                    return;
                }
                continue;
            }
        };
        let Some(request) = request else { return };
        cell.take(&robot, request).await;
    }
}

impl CellOwner {
    async fn take(&mut self, robot: &RobotHandle, request: CellRequest) {
        match request {
            CellRequest::Hold { who, reply } => {
                let _ = reply.send(self.hold(who).await);
            }
            CellRequest::SetMode { to, reply } => {
                let _ = reply.send(self.set_mode(robot, to).await);
            }
            CellRequest::FaceWrite { at, values, reply } => {
                let _ = reply.send(self.face_write(robot, at, &values).await);
            }
        }
    }

    /// Publishes the mode and the face as they are now.
    fn publish(&self) {
        self.out.send_replace(self.view.clone());
    }

    /// The mode, held, when `who` drives the robot; refused otherwise.
    async fn hold(&self, who: Mode) -> Result<Owner, ModeError> {
        let mode = Arc::clone(&self.mode).read_owned().await;
        if *mode == who {
            Ok(Owner(mode))
        } else {
            Err(ModeError::NotYours { mode: *mode })
        }
    }

    /// Sets who drives the robot: refused while a cycle is under way or a move is queued or
    /// running, and `remote` without a cell face. Waits until no order holds the mode.
    async fn set_mode(&mut self, robot: &RobotHandle, to: Mode) -> Result<Mode, ModeError> {
        let mut mode = self.mode.write().await;
        if *mode == to {
            return Ok(to);
        }
        if to == Mode::Remote && self.view.face.is_none() {
            return Err(ModeError::NoFace {
                robot: robot.robot().name.clone(),
            });
        }
        if let Some(c) = robot.cycle().filter(|c| !c.state.is_final()) {
            let state = serde_json::to_value(c.state).unwrap_or_default();
            return Err(ModeError::Busy {
                what: format!(
                    "cycle {} is {}: stop it first (linterpd cycle stop)",
                    c.program,
                    state.as_str().unwrap_or_default()
                ),
            });
        }
        let state = robot.snapshot().state;
        let running = state.current_move.or_else(|| state.queued.first().copied());
        if let Some(id) = running {
            return Err(ModeError::Busy {
                what: format!("move {id} is queued or running: wait for it, or stop the robot"),
            });
        }
        tracing::info!(robot = %robot.robot().name, from = %*mode, to = %to, "mode changed");
        *mode = to;
        self.view.mode = to;
        if let Some(face) = &mut self.view.face {
            face.mode_changed();
        }
        self.publish();
        Ok(to)
    }
}

impl RobotHandle {
    /// The mode, held, when `who` drives the robot; refused otherwise. Hold it while the order
    /// is taken (never taken twice by one caller: a mode change waiting between would wait for
    /// ever).
    pub async fn owned_by(&self, who: Mode) -> Result<Owner, ModeError> {
        self.ask_cell(|reply| CellRequest::Hold { who, reply })
            .await
            .unwrap_or(Err(ModeError::ShuttingDown))
    }

    /// Sets who drives the robot: refused while a cycle is under way or a move is queued or
    /// running, and `remote` without a cell face.
    pub async fn set_mode(&self, to: Mode) -> Result<Mode, ModeError> {
        self.ask_cell(|reply| CellRequest::SetMode { to, reply })
            .await
            .unwrap_or(Err(ModeError::ShuttingDown))
    }
}
