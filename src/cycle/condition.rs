//! PURE. A `wait`'s condition: input bits and signal names, DT words compared with a value,
//! `!` (not), `&` (all of), `|` (any of), parentheses; `&` binds tighter than `|`.
//!
//! ```text
//!  part_present & (press_open | X7) & !R10A
//!  DT100 == 3 | DT101 >= -5
//! ```
//! Every term is resolved before anything runs: a bit in one of the four input words the PLC
//! copies into the status block is read at no cost with every status read; any other bit or a
//! DT word is read through the gateway (it must be in the robot's read list) each time the
//! condition is decided.

use std::collections::BTreeMap;
use std::fmt;

use thiserror::Error;

use crate::gateway::{AccessList, Address, Area, Denied, Range};
use crate::order::permit::PermitNames;

/// A condition that does not parse or resolve.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("condition {text:?}: {reason}")]
pub struct ConditionError {
    /// The condition as given.
    pub text: String,
    /// What is wrong.
    pub reason: ConditionFault,
}

/// What is wrong with a condition, naming the term or the character.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ConditionFault {
    /// Nothing to decide.
    #[error("is empty")]
    Empty,
    /// Digits that do not make a number.
    #[error("{digits:?} is not a number")]
    NotANumber {
        /// The digits.
        digits: String,
    },
    /// A character no term begins with.
    #[error("{found:?} at character {at} is not understood")]
    NotUnderstood {
        /// The character.
        found: char,
        /// Where, from 1.
        at: usize,
    },
    /// A `(` with no `)`.
    #[error("a `(` is not closed")]
    NotClosed,
    /// Something else where a term belongs.
    #[error("expected an input, a signal or `(`, found {found}")]
    Unexpected {
        /// What was found, as the parser names it.
        found: String,
    },
    /// The text ends where a term belongs.
    #[error("ends where an input, a signal or `(` was expected")]
    EndsEarly,
    /// A name that is no signal and no address.
    #[error("{name:?} is neither a signal ({known}) nor an address (X5, R10A, DT100)")]
    Unknown {
        /// The name.
        name: String,
        /// The signals there are, in words.
        known: String,
    },
    /// A compare with no number after it.
    #[error("{name} {compare} needs a number after it")]
    NoNumber {
        /// The term compared.
        name: String,
        /// The compare.
        compare: &'static str,
    },
    /// A bit compared with a value.
    #[error("{name} is a bit: only a DT word is compared with a value")]
    BitCompared {
        /// The bit.
        name: String,
    },
    /// A value no DT word holds.
    #[error("{value} is outside a DT word's -32768..=32767 (compared as signed)")]
    OutOfRange {
        /// The value.
        value: i64,
    },
    /// A DT word not compared.
    #[error("{name} is a DT word: compare it (`{name} == 1`)")]
    WordNotCompared {
        /// The word.
        name: String,
    },
    /// An address past its area.
    #[error("{address} does not exist")]
    NoSuchAddress {
        /// The address.
        address: Address,
    },
    /// An address the gateway may not read, outside the input words.
    #[error(
        "{address} is not in the input words the PLC copies and cannot be read: {denied} (add \
         it to [robots.NAME.gateway] read, or copy its word into the status block)"
    )]
    NotReadable {
        /// The address.
        address: Address,
        /// Why the gateway refuses it.
        denied: Denied,
    },
    /// A pallet term that is not one.
    #[error(
        "{name}: a pallet is read as pallet.NAME.full, pallet.NAME.layer == N or pallet.NAME.index < N"
    )]
    PalletTerm {
        /// The term as written.
        name: String,
    },
    /// Terms after a whole condition.
    #[error("{left} is left over after a whole condition")]
    LeftOver {
        /// The first of them, as the parser names it.
        left: String,
    },
}

/// Where a term's value comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// Bit `bit` of input word `word` of the status block.
    Input {
        /// Which of the four input words.
        word: usize,
        /// The bit.
        bit: u8,
    },
    /// A bit or DT word read through the gateway.
    Read(Address),
}

/// A comparison of a DT word with a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compare {
    /// `==`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
}

