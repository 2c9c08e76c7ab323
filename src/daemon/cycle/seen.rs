//! What a cycle's driver sees and waits on: the control asked for and the robot's incidents,
//! read into the runner's [`Seen`] before each decision; standing until the control changes;
//! an incident since a mark, which any action on the robot gives way to.

use std::time::Instant;

use tokio::sync::watch;

use crate::cycle::runner::{Control, Event, Seen};
use crate::daemon::Snapshot;
use crate::daemon::gate::Gate;

/// The watches a cycle's driver reads.
pub(super) struct Sight {
    /// The robot's snapshot, for its incidents.
    incidents: watch::Receiver<Snapshot>,
    /// The control asked for.
    pub(super) control: watch::Receiver<Control>,
    /// The controller is gone (the daemon shuts down): taken as a stop.
    orphaned: bool,
}

impl Sight {
    pub(super) fn new(
        incidents: watch::Receiver<Snapshot>,
        control: watch::Receiver<Control>,
    ) -> Self {
        Self {
            incidents,
            control,
            orphaned: false,
        }
    }

    /// What the runner sees now.
    pub(super) fn seen(&mut self) -> Seen {
        let mut control = *self.control.borrow_and_update();
        if self.orphaned {
            control.stop(false);
        }
        let snapshot = self.incidents.borrow();
        Seen {
            control,
            incidents: snapshot.incidents.count,
            last_incident: snapshot.incidents.last.clone(),
            restarts: snapshot.incidents.restarts,
            now: Instant::now(),
        }
    }

    /// Stands until the control changes or an incident comes since `mark`.
    pub(super) async fn stand(&mut self, mark: u64) -> Event<Gate> {
        let incidents = self.incidents.clone();
        tokio::select! {
            changed = self.control.changed() => {
                self.orphaned |= changed.is_err();
                Event::Changed
            }
            why = until_incident(incidents, mark) => Event::Incident(why),
        }
    }

    /// Waits until the incident count is other than `mark`: the last incident, in words. (It
    /// waits on a watch of its own: the driver's may be borrowed meanwhile.)
    pub(super) fn incident_since(&self, mark: u64) -> impl Future<Output = String> + use<> {
        until_incident(self.incidents.clone(), mark)
    }
}

/// Waits until the incident count is other than `mark`: the last incident, in words.
async fn until_incident(mut incidents: watch::Receiver<Snapshot>, mark: u64) -> String {
    loop {
        {
            let now = &incidents.borrow_and_update().incidents;
            if now.count != mark {
                return now.last.clone().unwrap_or_default();
            }
        }
        if incidents.changed().await.is_err() {
            // The robot's worker is gone: nothing more comes.
            std::future::pending::<()>().await;
        }
    }
}
