//! The mock PLC's device memory: DT data registers and R internal relays, with range errors a
//! server turns into MEWTOCOL error 61/66 or Modbus exception 02/03.
//!
//! ```text
//! DT0 ..= DT32764          u16 words (FP-X C30/C60, PLC.md §3 "Special registers")
//! WR0 ..= WR255            u16 words of R relays; relay number = word * 16 + bit (R0 ..= R255F)
//! ```

use thiserror::Error;

use crate::contract::DT_LAST;

/// Words of R relays (WR0..=WR255: R0..=R255F, the FP-X's 4096 internal relays).
pub const RELAY_WORDS: u16 = 256;
/// The last relay number (R255F).
pub const RELAY_LAST: u16 = RELAY_WORDS * 16 - 1;

/// An access outside the mock's memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum MemoryError {
    /// DT words outside DT0..=DT`last`.
    #[error("DT{start}..=DT{end} is outside DT0..=DT{last}")]
    DtOutOfRange {
        /// First word asked for.
        start: u32,
        /// Last word asked for.
        end: u32,
        /// The last DT word.
        last: u16,
    },
    /// A relay outside R0..=R255F.
    #[error("relay number {relay} is outside R0..=R{last_word}F", last_word = last / 16)]
    RelayOutOfRange {
        /// Relay number asked for (word * 16 + bit).
        relay: u32,
        /// The last relay number.
        last: u16,
    },
    /// Relay words outside WR0..=WR`last`.
    #[error("WR{start}..=WR{end} is outside WR0..=WR{last}")]
    RelayWordOutOfRange {
        /// First word asked for.
        start: u32,
        /// Last word asked for.
        end: u32,
        /// The last relay word.
        last: u16,
    },
}

impl MemoryError {
    /// The MEWTOCOL-COM error a PLC answers (PLC.md §1, "Error codes"): 66 (address error) when
    /// the first address is already outside the area, 61 (data error, range) when only the end of
    /// the range runs past it.
    #[must_use]
    pub fn mewtocol_code(&self) -> u8 {
        match *self {
            Self::DtOutOfRange { start, last, .. }
            | Self::RelayWordOutOfRange { start, last, .. } => {
                if start > u32::from(last) {
                    66
                } else {
                    61
                }
            }
            Self::RelayOutOfRange { .. } => 66,
        }
    }

    /// The Modbus exception a slave answers: 02, illegal data address (03, illegal data value,
    /// is for a bad quantity, which the protocol layer checks before memory is reached).
    #[must_use]
    pub fn modbus_exception(&self) -> u8 {
        2
    }
}

/// DT words and R relays.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Memory {
    dt: Vec<u16>,
    wr: Vec<u16>,
}

impl Default for Memory {
    fn default() -> Self {
        Self::new()
    }
}

/// The index range `start..start + count`, or `None` past `len`.
fn span(start: u32, count: usize, len: usize) -> Option<std::ops::Range<usize>> {
    let from = start as usize;
    let to = from.checked_add(count)?;
    (to <= len).then_some(from..to)
}

impl Memory {
    /// All zero.
    #[must_use]
    pub fn new() -> Self {
        Self {
            dt: vec![0; usize::from(DT_LAST) + 1],
            wr: vec![0; usize::from(RELAY_WORDS)],
        }
    }

    fn dt_span(&self, start: u32, count: usize) -> Result<std::ops::Range<usize>, MemoryError> {
        span(start, count, self.dt.len()).ok_or(MemoryError::DtOutOfRange {
            start,
            end: (start as usize + count.max(1) - 1) as u32,
            last: DT_LAST,
        })
    }

    /// Reads `count` DT words from `start`.
    pub fn read_dt(&self, start: u32, count: usize) -> Result<&[u16], MemoryError> {
        Ok(&self.dt[self.dt_span(start, count)?])
    }

    /// Writes `words` to DT from `start`; nothing is written if any word is out of range.
    pub fn write_dt(&mut self, start: u32, words: &[u16]) -> Result<(), MemoryError> {
        let range = self.dt_span(start, words.len())?;
        self.dt[range].copy_from_slice(words);
        Ok(())
    }

