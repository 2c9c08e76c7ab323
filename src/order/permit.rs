//! PURE. A move's `permit` as an order writes it (`"press_open & !press_moving"`, `"X5 & !X6"`)
//! resolved to the contract's [`Permit`]: every term a signal's name or an X / R bit in one of
//! the four input words the PLC program copies into the status block, each optionally negated
//! with `!`, joined by `&`. The PLC checks exactly that (`inputs[i] & mask[i] == value[i]`), so
//! nothing else is a permit: an `|`, a DT word or a bit outside the input words is refused,
//! naming the term and the words there are.

use std::collections::BTreeMap;

use thiserror::Error;

use crate::contract::{INPUT_WORDS, InputArea, InputWord, Permit, PermitBit};
use crate::gateway::{Address, Area};

/// Why a permit cannot be checked by the PLC.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("permit {text:?}: {reason}")]
pub struct PermitError {
    /// The permit as given.
    pub text: String,
    /// What is wrong with it.
    pub reason: String,
}

/// What a permit's terms are resolved against.
#[derive(Debug, Clone, Copy)]
pub struct PermitNames<'a> {
    /// Signal name -> its bit.
    pub signals: &'a BTreeMap<String, Address>,
    /// The input words the PLC copies into the status block.
    pub inputs: &'a [InputWord; INPUT_WORDS],
}

impl PermitNames<'_> {
    /// The input word and bit `address` is, if it is in one of the input words.
    #[must_use]
    pub fn input_bit(&self, address: Address) -> Option<(usize, u8)> {
        let area = match address.area {
            Area::X => InputArea::X,
            Area::R => InputArea::R,
            _ => return None,
        };
        let (word, bit) = (address.index / 16, (address.index % 16) as u8);
        let at = self
            .inputs
            .iter()
            .position(|w| w.area == area && u32::from(w.word) == word)?;
        Some((at, bit))
    }

    fn words_named(&self) -> String {
        let names: Vec<String> = self.inputs.iter().map(ToString::to_string).collect();
        names.join(", ")
    }
}

/// Resolves `text` against `names`.
///
/// # Errors
/// The term at fault and why: not a signal or an input bit, an `|`, a DT word, a bit outside the
/// input words, one bit asked both ways.
pub fn resolve(text: &str, names: PermitNames<'_>) -> Result<Permit, PermitError> {
    let refuse = |reason: String| PermitError {
        text: text.to_owned(),
        reason,
    };
    if text.contains('|') {
        return Err(refuse(
            "the PLC checks an all-of (`&`) over its input words: `|` cannot be a permit".into(),
        ));
    }
    if text.trim().is_empty() {
        return Err(refuse(
            "is empty: leave `permit` out for a move with none".into(),
        ));
    }
    let mut bits = Vec::new();
    for term in text.split('&') {
        let term = term.trim();
        let (on, name) = match term.strip_prefix('!') {
            Some(rest) => (false, rest.trim()),
            None => (true, term),
        };
        if name.is_empty() {
            return Err(refuse(
                "has an empty term (two `&` in a row, or a lone `!`)".into(),
            ));
        }
        let address = match names.signals.get(name) {
            Some(a) => *a,
            None => name.parse::<Address>().map_err(|_| {
                let known: Vec<&str> = names.signals.keys().map(String::as_str).collect();
                refuse(format!(
                    "{name:?} is neither a signal ({}) nor an X or R bit",
                    if known.is_empty() {
                        "none named".to_owned()
                    } else {
                        known.join(", ")
                    }
                ))
            })?,
        };
        if address.area == Area::Dt {
            return Err(refuse(format!(
                "{name} is a DT word: a permit is input bits only (a `wait` may compare words)"
            )));
        }
        let (word, bit) = names.input_bit(address).ok_or_else(|| {
            refuse(format!(
                "{name} ({address}) is not in the input words the PLC copies ({}): the PLC \
                 could not check it",
                names.words_named()
            ))
        })?;
        bits.push(PermitBit { word, bit, on });
    }
    Permit::of(&bits).ok_or_else(|| refuse("asks one input bit to be both on and off".into()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn signals() -> BTreeMap<String, Address> {
        [
            ("press_open", "X5"),
            ("press_moving", "X6"),
            ("part", "R10A"),
            ("go", "Y0"),
        ]
        .into_iter()
        .map(|(n, a)| (n.to_owned(), a.parse().unwrap()))
        .collect()
    }

    fn resolved(text: &str) -> Result<Permit, PermitError> {
        let signals = signals();
        let names = PermitNames {
            signals: &signals,
            inputs: &InputWord::DEFAULTS,
        };
        resolve(text, names)
    }

    #[test]
    fn names_and_bits_resolve_to_the_words_the_plc_compares() {
        let p = resolved("press_open & !press_moving").unwrap();
        assert_eq!((p.mask, p.value), ([0x60, 0, 0, 0], [0x20, 0, 0, 0]));
        let p = resolved(" X5&!X6 & part & X1F ").unwrap();
        assert_eq!(p.mask, [0x60, 0x8000, 1 << 10, 0]);
        assert_eq!(p.value, [0x20, 0x8000, 1 << 10, 0]);
    }

    #[test]
    fn what_the_plc_cannot_check_is_refused_naming_the_term() {
        for (text, words) in [
            ("X5 | X6", "`|` cannot be a permit"),
            ("press_open & !press_open", "both on and off"),
            ("DT100", "DT100 is a DT word"),
            (
                "X25",
                "X25 (X25) is not in the input words the PLC copies (WX0, WX1, WR10, WR11)",
            ),
            ("go", "go (Y0) is not in the input words"),
            (
                "door_shut",
                "\"door_shut\" is neither a signal (go, part, press_moving, press_open)",
            ),
            ("X5 & & X6", "empty term"),
            ("  ", "is empty"),
        ] {
            let e = resolved(text).unwrap_err().to_string();
            assert!(
                e.contains(words) && e.contains(&format!("{text:?}")),
                "{text}: {e}"
            );
        }
    }
}