impl Compare {
    fn symbol(self) -> &'static str {
        match self {
            Self::Eq => "==",
            Self::Ne => "!=",
            Self::Lt => "<",
            Self::Le => "<=",
            Self::Gt => ">",
            Self::Ge => ">=",
        }
    }

    fn holds(self, a: i16, b: i16) -> bool {
        match self {
            Self::Eq => a == b,
            Self::Ne => a != b,
            Self::Lt => a < b,
            Self::Le => a <= b,
            Self::Gt => a > b,
            Self::Ge => a >= b,
        }
    }
}

/// A resolved condition.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Condition {
    /// A bit is on; `name` is how the program wrote it.
    Bit {
        /// As written (a signal's name or an address).
        name: String,
        /// Its address.
        address: Address,
        /// Where its value comes from.
        source: Source,
    },
    /// A DT word (signed) compared with a value.
    Word {
        /// The word.
        address: Address,
        /// The comparison.
        compare: Compare,
        /// The value.
        value: i16,
    },
    /// Not.
    Not(Box<Condition>),
    /// All of.
    All(Vec<Condition>),
    /// Any of.
    Any(Vec<Condition>),
    /// A pallet's counter: `pallet.NAME.full`, `pallet.NAME.layer == 3`, `pallet.NAME.index < 12`
    /// (layer and index from 0, as the pattern counts them).
    Pallet {
        /// The pallet.
        pallet: String,
        /// What of it.
        term: PalletTerm,
    },
}

/// What a condition reads of a pallet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PalletTerm {
    /// Every slot is filled.
    Full,
    /// The next slot begins a layer above the first (the cycle's `between_layers` runs).
    BeginsLayer,
    /// The next slot's layer compared with a value.
    Layer(Compare, i64),
    /// The next slot's index compared with a value.
    Index(Compare, i64),
}

/// A pallet's counter as a condition reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PalletView {
    /// The slot to fill next, from 0.
    pub index: usize,
    /// Its layer, from 0.
    pub layer: usize,
    /// Whether it is the first slot of a layer above the first.
    pub begins_layer: bool,
    /// Whether every slot is filled.
    pub full: bool,
}

impl PalletTerm {
    fn holds(self, view: PalletView) -> bool {
        let compare = |c: Compare, a: usize, b: i64| {
            let a = i64::try_from(a).unwrap_or(i64::MAX);
            match c {
                Compare::Eq => a == b,
                Compare::Ne => a != b,
                Compare::Lt => a < b,
                Compare::Le => a <= b,
                Compare::Gt => a > b,
                Compare::Ge => a >= b,
            }
        };
        match self {
            Self::Full => view.full,
            Self::BeginsLayer => view.begins_layer,
            Self::Layer(c, v) => compare(c, view.layer, v),
            Self::Index(c, v) => compare(c, view.index, v),
        }
    }
}

impl Condition {
    /// The pallets it reads, each once.
    #[must_use]
    pub fn pallets(&self) -> Vec<&str> {
        let mut out = Vec::new();
        self.collect_pallets(&mut out);
        out
    }

    fn collect_pallets<'a>(&'a self, out: &mut Vec<&'a str>) {
        match self {
            Self::Pallet { pallet, .. } if !out.contains(&pallet.as_str()) => out.push(pallet),
            Self::Not(c) => c.collect_pallets(out),
            Self::All(cs) | Self::Any(cs) => cs.iter().for_each(|c| c.collect_pallets(out)),
            _ => {}
        }
    }

    /// Whether it holds on the status block's input words, `read` giving every other word or
    /// bit it needs (`None`: unknown, and a term that cannot be known does not hold).
    #[must_use]
    pub fn holds(&self, inputs: &[u16; 4], read: &dyn Fn(Address) -> Option<u16>) -> bool {
        self.holds_with(inputs, read, &|_| None)
    }

    /// [`Self::holds`], `pallet` giving each pallet's counter (`None`: unknown, and its term
    /// does not hold).
    #[must_use]
    pub fn holds_with(
        &self,
        inputs: &[u16; 4],
        read: &dyn Fn(Address) -> Option<u16>,
        pallet: &dyn Fn(&str) -> Option<PalletView>,
    ) -> bool {
        match self {
            Self::Pallet { pallet: name, term } => pallet(name).is_some_and(|v| term.holds(v)),
            Self::Bit { source, .. } => match *source {
                Source::Input { word, bit } => inputs[word] & (1 << bit) != 0,
                Source::Read(a) => read(a).is_some_and(|v| v != 0),
            },
            Self::Word {
                address,
                compare,
                value,
            } => read(*address).is_some_and(|v| compare.holds(v as i16, *value)),
            Self::Not(c) => !c.holds_with(inputs, read, pallet),
            Self::All(cs) => cs.iter().all(|c| c.holds_with(inputs, read, pallet)),
            Self::Any(cs) => cs.iter().any(|c| c.holds_with(inputs, read, pallet)),
        }
    }

    /// The bits and words it reads through the gateway, each once.
    #[must_use]
    pub fn reads(&self) -> Vec<Address> {
        let mut out = Vec::new();
        self.collect_reads(&mut out);
        out
    }

    fn collect_reads(&self, out: &mut Vec<Address>) {
        let mut push = |a: Address| {
            if !out.contains(&a) {
                out.push(a);
            }
        };
        match self {
            Self::Bit {
                source: Source::Read(a),
                ..
            } => push(*a),
            Self::Bit { .. } | Self::Pallet { .. } => {}
            Self::Word { address, .. } => push(*address),
            Self::Not(c) => c.collect_reads(out),
            Self::All(cs) | Self::Any(cs) => cs.iter().for_each(|c| c.collect_reads(out)),
        }
    }
}

