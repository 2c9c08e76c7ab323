//! Moves with no motion of their own: planned to end within a pulse of where they begin. With
//! nothing running such a move ends done at once; behind a running start (its lead) it ends with
//! that start, done only if the lead ended done at the same counts.

use super::Worker;
use crate::contract::CHANNELS;
use crate::wire::{MoveId, Stage};

/// A move with no motion of its own queued behind a running start (its lead): it ends with
/// that start.
#[derive(Debug, Clone, Copy)]
pub(super) struct Follower {
    /// The move.
    id: MoveId,
    /// The start it ends with.
    lead: MoveId,
    /// Its targets per channel: the lead's.
    targets: [i32; CHANNELS],
}

impl Worker {
    /// Move `id`, whose `targets` are within a pulse of `from`, where it begins: nothing to
    /// start. With nothing running (`lead` none) the robot is at `from` now and it ends done;
    /// behind the running start `lead` it is not there yet, and it ends with that start (done
    /// only if that one ends done, [`Worker::finish`]).
    pub(super) fn in_place(
        &mut self,
        id: MoveId,
        from: [i32; CHANNELS],
        targets: [i32; CHANNELS],
        lead: Option<MoveId>,
    ) {
        self.shared.moves(|m| {
            m.update(id, |r| {
                r.start_counts = Some(from.map(i64::from));
                r.target_counts = Some(targets.map(i64::from));
            });
        });
        if let Some(lead) = lead {
            tracing::info!(robot = %self.robot.name, id, lead, "no motion of its own: ends with the move ahead");
            self.followers.push(Follower { id, lead, targets });
            return;
        }
        let error = std::array::from_fn(|c| i64::from(from[c]) - i64::from(targets[c]));
        self.finish(id, Stage::Done, None, Some(error));
        tracing::info!(robot = %self.robot.name, id, "move within one pulse of the pose: done without a start");
    }

    /// Ends the moves with no motion of their own that end with move `lead`, which ended
    /// `stage` (`why`): done at their targets only when it ended done at the same counts, else
    /// cancelled with the reason.
    pub(super) fn end_followers(&mut self, lead: MoveId, stage: Stage, why: Option<&str>) {
        let (ending, rest) = std::mem::take(&mut self.followers)
            .into_iter()
            .partition(|f: &Follower| f.lead == lead);
        self.followers = rest;
        let counts = self.shared.moves(|m| m.get(lead)).and_then(|r| {
            r.counts
                .zip(r.target_counts)
                .filter(|_| stage == Stage::Done)
        });
        for f in ending {
            let targets = f.targets.map(i64::from);
            match counts {
                Some((counts, lead_targets)) if lead_targets == targets => {
                    let error = std::array::from_fn(|c| counts[c] - targets[c]);
                    self.finish(f.id, Stage::Done, None, Some(error));
                }
                _ => {
                    let why = format!(
                        "cancelled: it had no motion of its own and was to end with move {lead}, \
                         which ended {}{}",
                        stage.name(),
                        why.map(|w| format!(" ({w})")).unwrap_or_default()
                    );
                    self.finish(f.id, Stage::Cancelled, Some(why), None);
                }
            }
        }
    }

    /// Cancels every move waiting to end with a start (the daemon shuts down).
    pub(super) fn cancel_followers(&mut self, why: &str) {
        for f in std::mem::take(&mut self.followers) {
            self.finish(f.id, Stage::Cancelled, Some(why.to_owned()), None);
        }
    }
}
