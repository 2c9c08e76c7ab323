//! The cell face mirrored in the robot PLC's own DT words (`[robots.NAME.cell.face] plc`), for a
//! press PLC wired to the robot's PLC rather than on Ethernet: every [`MIRROR_EVERY`] the daemon
//! reads the four command words there and takes them as a write to the face, and writes the
//! status words back when they changed. Both go through the robot's link, in turn with its
//! motion exchanges, like the gateway's.
//!
//! ```text
//!  PLC DTn+0..+3  --read every 200 ms, when changed--> face_write (edges, actions)
//!  PLC DTn+8..+17 <--written when changed-------------- face_block's status words
//!       (..+22 with the pallet's words, when the face shows a pallet)
//! ```
//! While the link is down nothing is read or written; once back, the status words are written
//! again whole.

use std::future::Future;
use std::time::Duration;

use crate::cell::face::{COMMAND_WORDS, STATUS_AT};
use crate::daemon::{RobotHandle, Values};
use crate::gateway::{Area, Range};

/// How often the command words are read.
pub const MIRROR_EVERY: Duration = Duration::from_millis(200);

/// Mirrors `robot`'s face in its PLC until `until` completes (at once when it has no mirror).
pub async fn mirror_face(robot: RobotHandle, until: impl Future<Output = ()>) {
    let Some((first, words)) = robot
        .face_settings()
        .and_then(|f| Some((f.plc?, f.block_words())))
    else {
        return;
    };
    tokio::select! {
        () = mirror(&robot, first, words) => {}
        () = until => {}
    }
}

/// Mirrors the block's first `block` words from DT`first`.
async fn mirror(robot: &RobotHandle, first: u32, block: usize) {
    let commands = Range {
        area: Area::Dt,
        first,
        last: first + COMMAND_WORDS as u32 - 1,
    };
    let status = Range {
        area: Area::Dt,
        first: first + STATUS_AT as u32,
        last: first + block as u32 - 1,
    };
    let mut taken: Option<Vec<u16>> = None;
    let mut written: Option<Vec<u16>> = None;
    let mut every = tokio::time::interval(MIRROR_EVERY);
    every.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        every.tick().await;
        match robot.gateway_job(commands, None).await {
            Ok(Values::Words(words)) if taken.as_ref() != Some(&words) => {
                robot.face_write(0, &words).await;
                taken = Some(words);
            }
            Ok(_) => {}
            Err(e) => {
                tracing::debug!(robot = %robot.robot().name, "cell face mirror: {e}");
                written = None;
                continue;
            }
        }
        let Some(face) = robot.face_block() else {
            return;
        };
        let words = face[STATUS_AT..block].to_vec();
        if written.as_ref() != Some(&words) {
            let wrote = robot
                .gateway_job(status, Some(Values::Words(words.clone())))
                .await;
            written = wrote.is_ok().then_some(words);
        }
    }
}
