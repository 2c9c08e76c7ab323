//! Where the contract's blocks and table areas sit in DT memory. Every base is configuration;
//! the defaults are CONTRACT.md's.

use thiserror::Error;

use super::{BANKS, CHANNELS, COMMAND_WORDS, DT_LAST, INPUT_WORDS, InputWord, STATUS_WORDS};

/// Addresses of the status block, the command block and the table areas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// First DT word of the status block.
    pub status_base: u16,
    /// First DT word of the command block.
    pub command_base: u16,
    /// First DT word of bank 0, channel 0's table area.
    pub table_base: u16,
    /// Words from one bank's areas to the next's.
    pub bank_stride: u16,
    /// Words from one channel's area to the next's within a bank.
    pub channel_stride: u16,
    /// Words in each channel's area.
    pub area_words: u16,
    /// The input words the program copies into the status block (version 3).
    pub inputs: [InputWord; INPUT_WORDS],
}

impl Default for Layout {
    fn default() -> Self {
        Self {
            status_base: 1_000,
            command_base: 1_032,
            table_base: 2_000,
            bank_stride: 8_000,
            channel_stride: 2_000,
            area_words: 2_000,
            inputs: InputWord::DEFAULTS,
        }
    }
}

/// Why a layout cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum LayoutError {
    /// A region runs past the end of DT memory.
    #[error("{region} ends at DT{end}; the FP-X DT area ends at DT{DT_LAST}")]
    PastEnd {
        /// Which region.
        region: String,
        /// Its last word.
        end: u32,
    },
    /// Two regions share words.
    #[error("{a} (DT{a_start}..=DT{a_end}) overlaps {b} (DT{b_start}..=DT{b_end})")]
    Overlap {
        /// First region.
        a: String,
        /// Its first word.
        a_start: u32,
        /// Its last word.
        a_end: u32,
        /// Second region.
        b: String,
        /// Its first word.
        b_start: u32,
        /// Its last word.
        b_end: u32,
    },
}

impl Layout {
    /// First DT word of a channel's table area in a bank.
    #[must_use]
    pub fn area(&self, bank: u16, channel: usize) -> u16 {
        self.table_base + bank * self.bank_stride + channel as u16 * self.channel_stride
    }

    /// The bank and channel of the table area DT word `word` lies in, if it lies in one.
    #[must_use]
    pub fn table_area_of(&self, word: u32) -> Option<(u16, usize)> {
        (0..BANKS)
            .flat_map(|bank| (0..CHANNELS).map(move |channel| (bank, channel)))
            .find(|&(bank, channel)| {
                let start = u32::from(self.area(bank, channel));
                (start..start + u32::from(self.area_words)).contains(&word)
            })
    }

    /// Whether DT word `word` belongs to the contract (its blocks or a table area).
    #[must_use]
    pub fn holds(&self, word: u32) -> bool {
        self.regions()
            .iter()
            .any(|(_, start, end)| (*start..=*end).contains(&word))
    }

    fn regions(&self) -> Vec<(String, u32, u32)> {
        let span =
            |start: u16, words: usize| (u32::from(start), u32::from(start) + words as u32 - 1);
        let mut out = vec![
            (
                "status block".to_owned(),
                span(self.status_base, STATUS_WORDS),
            ),
            (
                "command block".to_owned(),
                span(self.command_base, COMMAND_WORDS),
            ),
        ];
        for bank in 0..BANKS {
            for ch in 0..CHANNELS {
                let start = u32::from(self.table_base)
                    + u32::from(bank) * u32::from(self.bank_stride)
                    + ch as u32 * u32::from(self.channel_stride);
                out.push((
                    format!("bank {bank} channel {ch} table area"),
                    (start, start + u32::from(self.area_words) - 1),
                ));
            }
        }
        out.into_iter().map(|(n, (s, e))| (n, s, e)).collect()
    }

    /// Checks that every region lies inside DT memory and that no two share a word.
    pub fn check(&self) -> Result<(), LayoutError> {
        let regions = self.regions();
        for (name, _, end) in &regions {
            if *end > u32::from(DT_LAST) {
                return Err(LayoutError::PastEnd {
                    region: name.clone(),
                    end: *end,
                });
            }
        }
        for (i, (a, a_start, a_end)) in regions.iter().enumerate() {
            for (b, b_start, b_end) in &regions[i + 1..] {
                if a_start <= b_end && b_start <= a_end {
                    return Err(LayoutError::Overlap {
                        a: a.clone(),
                        a_start: *a_start,
                        a_end: *a_end,
                        b: b.clone(),
                        b_start: *b_start,
                        b_end: *b_end,
                    });
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_layout_is_contract_md_and_fits() {
        let l = Layout::default();
        assert_eq!(l.area(0, 0), 2_000);
        assert_eq!(l.area(1, 3), 2_000 + 8_000 + 6_000);
        assert!(l.check().is_ok());
    }

    #[test]
    fn a_word_is_placed_in_its_banks_channel_area_and_none_outside_them() {
        let l = Layout::default();
        // Bank 0 channel 0 from DT2000, channel 1 from DT4000; bank 1 from DT10000.
        assert_eq!(l.table_area_of(2_000), Some((0, 0)));
        assert_eq!(l.table_area_of(3_999), Some((0, 0)));
        assert_eq!(l.table_area_of(4_000), Some((0, 1)));
        assert_eq!(l.table_area_of(10_000), Some((1, 0)));
        assert_eq!(l.table_area_of(17_999), Some((1, 3)));
        // The blocks and past the last area: none.
        assert_eq!(l.table_area_of(1_032), None);
        assert_eq!(l.table_area_of(1_999), None);
        assert_eq!(l.table_area_of(18_000), None);
    }

    #[test]
    fn area_past_dt_end_is_refused() {
        let l = Layout {
            table_base: 20_000,
            ..Layout::default()
        };
        let e = l.check().unwrap_err().to_string();
        assert!(
            e.contains("bank 1 channel 2") && e.contains("DT32764"),
            "{e}"
        );
    }

    #[test]
    fn overlapping_blocks_are_refused() {
        let l = Layout {
            command_base: 1_010,
            ..Layout::default()
        };
        assert!(matches!(l.check(), Err(LayoutError::Overlap { .. })));
    }
}
