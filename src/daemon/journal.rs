//! What the daemon journals of its robots by following what they publish: one task per robot
//! wakes on each snapshot its worker publishes (`RobotHandle::watch_snapshot`), reads the
//! robot's state and journals what changed (`wire::journal::Follow`: faults and their reason,
//! cycles' starts and ends, holds, mode changes, the cell face's commands). Nothing in the
//! worker or the cycle waits for it, and it never waits on the disk (`Journal::record`).

use std::collections::BTreeMap;

use tokio_util::sync::CancellationToken;

use super::RobotHandle;
use crate::journal::Journal;
use crate::wire::journal::Follow;

/// Starts a follower per robot, journaling into `journal` until `closing` (none when the
/// journal is off).
pub fn follow(
    robots: &BTreeMap<String, RobotHandle>,
    journal: &Journal,
    closing: &CancellationToken,
) {
    if !journal.is_on() {
        return;
    }
    for handle in robots.values() {
        tokio::spawn(follow_robot(
            handle.clone(),
            journal.clone(),
            closing.clone(),
        ));
    }
}

/// One robot's follower: each published snapshot's changes, journaled.
async fn follow_robot(handle: RobotHandle, journal: Journal, closing: CancellationToken) {
    let name = handle.robot().name.clone();
    let mut reads = handle.watch_snapshot();
    let mut follow = Follow::default();
    loop {
        for kind in follow.observe(&handle.state()) {
            journal.record(Some(&name), kind);
        }
        tokio::select! {
            biased;
            () = closing.cancelled() => return,
            changed = reads.changed() => if changed.is_err() { return },
        }
    }
}
