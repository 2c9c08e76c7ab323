//! The mock PLC's device memory: DT data registers, X inputs, Y outputs and R internal relays,
//! with range errors a server turns into MEWTOCOL error 61/66 or Modbus exception 02/03.
//!
//! ```text
//! DT0 ..= DT32764          u16 words (FP-X C30/C60, PLC.md §3 "Special registers")
//! WX0 ..= WX109            X inputs, bit = word * 16 + bit (X0 ..= X109F); set by a test
//! WY0 ..= WY109            Y outputs (Y0 ..= Y109F)
//! WR0 ..= WR255            R relays (R0 ..= R255F)
//! ```

use thiserror::Error;

use crate::contract::DT_LAST;
use crate::gateway::Area;

/// Words of R relays (WR0..=WR255: R0..=R255F, the FP-X's 4096 internal relays).
pub const RELAY_WORDS: u16 = 256;
/// The last relay number (R255F).
pub const RELAY_LAST: u16 = RELAY_WORDS * 16 - 1;
/// Words of X inputs and of Y outputs (X0..=X109F, Y0..=Y109F on an FP-X C60).
pub const IO_WORDS: u16 = 110;
/// The first relay word kept through a power cut: WR248..=WR255 (R2480..=R255F) is the FP-X's
/// fixed hold area (kept without a battery, as the FP0R's is); the relays below it are
/// non-hold, off at power-up.
pub const RELAY_HOLD_WORD: u16 = 248;

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
    /// A bit outside its area.
    #[error("{area} bit number {bit} is outside {area}0..={area}{last_word}F", last_word = last / 16)]
    BitOutOfRange {
        /// `X`, `Y` or `R`.
        area: &'static str,
        /// Bit number asked for (word * 16 + bit).
        bit: u32,
        /// The area's last bit number.
        last: u16,
    },
    /// Bit words outside their area.
    #[error("W{area}{start}..=W{area}{end} is outside W{area}0..=W{area}{last}")]
    BitWordOutOfRange {
        /// `X`, `Y` or `R`.
        area: &'static str,
        /// First word asked for.
        start: u32,
        /// Last word asked for.
        end: u32,
        /// The area's last word.
        last: u16,
    },
    /// An area that holds no bits (DT).
    #[error("{area} holds words, not bits")]
    NotBits {
        /// The area.
        area: &'static str,
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
            | Self::BitWordOutOfRange { start, last, .. } => {
                if start > u32::from(last) {
                    66
                } else {
                    61
                }
            }
            Self::BitOutOfRange { .. } | Self::NotBits { .. } => 66,
        }
    }

    /// The Modbus exception a slave answers: 02, illegal data address (03, illegal data value,
    /// is for a bad quantity, which the protocol layer checks before memory is reached).
    #[must_use]
    pub fn modbus_exception(&self) -> u8 {
        2
    }
}

