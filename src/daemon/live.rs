//! What a reload (SIGHUP) changes under a running robot: its gateway's read and write lists and
//! its cell's signals, programs directory and `require_wait_timeout`. Every order, register
//! request and cycle check reads them when it is taken; a cycle under way keeps the ones it
//! was checked with (its handle is [`Live::pinned`]), so a signal renamed under it cannot point
//! one of its permits elsewhere. The Modbus face and the cell face are bound at start: they
//! change with a restart only, and keep their running settings here.

use std::sync::{Arc, PoisonError, RwLock};

use crate::config::CellSettings;
use crate::gateway::{AccessList, GatewaySettings};

/// A robot's settings that a reload may change.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LiveSettings {
    /// Its gateway (the access list changes live; the Modbus face as started).
    pub gateway: GatewaySettings,
    /// Its cell (signals, programs, `require_wait_timeout` change live; the face as started).
    pub cell: CellSettings,
}

/// [`LiveSettings`] shared by a robot's handles, replaced whole by a reload.
#[derive(Debug, Clone)]
pub(crate) struct Live(Arc<RwLock<Arc<LiveSettings>>>);

impl Live {
    pub(crate) fn new(settings: LiveSettings) -> Self {
        Self(Arc::new(RwLock::new(Arc::new(settings))))
    }

    /// The settings now.
    pub(crate) fn get(&self) -> Arc<LiveSettings> {
        Arc::clone(&self.0.read().unwrap_or_else(PoisonError::into_inner))
    }

    /// The settings now, no longer changed by a reload of the robot's (a cycle's own).
    pub(crate) fn pinned(&self) -> Self {
        Self(Arc::new(RwLock::new(self.get())))
    }

    /// Takes `access` as the gateway's access list (the Modbus face stays as it runs).
    pub(crate) fn set_access(&self, access: AccessList) {
        self.update(|s| s.gateway.access = access);
    }

    /// Takes `cell`'s signals, programs and `require_wait_timeout` (the face stays as it runs).
    pub(crate) fn set_cell(&self, cell: CellSettings) {
        self.update(|s| {
            s.cell = CellSettings {
                face: s.cell.face.take(),
                ..cell
            };
        });
    }

    fn update(&self, change: impl FnOnce(&mut LiveSettings)) {
        let mut now = self.0.write().unwrap_or_else(PoisonError::into_inner);
        let mut next = LiveSettings::clone(&now);
        change(&mut next);
        *now = Arc::new(next);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::FaceSettings;

    fn face() -> FaceSettings {
        FaceSettings {
            registers: 50_000,
            plc: None,
            home: "home".to_owned(),
            positions: Vec::new(),
            mode: crate::cell::Mode::Local,
            pallet: None,
        }
    }

    #[test]
    fn a_reload_replaces_the_lists_and_signals_but_keeps_the_faces_and_a_pinned_copy() {
        let live = Live::new(LiveSettings {
            gateway: GatewaySettings::default(),
            cell: CellSettings {
                face: Some(face()),
                ..CellSettings::default()
            },
        });
        let pinned = live.pinned();
        let mut cell = CellSettings {
            programs: Some("cycles".into()),
            require_wait_timeout: true,
            ..CellSettings::default()
        };
        cell.signals.insert("go".to_owned(), "Y0".parse().unwrap());
        live.set_cell(cell.clone());
        let now = live.get();
        assert_eq!(now.cell.signals, cell.signals);
        assert_eq!(now.cell.programs, cell.programs);
        assert!(now.cell.require_wait_timeout);
        assert_eq!(now.cell.face, Some(face()), "the face is as started");
        assert!(pinned.get().cell.signals.is_empty(), "a cycle's copy stays");
        assert_eq!(pinned.get().cell.programs, None);
    }
}
