//! Version 3's cell inputs: the four input words the PLC program copies into the status block
//! every scan (`inputs[0..3]`, status +22..+25), and a start's permit over them (command
//! +17..+24).
//!
//! ```text
//!  inputs = ["WX0", "WX1", "WR10", "WR11"]    the words the integrator names in the program
//!  X5  -> inputs[0] bit 5      R10A -> inputs[2] bit 10 (R10A = word 10, bit A)
//!  permit holds  <=>  inputs[i] & mask[i] == value[i]  for every i
//! ```

use std::fmt;
use std::str::FromStr;

use thiserror::Error;

/// Input words copied into the status block.
pub const INPUT_WORDS: usize = 4;

/// The area an input word is copied from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InputArea {
    /// External inputs (WX).
    X,
    /// Internal relays (WR), e.g. set by the press PLC over a link.
    R,
}

/// One of the words the PLC program copies into `inputs`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct InputWord {
    /// X or R.
    pub area: InputArea,
    /// The word number (WX0 = 0, WR10 = 10).
    pub word: u16,
}

impl InputWord {
    /// The words CONTRACT.md gives as its example, and the reference listing copies.
    pub const DEFAULTS: [Self; INPUT_WORDS] = [
        Self::x(0),
        Self::x(1),
        Self {
            area: InputArea::R,
            word: 10,
        },
        Self {
            area: InputArea::R,
            word: 11,
        },
    ];

    const fn x(word: u16) -> Self {
        Self {
            area: InputArea::X,
            word,
        }
    }
}

impl fmt::Display for InputWord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let area = match self.area {
            InputArea::X => "WX",
            InputArea::R => "WR",
        };
        write!(f, "{area}{}", self.word)
    }
}

/// Why a text is not an input word.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{text:?} is not an input word: write WX<n> (n 0..=109) or WR<n> (n 0..=255)")]
pub struct InputWordError {
    /// The text given.
    pub text: String,
}

impl FromStr for InputWord {
    type Err = InputWordError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = || InputWordError {
            text: text.to_owned(),
        };
        let upper = text.trim().to_ascii_uppercase();
        let (area, digits, last) = if let Some(d) = upper.strip_prefix("WX") {
            (InputArea::X, d, 109)
        } else if let Some(d) = upper.strip_prefix("WR") {
            (InputArea::R, d, 255)
        } else {
            return Err(bad());
        };
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Err(bad());
        }
        let word: u16 = digits.parse().map_err(|_| bad())?;
        if word > last {
            return Err(bad());
        }
        Ok(Self { area, word })
    }
}

/// A start's permit: the bits of each input word it looks at and the values they must have.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct Permit {
    /// Per input word, the bits the permit looks at.
    pub mask: [u16; INPUT_WORDS],
    /// Per input word, the values those bits must have (only bits in `mask`).
    pub value: [u16; INPUT_WORDS],
}

/// One input bit a permit needs, and the value it needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PermitBit {
    /// Which of the input words.
    pub word: usize,
    /// The bit in it (0..=15).
    pub bit: u8,
    /// The value the permit needs.
    pub on: bool,
}

impl Permit {
    /// No permit: every start may run (all words 0).
    pub const NONE: Self = Self {
        mask: [0; INPUT_WORDS],
        value: [0; INPUT_WORDS],
    };

    /// Whether the permit looks at no input.
    #[must_use]
    pub fn is_none(&self) -> bool {
        self.mask == [0; INPUT_WORDS]
    }

    /// A permit requiring `bits`; `None` when two of them ask one bit for both values.
    #[must_use]
    pub fn of(bits: &[PermitBit]) -> Option<Self> {
        let mut p = Self::NONE;
        for b in bits {
            let m = 1u16 << b.bit;
            let v = if b.on { m } else { 0 };
            if p.mask[b.word] & m != 0 && p.value[b.word] & m != v {
                return None;
            }
            p.mask[b.word] |= m;
            p.value[b.word] |= v;
        }
        Some(p)
    }

    /// Whether it holds on `inputs` (the contract's rule, word by word).
    #[must_use]
    pub fn holds(&self, inputs: &[u16; INPUT_WORDS]) -> bool {
        (0..INPUT_WORDS).all(|i| inputs[i] & self.mask[i] == self.value[i])
    }

