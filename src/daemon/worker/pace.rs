//! PURE. Whether a path section's parts can chain at speed over this link: each part after the
//! first must be written, read back and started while the part before it runs, or the part
//! before ends at speed with nothing waiting and the robot stops there abruptly. Judged before
//! the section's first part starts, from the pace the link showed just then: a status read, a
//! one-word read, and the later parts' tables written and read back (preloaded) into the banks
//! they will start from.
//!
//! A part's start, once the part before it is seen running, takes (as the worker makes them):
//! the status read that sees the part before running (its turn begins on it), its directories
//! left to write (one per channel whose tables lie past another part's in the same bank) and
//! its command block written and read back (written only, with `read_back = false`), the
//! status read before the start, and the one-word start write; a part not preloaded (the areas
//! were full) has its tables written and read back too, at the preloads' pace per word, with a
//! status read each heartbeat timeout that watches the part before it. An exchange of `w` words
//! is taken on the line through the two reads measured (one word, and the status block's
//! [`STATUS_WORDS`]): a fixed cost per exchange and a cost per word.

use std::time::Duration;

use crate::contract::STATUS_WORDS;
use crate::plan::Plan;
use crate::plc::exchange::{BLOCK_WRITE_WORDS, ContractError, PERMIT_WRITE_WORDS};
use crate::table::DIRECTORY_WORDS;

/// The estimate must fit the part before it this many times over (a link's pace varies).
const MARGIN: f64 = 1.25;

/// What the link showed just before the section's first start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct LinkPace {
    /// One status read ([`STATUS_WORDS`] words).
    pub status: Duration,
    /// One one-word read.
    pub word: Duration,
    /// The later parts' tables written and read back ...
    pub preload: Duration,
    /// ... that many words.
    pub preload_words: usize,
    /// Whether every write is read back (the contract's `verify`).
    pub read_back: bool,
    /// Whether each start writes its permit (a second write: a start with no permit writes it
    /// only when the PLC's permit words are not known to be 0 already).
    pub permit_write: bool,
    /// How often a running part is watched (a status read) while the next one is written: the
    /// heartbeat timeout.
    pub watch_every: Duration,
}

/// One part of a section as the check sees it: the words its start writes, how long it runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Part {
    /// DT words of its tables and command block.
    pub words: usize,
    /// Its planned duration, s.
    pub runs_s: f64,
    /// Preloaded: how many directories its start still writes. `None`: its tables too.
    pub preloaded: Option<usize>,
}

impl Part {
    /// `plan` as a part, preloaded with `directories` left to write, or not preloaded.
    pub(super) fn of(plan: &Plan, preloaded: Option<usize>) -> Self {
        Self {
            words: plan.figures.words,
            runs_s: plan.duration_s(),
            preloaded,
        }
    }
}

impl LinkPace {
    /// This pace, measured for one section, for another's parts: its status read as slow as
    /// the link shows it now or was then, whichever is slower, and its first part's permit.
    pub(super) fn for_section(self, status_now: Duration, permit_write: bool) -> Self {
        Self {
            status: self.status.max(status_now),
            permit_write,
            ..self
        }
    }

    /// About how long one exchange of `words` words takes, s: on the line through the two
    /// reads measured (never less than the one-word read).
    fn exchange_s(&self, words: usize) -> f64 {
        let one = self.word.as_secs_f64();
        let per_word = (self.status.as_secs_f64() - one).max(0.0) / (STATUS_WORDS - 1) as f64;
        one + per_word * words.saturating_sub(1) as f64
    }

    /// Exchanges per block written: the write, and its read-back unless switched off.
    fn exchanges_per_write(&self) -> f64 {
        if self.read_back { 2.0 } else { 1.0 }
    }

    /// About how long a part takes to start once the part before it is seen running, s: two
    /// status reads, its block written (and read back), with its permit when it has one (a
    /// second write, after the `host` word), the start write.
    fn start_s(&self) -> f64 {
        2.0 * self.status.as_secs_f64()
            + self.exchanges_per_write()
                * (self.exchange_s(BLOCK_WRITE_WORDS)
                    + if self.permit_write {
                        self.exchange_s(PERMIT_WRITE_WORDS)
                    } else {
                        0.0
                    })
            + self.exchange_s(1)
    }