impl fmt::Display for Condition {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let join = |f: &mut fmt::Formatter<'_>, cs: &[Condition], op: &str| {
            for (i, c) in cs.iter().enumerate() {
                if i > 0 {
                    write!(f, " {op} ")?;
                }
                if matches!(c, Self::Any(_) | Self::All(_)) {
                    write!(f, "({c})")?;
                } else {
                    write!(f, "{c}")?;
                }
            }
            Ok(())
        };
        match self {
            Self::Bit { name, address, .. } if name.parse::<Address>().is_ok() => {
                write!(f, "{address}")
            }
            Self::Bit { name, address, .. } => write!(f, "{name} ({address})"),
            Self::Word {
                address,
                compare,
                value,
            } => write!(f, "{address} {} {value}", compare.symbol()),
            Self::Pallet { pallet, term } => match term {
                PalletTerm::Full => write!(f, "pallet.{pallet}.full"),
                PalletTerm::BeginsLayer => write!(f, "pallet.{pallet} begins a layer"),
                PalletTerm::Layer(c, v) => write!(f, "pallet.{pallet}.layer {} {v}", c.symbol()),
                PalletTerm::Index(c, v) => write!(f, "pallet.{pallet}.index {} {v}", c.symbol()),
            },
            Self::Not(c) if matches!(**c, Self::Any(_) | Self::All(_)) => write!(f, "!({c})"),
            Self::Not(c) => write!(f, "!{c}"),
            Self::All(cs) => join(f, cs, "&"),
            Self::Any(cs) => join(f, cs, "|"),
        }
    }
}

/// What a condition's names resolve against.
#[derive(Debug, Clone, Copy)]
pub struct Names<'a> {
    /// Signal names and input words.
    pub permit: PermitNames<'a>,
    /// What may be read through the gateway.
    pub access: &'a AccessList,
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Word(String),
    Number(i64),
    Not,
    And,
    Or,
    Open,
    Close,
    Compare(Compare),
}

fn tokens(text: &str) -> Result<Vec<Token>, ConditionFault> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        let two = |t: Token| (t, 2);
        let (token, len) = match (c, next) {
            (c, _) if c.is_whitespace() => {
                i += 1;
                continue;
            }
            ('=', Some('=')) => two(Token::Compare(Compare::Eq)),
            ('!', Some('=')) => two(Token::Compare(Compare::Ne)),
            ('<', Some('=')) => two(Token::Compare(Compare::Le)),
            ('>', Some('=')) => two(Token::Compare(Compare::Ge)),
            ('<', _) => (Token::Compare(Compare::Lt), 1),
            ('>', _) => (Token::Compare(Compare::Gt), 1),
            ('!', _) => (Token::Not, 1),
            ('&', _) => (Token::And, 1),
            ('|', _) => (Token::Or, 1),
            ('(', _) => (Token::Open, 1),
            (')', _) => (Token::Close, 1),
            (c, _) if c == '-' || c.is_ascii_digit() => number(&chars[i..])?,
            (c, _) if c.is_ascii_alphabetic() || c == '_' => word(&chars[i..]),
            (found, _) => return Err(ConditionFault::NotUnderstood { found, at: i + 1 }),
        };
        out.push(token);
        i += len;
    }
    Ok(out)
}

