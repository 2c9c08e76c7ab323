//! PURE. Whether a path section's parts can chain at speed over this link: each part after the
//! first must be written, read back and started while the part before it runs, or the part
//! before ends at speed with nothing waiting and the robot stops there abruptly. Judged before
//! the section's first part starts, from the pace the link showed just then: a status read (one
//! exchange) and the second part's tables, written and read back into the idle bank.

use std::time::Duration;

use crate::plan::Plan;
use crate::plc::contract::ContractError;

/// Exchanges between the start of the part before and the start of a part, besides its tables
/// (as the worker makes them): the status read that sees the part before running, the poll its
/// turn begins with (up to two exchanges), its command block written and read back, the status
/// read before the start, and the start write; each counted as long as a whole status read.
/// Counted from a run at 19200 baud, where five were not enough.
const CHAIN_EXCHANGES: u32 = 7;

/// The estimate must fit the part before it this many times over (a link's pace varies).
const MARGIN: f64 = 1.25;

/// What the link showed just before the section's first start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Pace {
    /// One status read.
    pub exchange: Duration,
    /// The second part's tables written and read back ...
    pub preload: Duration,
    /// ... that many words.
    pub preload_words: usize,
}

/// One part of a section as the check sees it: the words its start writes, how long it runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Part {
    /// DT words of its tables and command block.
    pub words: usize,
    /// Its planned duration, s.
    pub runs_s: f64,
}

impl Part {
    pub(super) fn of(plan: &Plan) -> Self {
        Self {
            words: plan.figures.words,
            runs_s: plan.duration_s(),
        }
    }
}

impl Pace {
    /// About how long part `k` (from 0) takes to be ready to start once its bank is free: the
    /// second part's tables are already written (preloaded), a later part's are not.
    fn need_s(&self, parts: &[Part], k: usize) -> f64 {
        let exchanges = self.exchange.as_secs_f64() * f64::from(CHAIN_EXCHANGES);
        if k == 1 {
            return exchanges;
        }
        let per_word_s = self.preload.as_secs_f64() / self.preload_words.max(1) as f64;
        parts[k].words as f64 * per_word_s + exchanges
    }

    /// Refuses a section's `parts` (the first about to start from rest) if a part after the
    /// first could not be made ready while the part before it runs.
    pub(super) fn check(&self, parts: &[Part]) -> Result<(), ContractError> {
        for k in 1..parts.len() {
            let need_s = self.need_s(parts, k);
            let runs_s = parts[k - 1].runs_s;
            if need_s * MARGIN > runs_s {
                return Err(ContractError::ChainOutrunsLink {
                    part: k + 1,
                    parts: parts.len(),
                    need_s,
                    runs_s,
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pace(exchange_ms: u64, preload_ms: u64, preload_words: usize) -> Pace {
        Pace {
            exchange: Duration::from_millis(exchange_ms),
            preload: Duration::from_millis(preload_ms),
            preload_words,
        }
    }

    fn part(words: usize, runs_s: f64) -> Part {
        Part { words, runs_s }
    }

    #[test]
    fn a_fast_link_chains_every_part() {
        // 115200 baud: a status read in 5 ms, 200 words written and read back in 0.2 s.
        let parts = [
            part(150, 0.39),
            part(200, 0.5),
            part(300, 1.2),
            part(100, 0.4),
        ];
        assert!(pace(5, 200, 200).check(&parts).is_ok());
    }

    #[test]
    fn the_second_part_needs_only_its_block_written_while_the_first_runs() {
        // Its tables went in before the first start: seven exchanges of 60 ms, 0.42 s, x1.25.
        let parts = [part(150, 0.53), part(5_000, 1.0)];
        assert!(pace(60, 6_000, 1_000).check(&parts).is_ok());
        let short = [part(150, 0.52), part(200, 1.0)];
        assert!(matches!(
            pace(60, 6_000, 1_000).check(&short),
            Err(ContractError::ChainOutrunsLink {
                part: 2,
                parts: 2,
                ..
            })
        ));
    }

    #[test]
    fn a_later_part_whose_upload_outlasts_the_part_before_it_is_named() {
        // 6 ms a word: part 3's 300 words take 1.8 s (plus seven 20 ms exchanges), part 2 runs
        // 1.5 s.
        let parts = [part(150, 0.5), part(200, 1.5), part(300, 1.0)];
        let refused = pace(20, 1_200, 200).check(&parts).unwrap_err();
        let ContractError::ChainOutrunsLink {
            part: which,
            parts: of,
            need_s,
            runs_s,
        } = refused
        else {
            panic!("{refused:?}");
        };
        assert_eq!((which, of), (3, 3));
        assert!((need_s - 1.94).abs() < 1e-9, "{need_s}");
        assert!((runs_s - 1.5).abs() < 1e-12);
        // Run slower, it fits.
        let slower = [part(150, 0.5), part(200, 2.5), part(300, 1.0)];
        assert!(pace(20, 1_200, 200).check(&slower).is_ok());
    }
}