    /// About how long part `k` (from 0) takes to be ready to start once its bank is free: a
    /// preloaded part's directories written (and read back), a part not preloaded its tables
    /// at the preloads' pace, with the status reads that watch the part before it meanwhile
    /// (one each `watch_every`), then its start.
    fn need_s(&self, parts: &[Part], k: usize) -> f64 {
        let tables_s = if let Some(directories) = parts[k].preloaded {
            directories as f64 * self.exchanges_per_write() * self.exchange_s(DIRECTORY_WORDS)
        } else {
            let per_word_s = self.preload.as_secs_f64() / self.preload_words.max(1) as f64;
            parts[k].words as f64 * per_word_s
        };
        let watch_s =
            (tables_s / self.watch_every.as_secs_f64()).floor() * self.status.as_secs_f64();
        tables_s + watch_s + self.start_s()
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

    /// A status read of 22 words in `status_ms`, a one-word read in `word_ms`.
    fn pace(status_ms: u64, word_ms: u64, preload_ms: u64, preload_words: usize) -> LinkPace {
        LinkPace {
            status: Duration::from_millis(status_ms),
            word: Duration::from_millis(word_ms),
            preload: Duration::from_millis(preload_ms),
            preload_words,
            read_back: true,
            permit_write: true,
            watch_every: Duration::from_secs(3_600),
        }
    }

    /// A part not preloaded.
    fn part(words: usize, runs_s: f64) -> Part {
        Part {
            words,
            runs_s,
            preloaded: None,
        }
    }

    /// A part preloaded, its start left with `directories` to write.
    fn preloaded(words: usize, runs_s: f64, directories: usize) -> Part {
        Part {
            words,
            runs_s,
            preloaded: Some(directories),
        }
    }

    #[test]
    fn an_exchange_is_priced_on_the_line_through_the_two_reads() {
        // 19200 baud, MEWTOCOL: 72 ms for 26 words, 20 ms for one: about 2.1 ms a word.
        let p = pace(72, 20, 0, 1);
        assert!((p.exchange_s(1) - 0.020).abs() < 1e-12);
        assert!((p.exchange_s(26) - 0.072).abs() < 1e-12);
        assert!((p.exchange_s(15) - (0.020 + 0.052 * 14.0 / 25.0)).abs() < 1e-12);
        // A link whose cost is all latency (TCP): every exchange costs the same.
        let tcp = pace(4, 4, 0, 1);
        assert!((tcp.exchange_s(15) - 0.004).abs() < 1e-12);
        // A status read measured faster than a one-word read (jitter): never below the latter.
        let odd = pace(3, 5, 0, 1);
        assert!((odd.exchange_s(15) - 0.005).abs() < 1e-12);
    }

    #[test]
    fn a_fast_link_chains_every_part() {
        // 115200 baud: a status read in 12 ms, one word in 4 ms, 200 words written and read
        // back in 0.2 s.
        let parts = [
            part(150, 0.39),
            part(200, 0.5),
            part(300, 1.2),
            part(100, 0.4),
        ];
        assert!(pace(12, 4, 200, 200).check(&parts).is_ok());
    }

    #[test]
    fn the_second_part_needs_only_its_block_written_while_the_first_runs() {
        // Its tables went in before the first start: two status reads (0.144 s), the block's
        // two writes (15 and 8 words) and their read-backs (2 x (0.0491 + 0.0346) s), the start
        // write (0.020 s): 0.331 s, x1.25.
        let p = pace(72, 20, 6_000, 1_000);
        let need = 0.144 + 2.0 * (0.040 + 0.052 * 21.0 / 25.0) + 0.020;
        assert!((p.start_s() - need).abs() < 1e-12, "{}", p.start_s());
        let fits = [part(150, need * MARGIN + 0.001), preloaded(5_000, 1.0, 0)];
        assert!(p.check(&fits).is_ok());
        let short = [part(150, need * MARGIN - 0.001), preloaded(200, 1.0, 0)];
        assert!(matches!(
            p.check(&short),
            Err(ContractError::ChainOutrunsLink {
                part: 2,
                parts: 2,
                ..
            })
        ));
    }

    #[test]
    fn a_later_part_whose_upload_outlasts_the_part_before_it_is_named() {
        // 6 ms a word: part 3's 300 words take 1.8 s (plus its start, 0.14 s: seven exchanges
        // of 20 ms), part 2 runs 1.5 s.
        let p = pace(20, 20, 1_200, 200);
        assert!((p.start_s() - 0.14).abs() < 1e-12);
        let parts = [part(150, 0.5), preloaded(200, 1.5, 0), part(300, 1.0)];
        let refused = p.check(&parts).unwrap_err();
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
        let slower = [part(150, 0.5), preloaded(200, 2.5, 0), part(300, 1.0)];
        assert!(p.check(&slower).is_ok());
        // Preloaded too, past the first part's tables in its bank: its start writes three
        // directories of 8 words and reads them back (6 x 20 ms at this link's pace).
        let later = [
            part(150, 0.5),
            preloaded(200, 1.5, 0),
            preloaded(300, 1.0, 3),
        ];
        assert!((p.need_s(&later, 2) - (0.14 + 0.12)).abs() < 1e-9);
        assert!(p.check(&later).is_ok());
    }

    #[test]
    fn a_part_written_whole_pays_for_the_reads_that_watch_the_part_before_it() {
        // 1 ms a word: 1 200 words take 1.2 s, watched every 0.5 s: two status reads of 72 ms.
        let unwatched = pace(72, 20, 1_000, 1_000);
        let watched = LinkPace {
            watch_every: Duration::from_millis(500),
            ..unwatched
        };
        let parts = [part(150, 5.0), part(1_200, 1.0)];
        let more = watched.need_s(&parts, 1) - unwatched.need_s(&parts, 1);
        assert!((more - 0.144).abs() < 1e-9, "{more}");
        // A preloaded part's start writes too little to be watched meanwhile.
        let light = [part(150, 5.0), preloaded(1_200, 1.0, 1)];
        assert!((watched.need_s(&light, 1) - unwatched.need_s(&light, 1)).abs() < 1e-12);
    }

    #[test]
    fn without_read_back_a_start_writes_its_blocks_once() {
        // 19200 baud as above, read_back = false: the block and directories written, not read.
        let on = pace(72, 20, 6_000, 1_000);
        let off = LinkPace {
            read_back: false,
            ..on
        };
        let block = on.exchange_s(BLOCK_WRITE_WORDS) + on.exchange_s(PERMIT_WRITE_WORDS);
        assert!((on.start_s() - off.start_s() - block).abs() < 1e-12);
        let parts = [part(150, 1.0), preloaded(200, 1.0, 3)];
        let directories = 3.0 * on.exchange_s(DIRECTORY_WORDS);
        assert!((on.need_s(&parts, 1) - off.need_s(&parts, 1) - block - directories).abs() < 1e-12);
        // A part before it that runs between the two estimates chains only without read-back.
        let runs_s = MARGIN * (off.need_s(&parts, 1) + on.need_s(&parts, 1)) / 2.0;
        let between = [part(150, runs_s), preloaded(200, 1.0, 3)];
        assert!(off.check(&between).is_ok());
        assert!(on.check(&between).is_err());
    }
}
