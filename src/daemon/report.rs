//! The reports of a robot's moves as the daemon keeps them: every move not ended and the latest
//! [`KEPT`] ended ones, each with a feed its watchers wake on.

use std::collections::{BTreeMap, VecDeque};

use tokio::sync::watch;

use crate::wire::{MoveId, MoveReport};

/// The moves of one robot: the report of every move not ended and of the latest [`KEPT`] ended
/// ones, and a feed per move.
#[derive(Debug, Default)]
pub struct Moves {
    feeds: BTreeMap<MoveId, watch::Sender<MoveReport>>,
    order: VecDeque<MoveId>,
}

/// Ended moves whose reports are kept per robot (a move not ended is always kept).
pub const KEPT: usize = 500;

impl Moves {
    /// Records a new report; past [`KEPT`] ended reports, the oldest ended ones are dropped
    /// (never the report of a move queued or running).
    pub fn insert(&mut self, report: MoveReport) {
        let id = report.id;
        self.feeds.insert(id, watch::channel(report).0);
        self.order.push_back(id);
        let ended = |feeds: &BTreeMap<MoveId, watch::Sender<MoveReport>>, id: &MoveId| {
            feeds.get(id).is_some_and(|f| f.borrow().stage.is_final())
        };
        let mut excess = self
            .order
            .iter()
            .filter(|id| ended(&self.feeds, id))
            .count()
            .saturating_sub(KEPT);
        while excess > 0 {
            let Some(at) = self.order.iter().position(|id| ended(&self.feeds, id)) else {
                break;
            };
            if let Some(old) = self.order.remove(at) {
                self.feeds.remove(&old);
            }
            excess -= 1;
        }
    }

    /// Changes a report and tells its watchers.
    pub fn update(&self, id: MoveId, change: impl FnOnce(&mut MoveReport)) {
        if let Some(feed) = self.feeds.get(&id) {
            feed.send_modify(change);
        }
    }

    /// A report.
    #[must_use]
    pub fn get(&self, id: MoveId) -> Option<MoveReport> {
        self.feeds.get(&id).map(|f| f.borrow().clone())
    }

    /// A feed of a move's reports.
    #[must_use]
    pub fn subscribe(&self, id: MoveId) -> Option<watch::Receiver<MoveReport>> {
        self.feeds.get(&id).map(watch::Sender::subscribe)
    }

    /// Every kept report, oldest first.
    #[must_use]
    pub fn all(&self) -> Vec<MoveReport> {
        self.order.iter().filter_map(|id| self.get(*id)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::order::MoveOrder;
    use crate::wire::Stage;

    /// Issue 25: a path of 1,000 stopped elements got 503 while its moves ran: the reports of
    /// its first starts, still queued, had been dropped to keep 500 per robot.
    #[test]
    fn the_report_of_a_move_not_ended_is_never_dropped() {
        let mut moves = Moves::default();
        let count = KEPT as u64 * 2;
        for id in 1..=count {
            moves.insert(MoveReport::new(id, "r", MoveOrder::default()));
        }
        assert!(
            (1..=count).all(|id| moves.get(id).is_some()),
            "a queued report was dropped"
        );
        // Once ended, only the latest KEPT ended reports stay, and every one not ended.
        for id in 1..=KEPT as u64 + 10 {
            moves.update(id, |r| r.stage = Stage::Done);
        }
        moves.insert(MoveReport::new(count + 1, "r", MoveOrder::default()));
        assert!(moves.get(10).is_none() && moves.get(11).is_some());
        assert!((KEPT as u64 + 11..=count + 1).all(|id| moves.get(id).is_some()));
        assert_eq!(moves.all().len(), KEPT + (count as usize - KEPT - 10) + 1);
    }
}
