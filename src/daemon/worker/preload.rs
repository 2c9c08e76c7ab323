//! PURE. Which parts of a path section chained at speed are preloaded before its first part
//! starts from rest (see `Worker::preload_section`, which makes the writes): the choice for each
//! part behind the first, in order, from what the link has shown so far ([`LinkPace`]) and where
//! the parts before it went ([`Placement`]).
//!
//! The second part always is (there is no pace yet to judge by); each later one only while, at
//! the pace the preloads so far have shown, the parts not preloaded could not all be written
//! whole while the part before each runs, and only while its bank's areas hold it. A part that
//! would not fit even the empty areas of its bank (the first preloaded) can never be written:
//! the start is refused before anything moves.

use super::pace::{LinkPace, Part};
use super::placement::Placement;
use crate::contract::CHANNELS;
use crate::plc::exchange::ContractError;
use crate::table::ValidTable;

/// What to do with the next part.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Choice {
    /// Preload it, its tables at these words of its bank (per channel); the words are taken.
    Preload([usize; CHANNELS]),
    /// Preload no more: at the pace shown, the rest are written whole at their turns in time.
    Enough,
    /// Preload no more: its bank's areas are full; it is written whole at its turn.
    Full,
}

/// The choice for the next part, whose `tables` go into `bank`: `pace` is what the preloads so
/// far have shown (`None` before the first), `parts` the section's parts as the pace check sees
/// them with the preloads so far, `placement` where the parts before it went.
///
/// # Errors
/// [`ContractError::TooLarge`] when the first part preloaded would not fit even its empty bank.
pub(super) fn choose(
    pace: Option<&LinkPace>,
    parts: &[Part],
    placement: &mut Placement,
    bank: u16,
    tables: &[ValidTable],
) -> Result<Choice, ContractError> {
    if pace.is_some_and(|pace| pace.check(parts).is_ok()) {
        return Ok(Choice::Enough);
    }
    match placement.place(bank, tables) {
        Ok(base) => Ok(Choice::Preload(base)),
        Err((channel, words)) if pace.is_none() => Err(ContractError::TooLarge {
            channel,
            words,
            area_words: u16::try_from(placement.area_words()).unwrap_or(u16::MAX),
        }),
        Err(_) => Ok(Choice::Full),
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::table::DIRECTORY_WORDS;

    /// A table on `channel` of `rows` rows (4 words a row, 2 + 2 for the code and end marker).
    fn table(channel: u8, rows: usize) -> ValidTable {
        let targets: Vec<i64> = (1..=rows).map(|k| 100 * k as i64).collect();
        crate::table::rising(channel, &targets)
    }

    /// A link that took `status_ms` for a status read and preloaded 100 words in `preload_ms`.
    fn pace(status_ms: u64, preload_ms: u64) -> LinkPace {
        LinkPace {
            status: Duration::from_millis(status_ms),
            word: Duration::from_millis(status_ms / 3),
            preload: Duration::from_millis(preload_ms),
            preload_words: 100,
            read_back: true,
            permit_write: false,
            watch_every: Duration::from_secs(3_600),
        }
    }

    fn part(words: usize, runs_s: f64, preloaded: Option<usize>) -> Part {
        Part {
            words,
            runs_s,
            preloaded,
        }
    }

    /// A case: the pace so far, the parts as the check sees them, the next part's bank and
    /// rows, and what to do.
    type Case<'a> = (Option<LinkPace>, &'a [Part], u16, usize, &'a str);

    #[test]
    fn each_part_is_preloaded_while_the_pace_says_the_rest_would_be_late() {
        // (the pace so far, the parts as the check sees them, the next part's rows, what to do)
        let slow_rest = [
            part(0, 2.0, None),
            part(60, 0.3, Some(0)),
            part(400, 0.1, None),
        ];
        let quick_rest = [
            part(0, 2.0, None),
            part(60, 1.0, Some(0)),
            part(40, 1.0, None),
        ];
        // (the pace so far, the parts as the check sees them, the bank the next part goes into
        // and its rows (the first part's 400 rows fill most of bank 0), what to do)
        let cases: [Case<'_>; 5] = [
            // No pace yet: the second part is always preloaded.
            (None, &slow_rest, 1, 10, "preload"),
            // A slow link: the third part (400 words) cannot be written whole in 0.3 s.
            (Some(pace(70, 1_000)), &slow_rest, 0, 10, "preload"),
            // A quick link: the rest are written whole in time.
            (Some(pace(5, 30)), &quick_rest, 0, 10, "enough"),
            // A slow link, and the next part does not fit past the first in bank 0.
            (Some(pace(70, 1_000)), &slow_rest, 0, 200, "full"),
            // The same part fits the other bank.
            (Some(pace(70, 1_000)), &slow_rest, 1, 200, "preload"),
        ];
        for (k, (pace, parts, bank, rows, want)) in cases.into_iter().enumerate() {
            let mut placement = Placement::new(0, &[table(0, 400)], 2_000);
            let got = choose(
                pace.as_ref(),
                parts,
                &mut placement,
                bank,
                &[table(0, rows)],
            )
            .unwrap();
            let name = match got {
                Choice::Preload(base) => {
                    let past_first = if bank == 0 { 1_600 + 4 } else { 0 };
                    assert_eq!(base[0], DIRECTORY_WORDS + past_first, "case {k}");
                    "preload"
                }
                Choice::Enough => "enough",
                Choice::Full => "full",
            };
            assert_eq!(name, want, "case {k}");
        }
    }

    #[test]
    fn a_first_part_too_large_for_an_empty_bank_refuses_the_start() {
        let mut placement = Placement::new(0, &[table(0, 10)], 200);
        let e = choose(None, &[], &mut placement, 1, &[table(2, 60)]).unwrap_err();
        assert!(
            matches!(
                e,
                ContractError::TooLarge {
                    channel: 2,
                    area_words: 200,
                    ..
                }
            ),
            "{e:?}"
        );
        // The words were not taken: a smaller part still fits.
        assert!(matches!(
            choose(None, &[], &mut placement, 1, &[table(2, 10)]),
            Ok(Choice::Preload(_))
        ));
    }
}