    /// One DT word.
    pub fn dt(&self, address: u32) -> Result<u16, MemoryError> {
        Ok(self.read_dt(address, 1)?[0])
    }

    fn wr_span(&self, start: u32, count: usize) -> Result<std::ops::Range<usize>, MemoryError> {
        span(start, count, self.wr.len()).ok_or(MemoryError::RelayWordOutOfRange {
            start,
            end: (start as usize + count.max(1) - 1) as u32,
            last: RELAY_WORDS - 1,
        })
    }

    /// Reads `count` relay words WR`start`...
    pub fn read_wr(&self, start: u32, count: usize) -> Result<&[u16], MemoryError> {
        Ok(&self.wr[self.wr_span(start, count)?])
    }

    /// Writes relay words from WR`start`; nothing is written if any word is out of range.
    pub fn write_wr(&mut self, start: u32, words: &[u16]) -> Result<(), MemoryError> {
        let range = self.wr_span(start, words.len())?;
        self.wr[range].copy_from_slice(words);
        Ok(())
    }

    fn relay_at(relay: u32) -> Result<(usize, u16), MemoryError> {
        if relay > u32::from(RELAY_LAST) {
            return Err(MemoryError::RelayOutOfRange {
                relay,
                last: RELAY_LAST,
            });
        }
        Ok(((relay / 16) as usize, 1 << (relay % 16)))
    }

    /// Reads relay R`relay` (`relay` = word * 16 + bit).
    pub fn relay(&self, relay: u32) -> Result<bool, MemoryError> {
        let (word, bit) = Self::relay_at(relay)?;
        Ok(self.wr[word] & bit != 0)
    }

    /// Writes relay R`relay`.
    pub fn set_relay(&mut self, relay: u32, on: bool) -> Result<(), MemoryError> {
        let (word, bit) = Self::relay_at(relay)?;
        if on {
            self.wr[word] |= bit;
        } else {
            self.wr[word] &= !bit;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn last_dt_word_is_writable_and_the_next_is_not() {
        let mut m = Memory::new();
        m.write_dt(32_763, &[1, 2]).unwrap();
        assert_eq!(m.read_dt(32_763, 2).unwrap(), &[1, 2]);
        let e = m.write_dt(32_764, &[1, 2]).unwrap_err();
        assert_eq!(
            e,
            MemoryError::DtOutOfRange {
                start: 32_764,
                end: 32_765,
                last: 32_764
            }
        );
        assert_eq!(m.dt(32_764).unwrap(), 2, "a refused write changes nothing");
        assert!(e.to_string().contains("DT32764..=DT32765"), "{e}");
    }

    #[test]
    fn range_errors_map_to_mewtocol_61_or_66_and_modbus_02() {
        let m = Memory::new();
        let partly = m.read_dt(32_760, 10).unwrap_err();
        let wholly = m.read_dt(40_000, 1).unwrap_err();
        assert_eq!((partly.mewtocol_code(), wholly.mewtocol_code()), (61, 66));
        assert_eq!(m.relay(5_000).unwrap_err().mewtocol_code(), 66);
        assert_eq!(partly.modbus_exception(), 2);
    }

    #[test]
    fn relay_number_is_word_times_sixteen_plus_bit() {
        let mut m = Memory::new();
        m.set_relay(0x11, true).unwrap(); // R1.1
        assert_eq!(m.read_wr(1, 1).unwrap(), &[0b10]);
        assert!(m.relay(17).unwrap());
        m.set_relay(17, false).unwrap();
        assert!(!m.relay(17).unwrap());
    }

    #[test]
    fn relay_past_r255f_is_refused_naming_the_limit() {
        let m = Memory::new();
        assert!(m.relay(4_095).is_ok());
        let e = m.relay(4_096).unwrap_err();
        assert!(e.to_string().contains("R255F"), "{e}");
        assert!(matches!(
            m.read_wr(255, 2),
            Err(MemoryError::RelayWordOutOfRange { last: 255, .. })
        ));
    }
}