/// The number `chars` begin with (a `-`, then digits), and its length.
fn number(chars: &[char]) -> Result<(Token, usize), ConditionFault> {
    let end = (1..chars.len())
        .find(|&j| !chars[j].is_ascii_digit())
        .unwrap_or(chars.len());
    let digits: String = chars[..end].iter().collect();
    let n = digits
        .parse()
        .map_err(|_| ConditionFault::NotANumber { digits })?;
    Ok((Token::Number(n), end))
}

/// The word `chars` begin with (a name or an address: letters, digits, `_`, `-`, `.`), and
/// its length.
fn word(chars: &[char]) -> (Token, usize) {
    let end = (1..chars.len())
        .find(|&j| !(chars[j].is_ascii_alphanumeric() || matches!(chars[j], '_' | '-' | '.')))
        .unwrap_or(chars.len());
    (Token::Word(chars[..end].iter().collect()), end)
}

struct Parser<'a> {
    tokens: Vec<Token>,
    at: usize,
    names: Names<'a>,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at)
    }

    fn any(&mut self) -> Result<Condition, ConditionFault> {
        let mut parts = vec![self.all()?];
        while self.peek() == Some(&Token::Or) {
            self.at += 1;
            parts.push(self.all()?);
        }
        Ok(if parts.len() == 1 {
            parts.remove(0)
        } else {
            Condition::Any(parts)
        })
    }

    fn all(&mut self) -> Result<Condition, ConditionFault> {
        let mut parts = vec![self.unary()?];
        while self.peek() == Some(&Token::And) {
            self.at += 1;
            parts.push(self.unary()?);
        }
        Ok(if parts.len() == 1 {
            parts.remove(0)
        } else {
            Condition::All(parts)
        })
    }

    fn unary(&mut self) -> Result<Condition, ConditionFault> {
        match self.tokens.get(self.at).cloned() {
            Some(Token::Not) => {
                self.at += 1;
                Ok(Condition::Not(Box::new(self.unary()?)))
            }
            Some(Token::Open) => {
                self.at += 1;
                let inner = self.any()?;
                if self.peek() != Some(&Token::Close) {
                    return Err(ConditionFault::NotClosed);
                }
                self.at += 1;
                Ok(inner)
            }
            Some(Token::Word(name)) => {
                self.at += 1;
                self.term(&name)
            }
            Some(other) => Err(ConditionFault::Unexpected {
                found: format!("{other:?}"),
            }),
            None => Err(ConditionFault::EndsEarly),
        }
    }

    fn term(&mut self, name: &str) -> Result<Condition, ConditionFault> {
        if let Some(rest) = name.strip_prefix("pallet.") {
            return self.pallet_term(name, rest);
        }
        let address = self.address_of(name)?;
        if let Some(Token::Compare(compare)) = self.peek().cloned() {
            self.at += 1;
            return self.word_term(name, address, compare);
        }
        if address.area == Area::Dt {
            return Err(ConditionFault::WordNotCompared {
                name: name.to_owned(),
            });
        }
        let source = if let Some((word, bit)) = self.names.permit.input_bit(address) {
            Source::Input { word, bit }
        } else {
            self.readable(address)?;
            Source::Read(address)
        };
        Ok(Condition::Bit {
            name: name.to_owned(),
            address,
            source,
        })
    }

    /// The address `name` is: a signal's, or an address written out.
    fn address_of(&self, name: &str) -> Result<Address, ConditionFault> {
        if let Some(a) = self.names.permit.signals.get(name) {
            return Ok(*a);
        }
        name.parse::<Address>().map_err(|_| {
            let known: Vec<&str> = self
                .names
                .permit
                .signals
                .keys()
                .map(String::as_str)
                .collect();
            ConditionFault::Unknown {
                name: name.to_owned(),
                known: if known.is_empty() {
                    "none named".to_owned()
                } else {
                    known.join(", ")
                },
            }
        })
    }

    /// A DT word `name` (at `address`) compared by `compare` with the number that follows.
    fn word_term(
        &mut self,
        name: &str,
        address: Address,
        compare: Compare,
    ) -> Result<Condition, ConditionFault> {
        let Some(Token::Number(value)) = self.tokens.get(self.at).cloned() else {
            return Err(ConditionFault::NoNumber {
                name: name.to_owned(),
                compare: compare.symbol(),
            });
        };
        self.at += 1;
        if address.area != Area::Dt {
            return Err(ConditionFault::BitCompared {
                name: name.to_owned(),
            });
        }
        let value = i16::try_from(value).map_err(|_| ConditionFault::OutOfRange { value })?;
        self.readable(address)?;
        Ok(Condition::Word {
            address,
            compare,
            value,
        })
    }

    /// `pallet.NAME.full`, or `pallet.NAME.layer` / `.index` compared with a number.
    fn pallet_term(&mut self, name: &str, rest: &str) -> Result<Condition, ConditionFault> {
        let bad = || ConditionFault::PalletTerm {
            name: name.to_owned(),
        };
        let (pallet, what) = rest.rsplit_once('.').ok_or_else(bad)?;
        if pallet.is_empty() {
            return Err(bad());
        }
        let compared = match self.peek().cloned() {
            Some(Token::Compare(c)) => {
                let Some(Token::Number(v)) = self.tokens.get(self.at + 1).cloned() else {
                    return Err(ConditionFault::NoNumber {
                        name: name.to_owned(),
                        compare: c.symbol(),
                    });
                };
                self.at += 2;
                Some((c, v))
            }
            _ => None,
        };
        let term = match (what, compared) {
            ("full", None) => PalletTerm::Full,
            ("layer", Some((c, v))) => PalletTerm::Layer(c, v),
            ("index", Some((c, v))) => PalletTerm::Index(c, v),
            _ => return Err(bad()),
        };
        Ok(Condition::Pallet {
            pallet: pallet.to_owned(),
            term,
        })
    }

    fn readable(&self, address: Address) -> Result<(), ConditionFault> {
        let range =
            Range::from_count(address, 1).ok_or(ConditionFault::NoSuchAddress { address })?;
        self.names
            .access
            .check_read(&range)
            .map_err(|denied| ConditionFault::NotReadable { address, denied })
    }
}

