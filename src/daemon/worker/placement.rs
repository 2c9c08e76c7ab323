//! PURE. Where the parts of a path section go in the PLC's table areas when they are preloaded
//! before the first part starts (see `Worker::preload_section`): the parts alternate between the
//! two banks, and in each bank every channel's segments follow those of the parts placed there
//! before them. A part whose segments begin at the directory's end has its directory written
//! with them; any other leaves its directory for its start, once the part before it in the same
//! bank has ended.

use crate::contract::CHANNELS;
use crate::table::{DIRECTORY_WORDS, ValidTable, encoded_words};

/// The words already taken in both banks' areas.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Placement {
    /// Per bank and channel, the first word no table placed so far takes.
    free: [[usize; CHANNELS]; 2],
    /// Words in each area.
    area_words: usize,
}

impl Placement {
    /// Both banks empty but for `tables`, the first part's, at the directory's end of `bank`.
    pub(super) fn new(bank: u16, tables: &[ValidTable], area_words: usize) -> Self {
        let mut placement = Self {
            free: [[DIRECTORY_WORDS; CHANNELS]; 2],
            area_words,
        };
        placement.free[usize::from(bank)] = after(placement.free[usize::from(bank)], tables);
        placement
    }

    /// Words in each area.
    pub(super) fn area_words(&self) -> usize {
        self.area_words
    }

    /// Where `tables` go in `bank` (per channel, the first word of their segments), taking
    /// those words; else, taking nothing, the first channel whose words would pass the end of
    /// its area, and where they would end.
    pub(super) fn place(
        &mut self,
        bank: u16,
        tables: &[ValidTable],
    ) -> Result<[usize; CHANNELS], (u8, usize)> {
        let base = self.free[usize::from(bank)];
        let end = after(base, tables);
        if let Some(c) = (0..CHANNELS).find(|&c| end[c] > self.area_words) {
            return Err((c as u8, end[c]));
        }
        self.free[usize::from(bank)] = end;
        Ok(base)
    }
}

/// `free` moved past each channel's segments in `tables`.
fn after(mut free: [usize; CHANNELS], tables: &[ValidTable]) -> [usize; CHANNELS] {
    for t in tables {
        free[usize::from(t.table().channel)] += encoded_words(t.table()) - DIRECTORY_WORDS;
    }
    free
}

/// How many directories a part placed at `base` leaves for its start to write: one per channel
/// of `tables` whose segments lie past another part's.
pub(super) fn directories_left(base: &[usize; CHANNELS], tables: &[ValidTable]) -> usize {
    tables
        .iter()
        .filter(|t| base[usize::from(t.table().channel)] > DIRECTORY_WORDS)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A table on `channel` of `rows` rows: 4 words a row, 2 for the control code, 2 for the
    /// end marker.
    fn table(channel: u8, rows: usize) -> ValidTable {
        let targets: Vec<i64> = (1..=rows).map(|k| 100 * k as i64).collect();
        crate::table::rising(channel, &targets)
    }

    #[test]
    fn parts_alternate_banks_each_past_the_tables_before_it_in_its_bank() {
        // The first part in bank 0: channel 0 takes 8 + 2 + 40 + 2 = 52 words, channel 2 none.
        let mut p = Placement::new(0, &[table(0, 10)], 2_000);
        // The second part in bank 1, at the directory's end: its directories go with it.
        let second = [table(0, 5), table(2, 5)];
        let base = p.place(1, &second).unwrap();
        assert_eq!(base, [8; CHANNELS]);
        assert_eq!(directories_left(&base, &second), 0);
        // The third in bank 0: channel 0 past the first part's 44 segment words, channel 2
        // (which the first part left empty) at the directory's end.
        let third = [table(0, 3), table(2, 3)];
        let base = p.place(0, &third).unwrap();
        assert_eq!(base, [52, 8, 8, 8]);
        assert_eq!(directories_left(&base, &third), 1);
        // The fourth in bank 1, past the second's 24 words on both channels.
        let base = p.place(1, &[table(0, 1), table(2, 1)]).unwrap();
        assert_eq!(base, [32, 8, 32, 8]);
        // The fifth in bank 0 again: past the first and the third (16 words a channel).
        assert_eq!(p.place(0, &[table(0, 1)]).unwrap(), [68, 8, 24, 8]);
    }

    #[test]
    fn a_part_that_would_pass_the_end_of_an_area_is_not_placed_and_takes_nothing() {
        // 100 words an area: the first part takes channel 1 to word 8 + 84 = 92.
        let mut p = Placement::new(0, &[table(1, 20)], 100);
        let before = p.clone();
        // 2 + 8 + 2 = 12 more words would end at 104.
        assert_eq!(p.place(0, &[table(1, 2)]), Err((1, 104)));
        assert_eq!(p, before);
        // 8 words end exactly at the area's end.
        assert_eq!(p.place(0, &[table(1, 1)]).unwrap(), [8, 92, 8, 8]);
        // The other bank still has room.
        assert_eq!(p.place(1, &[table(1, 20)]).unwrap(), [8; CHANNELS]);
    }
}