/// DT words and X, Y and R bits.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Memory {
    dt: Vec<u16>,
    wx: Vec<u16>,
    wy: Vec<u16>,
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
            wx: vec![0; usize::from(IO_WORDS)],
            wy: vec![0; usize::from(IO_WORDS)],
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

    fn words(&self, area: Area) -> Result<&Vec<u16>, MemoryError> {
        match area {
            Area::X => Ok(&self.wx),
            Area::Y => Ok(&self.wy),
            Area::R => Ok(&self.wr),
            Area::Dt => Err(MemoryError::NotBits { area: "DT" }),
        }
    }

    fn words_mut(&mut self, area: Area) -> Result<&mut Vec<u16>, MemoryError> {
        match area {
            Area::X => Ok(&mut self.wx),
            Area::Y => Ok(&mut self.wy),
            Area::R => Ok(&mut self.wr),
            Area::Dt => Err(MemoryError::NotBits { area: "DT" }),
        }
    }

    fn word_span(
        &self,
        area: Area,
        start: u32,
        count: usize,
    ) -> Result<std::ops::Range<usize>, MemoryError> {
        let len = self.words(area)?.len();
        span(start, count, len).ok_or(MemoryError::BitWordOutOfRange {
            area: area.name(),
            start,
            end: (start as usize + count.max(1) - 1) as u32,
            last: len as u16 - 1,
        })
    }

    /// Reads `count` bit words of `area` (X, Y or R) from word `start`.
    pub fn read_bit_words(
        &self,
        area: Area,
        start: u32,
        count: usize,
    ) -> Result<&[u16], MemoryError> {
        let range = self.word_span(area, start, count)?;
        Ok(&self.words(area)?[range])
    }

    /// Reads `count` relay words WR`start`...
    pub fn read_wr(&self, start: u32, count: usize) -> Result<&[u16], MemoryError> {
        self.read_bit_words(Area::R, start, count)
    }

    /// Writes relay words from WR`start`; nothing is written if any word is out of range.
    pub fn write_wr(&mut self, start: u32, words: &[u16]) -> Result<(), MemoryError> {
        let range = self.word_span(Area::R, start, words.len())?;
        self.wr[range].copy_from_slice(words);
        Ok(())
    }

    fn bit_at(&self, area: Area, bit: u32) -> Result<(usize, u16), MemoryError> {
        let last = self.words(area)?.len() as u32 * 16 - 1;
        if bit > last {
            return Err(MemoryError::BitOutOfRange {
                area: area.name(),
                bit,
                last: last as u16,
            });
        }
        Ok(((bit / 16) as usize, 1 << (bit % 16)))
    }

    /// Reads bit `bit` (word * 16 + bit) of `area` (X, Y or R).
    pub fn bit(&self, area: Area, bit: u32) -> Result<bool, MemoryError> {
        let (word, mask) = self.bit_at(area, bit)?;
        Ok(self.words(area)?[word] & mask != 0)
    }

    /// Writes bit `bit` of `area`.
    pub fn set_bit(&mut self, area: Area, bit: u32, on: bool) -> Result<(), MemoryError> {
        let (word, mask) = self.bit_at(area, bit)?;
        let words = self.words_mut(area)?;
        if on {
            words[word] |= mask;
        } else {
            words[word] &= !mask;
        }
        Ok(())
    }

    /// A power cut: every Y output and every non-hold relay (below [`RELAY_HOLD_WORD`]) off.
    /// Returns the bits that were on, Y then R (bit numbers word * 16 + bit).
    pub fn power_cut(&mut self) -> (Vec<u32>, Vec<u32>) {
        let on = |words: &[u16]| -> Vec<u32> {
            (0..words.len() as u32 * 16)
                .filter(|b| words[(b / 16) as usize] & (1 << (b % 16)) != 0)
                .collect()
        };
        let hold = usize::from(RELAY_HOLD_WORD);
        let lost = (on(&self.wy), on(&self.wr[..hold]));
        self.wy.fill(0);
        self.wr[..hold].fill(0);
        lost
    }

    /// Reads relay R`relay` (`relay` = word * 16 + bit).
    pub fn relay(&self, relay: u32) -> Result<bool, MemoryError> {
        self.bit(Area::R, relay)
    }

    /// Writes relay R`relay`.
    pub fn set_relay(&mut self, relay: u32, on: bool) -> Result<(), MemoryError> {
        self.set_bit(Area::R, relay, on)
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
    fn x_y_and_r_bits_are_three_areas() {
        let mut m = Memory::new();
        m.set_bit(Area::Y, 17, true).unwrap();
        m.set_bit(Area::X, 1, true).unwrap();
        assert!(m.bit(Area::Y, 17).unwrap() && !m.bit(Area::R, 17).unwrap());
        assert_eq!(m.read_bit_words(Area::Y, 1, 1).unwrap(), &[2]);
        assert_eq!(m.read_bit_words(Area::X, 0, 1).unwrap(), &[2]);
        let e = m.bit(Area::Y, 110 * 16).unwrap_err();
        assert_eq!(e.to_string(), "Y bit number 1760 is outside Y0..=Y109F");
        assert!(matches!(
            m.bit(Area::Dt, 0),
            Err(MemoryError::NotBits { .. })
        ));
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
            Err(MemoryError::BitWordOutOfRange { last: 255, .. })
        ));
    }
}