/// Parses and resolves `text`.
///
/// # Errors
/// The text and what in it is wrong.
pub fn parse(text: &str, names: Names<'_>) -> Result<Condition, ConditionError> {
    let fail = |reason: ConditionFault| ConditionError {
        text: text.to_owned(),
        reason,
    };
    let tokens = tokens(text).map_err(fail)?;
    if tokens.is_empty() {
        return Err(fail(ConditionFault::Empty));
    }
    let mut p = Parser {
        tokens,
        at: 0,
        names,
    };
    let c = p.any().map_err(fail)?;
    if p.at < p.tokens.len() {
        return Err(fail(ConditionFault::LeftOver {
            left: format!("{:?}", p.tokens[p.at]),
        }));
    }
    Ok(c)
}

/// Signal names of a cell, for tests and messages.
pub type Signals = BTreeMap<String, Address>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contract::{InputWord, Layout};

    fn signals() -> Signals {
        [
            ("press_open", "X5"),
            ("press_moving", "X6"),
            ("part", "X12"),
            ("far", "X30"),
        ]
        .into_iter()
        .map(|(n, a)| (n.to_owned(), a.parse().unwrap()))
        .collect()
    }

    fn access() -> AccessList {
        let ranges = |l: &[&str]| l.iter().map(|r| r.parse().unwrap()).collect();
        AccessList::new(
            ranges(&["DT100-DT199", "X30-X3F"]),
            vec![],
            &Layout::default(),
        )
        .unwrap()
    }

    fn parsed(text: &str) -> Result<Condition, ConditionError> {
        let (signals, access) = (signals(), access());
        let names = Names {
            permit: PermitNames {
                signals: &signals,
                inputs: &InputWord::DEFAULTS,
            },
            access: &access,
        };
        parse(text, names)
    }

    #[test]
    fn and_binds_tighter_than_or_and_parentheses_group() {
        let c = parsed("press_open & !press_moving | part").unwrap();
        assert_eq!(
            c.to_string(),
            "(press_open (X5) & !press_moving (X6)) | part (X12)"
        );
        let c = parsed("press_open & (!press_moving | part)").unwrap();
        assert_eq!(
            c.to_string(),
            "press_open (X5) & (!press_moving (X6) | part (X12))"
        );
        let c = parsed("!(X5 | X6)").unwrap();
        assert_eq!(c.to_string(), "!(X5 | X6)");
    }

    #[test]
    fn a_condition_holds_as_its_truth_table_says() {
        let c = parsed("press_open & !press_moving | part").unwrap();
        let none = |_: Address| None;
        for (x0, x1, expected) in [
            (0x20, 0, true),
            (0x60, 0, false),
            (0x60, 1 << 2, true),
            (0, 0, false),
            (0x40, 1 << 2, true),
        ] {
            assert_eq!(c.holds(&[x0, x1, 0, 0], &none), expected, "{x0:#x} {x1:#x}");
        }
    }

    #[test]
    fn words_and_bits_outside_the_input_words_are_read_through_the_gateway() {
        let c = parsed("DT100 >= -5 & far").unwrap();
        let dt100: Address = "DT100".parse().unwrap();
        let x30: Address = "X30".parse().unwrap();
        assert_eq!(c.reads(), vec![dt100, x30]);
        let read = |v: u16, bit: u16| move |a: Address| Some(if a == dt100 { v } else { bit });
        assert!(c.holds(&[0; 4], &read((-5i16) as u16, 1)));
        assert!(!c.holds(&[0; 4], &read((-6i16) as u16, 1)));
        assert!(!c.holds(&[0; 4], &read(7, 0)));
        // Unknown (the read failed): not met.
        assert!(!c.holds(&[0; 4], &|_| None));
        assert_eq!(c.to_string(), "DT100 >= -5 & far (X30)");
    }

    #[test]
    fn a_bad_condition_is_refused_naming_the_text_and_the_fault() {
        for (text, words) in [
            ("", "is empty"),
            ("press_open &", "ends where an input"),
            ("(X5 | X6", "`(` is not closed"),
            ("X5 X6", "left over"),
            (
                "door",
                "\"door\" is neither a signal (far, part, press_moving, press_open)",
            ),
            ("DT100", "compare it"),
            ("X5 == 1", "only a DT word is compared"),
            ("DT100 == 40000", "outside a DT word"),
            (
                "DT300 == 1",
                "DT300 is not in the input words the PLC copies and cannot be read",
            ),
            ("X40", "X40 is not in the input words"),
            ("X5 ; X6", "';' at character 4"),
        ] {
            let e = parsed(text).unwrap_err().to_string();
            assert!(
                e.contains(words) && e.contains(&format!("{text:?}")),
                "{text}: {e}"
            );
        }
    }

    #[test]
    fn a_pallet_is_read_by_its_counter() {
        let c = parsed("pallet.out.full | pallet.out.layer == 3 & pallet.in.index < 12").unwrap();
        assert_eq!(c.pallets(), ["out", "in"]);
        assert_eq!(
            c.to_string(),
            "pallet.out.full | (pallet.out.layer == 3 & pallet.in.index < 12)"
        );
        let view = |index, layer, full| PalletView {
            index,
            layer,
            begins_layer: false,
            full,
        };
        let inputs = [0; 4];
        let holds = |out: PalletView, inp: PalletView| {
            c.holds_with(&inputs, &|_| None, &|p| match p {
                "out" => Some(out),
                "in" => Some(inp),
                _ => None,
            })
        };
        assert!(holds(view(0, 0, true), view(20, 0, false)));
        assert!(holds(view(19, 3, false), view(11, 0, false)));
        assert!(!holds(view(19, 3, false), view(12, 0, false)));
        assert!(!holds(view(5, 2, false), view(0, 0, false)));
        // A pallet not known: its terms do not hold.
        assert!(!c.holds(&inputs, &|_| None));
        for bad in [
            "pallet.out.layer",
            "pallet.out.full == 1",
            "pallet.out",
            "pallet..full",
        ] {
            let e = parsed(bad).unwrap_err().to_string();
            assert!(
                e.contains("pallet.NAME.full") || e.contains("needs a number"),
                "{bad}: {e}"
            );
        }
    }
}
