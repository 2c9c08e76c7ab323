//! Moves with no motion of their own: planned to end within a pulse of where they begin. With
//! nothing running such a move ends done at once; behind a running start (its lead) it ends with
//! that start, done only if the lead ended done at the same counts. The decisions are the
//! dispatcher's ([`Dispatcher::in_place`], [`follower_ends`]); here they are carried out.
//!
//! [`Dispatcher::in_place`]: super::dispatch::Dispatcher::in_place

use super::Worker;
use super::dispatch::follower_ends;
use crate::contract::CHANNELS;
use crate::wire::{MoveId, Stage};

impl Worker {
    /// Move `id`, whose `targets` are within a pulse of `from`, where it begins: nothing to
    /// start. With nothing running (`lead` none) it ends done; behind the running start `lead`
    /// it ends with that start.
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
        match self.dispatch.in_place(id, from, targets, lead) {
            None => {
                tracing::info!(robot = %self.robot.name, id, lead, "no motion of its own: ends with the move ahead");
            }
            Some(done) => {
                self.finish_all(vec![done]);
                tracing::info!(robot = %self.robot.name, id, "move within one pulse of the pose: done without a start");
            }
        }
    }

    /// Move `lead` ended `stage` (`why`, `final_error` off its targets): its record goes, and
    /// the moves with no motion of their own that end with it end as its report says, at the
    /// counts it ended on. Done with no final error, its end was learnt from the start the PLC
    /// took behind it, with no block read at it: the counts last read are from before its end,
    /// so none are given (the followers end done with no final error either).
    pub(super) fn end_followers(
        &mut self,
        lead: MoveId,
        stage: Stage,
        why: Option<&str>,
        final_error: Option<[i64; CHANNELS]>,
    ) {
        let followers = self.dispatch.finished(lead);
        let at = self.shared.moves(|m| m.get(lead)).and_then(|r| {
            let targets = r.target_counts?;
            let counts = match final_error {
                Some(e) => Some(std::array::from_fn(|c| targets[c] + e[c])),
                None if stage == Stage::Done => None,
                None => r.counts,
            };
            Some((counts, targets))
        });
        self.finish_all(follower_ends(lead, &followers, stage, why, at));
    }

    /// Cancels every move waiting to end with a start (the daemon shuts down).
    pub(super) fn cancel_followers(&mut self, why: &str) {
        for id in self.dispatch.take_followers() {
            self.finish(id, Stage::Cancelled, Some(why.to_owned()), None);
        }
    }
}