    /// The bits it needs that `inputs` do not have, in word and bit order.
    #[must_use]
    pub fn unmet(&self, inputs: &[u16; INPUT_WORDS]) -> Vec<PermitBit> {
        let mut out = Vec::new();
        for (word, input) in inputs.iter().enumerate() {
            for bit in 0..16u8 {
                let m = 1u16 << bit;
                if self.mask[word] & m != 0 && (input ^ self.value[word]) & m != 0 {
                    out.push(PermitBit {
                        word,
                        bit,
                        on: self.value[word] & m != 0,
                    });
                }
            }
        }
        out
    }

    /// Whether its value words set only bits its mask looks at (a command block the PLC can
    /// honour as written).
    #[must_use]
    pub fn is_well_formed(&self) -> bool {
        (0..INPUT_WORDS).all(|i| self.value[i] & !self.mask[i] == 0)
    }
}

/// What `permit` lacks on `inputs`, named by `words`: "X5 is off (the permit needs it on)".
#[must_use]
pub fn describe_unmet(
    permit: &Permit,
    inputs: &[u16; INPUT_WORDS],
    words: &[InputWord; INPUT_WORDS],
) -> String {
    let parts: Vec<String> = permit
        .unmet(inputs)
        .iter()
        .map(|b| {
            let (is, needs) = if b.on { ("off", "on") } else { ("on", "off") };
            format!(
                "{} is {is} (the permit needs it {needs})",
                bit_name(words[b.word], b.bit)
            )
        })
        .collect();
    parts.join(", ")
}

/// The Panasonic name of bit `bit` of `word` (`X5`, `X1A`, `R10A`).
#[must_use]
pub fn bit_name(word: InputWord, bit: u8) -> String {
    let area = match word.area {
        InputArea::X => "X",
        InputArea::R => "R",
    };
    format!(
        "{area}{}{bit:X}",
        if word.word == 0 {
            String::new()
        } else {
            word.word.to_string()
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn input_words_read_as_panasonic_writes_them_and_refuse_the_rest() {
        assert_eq!("WX0".parse::<InputWord>().unwrap(), InputWord::DEFAULTS[0]);
        assert_eq!("wr10".parse::<InputWord>().unwrap(), InputWord::DEFAULTS[2]);
        assert_eq!(InputWord::DEFAULTS[3].to_string(), "WR11");
        for bad in ["X0", "WY0", "WX", "WX110", "WR256", "WX-1", "WX1.5", ""] {
            let e = bad.parse::<InputWord>().unwrap_err().to_string();
            assert!(
                e.contains(&format!("{bad:?}")) && e.contains("WX<n>"),
                "{e}"
            );
        }
    }

    #[test]
    fn a_permit_holds_only_when_every_looked_at_bit_has_its_value() {
        let p = Permit::of(&[
            PermitBit {
                word: 0,
                bit: 5,
                on: true,
            },
            PermitBit {
                word: 0,
                bit: 6,
                on: false,
            },
            PermitBit {
                word: 2,
                bit: 0,
                on: true,
            },
        ])
        .unwrap();
        assert_eq!(p.mask, [0x60, 0, 1, 0]);
        assert_eq!(p.value, [0x20, 0, 1, 0]);
        assert!(p.is_well_formed());
        assert!(p.holds(&[0x20, 0xFFFF, 1, 7]));
        assert!(p.holds(&[0xFFBF, 0, 0xFFFF, 0]));
        assert!(!p.holds(&[0x60, 0, 1, 0]));
        assert_eq!(
            p.unmet(&[0x40, 0, 0, 0]),
            vec![
                PermitBit {
                    word: 0,
                    bit: 5,
                    on: true
                },
                PermitBit {
                    word: 0,
                    bit: 6,
                    on: false
                },
                PermitBit {
                    word: 2,
                    bit: 0,
                    on: true
                },
            ]
        );
        assert!(Permit::NONE.holds(&[1, 2, 3, 4]) && Permit::NONE.is_none());
    }

    #[test]
    fn a_permit_asking_one_bit_for_both_values_is_none() {
        let both = [
            PermitBit {
                word: 1,
                bit: 3,
                on: true,
            },
            PermitBit {
                word: 1,
                bit: 3,
                on: false,
            },
        ];
        assert_eq!(Permit::of(&both), None);
    }

    #[test]
    fn bits_are_named_as_panasonic_writes_them() {
        assert_eq!(bit_name(InputWord::DEFAULTS[0], 5), "X5");
        assert_eq!(bit_name(InputWord::DEFAULTS[1], 10), "X1A");
        assert_eq!(bit_name(InputWord::DEFAULTS[2], 10), "R10A");
    }
}
