//! PURE. The register gateway's rules: the PLC addresses the cell may reach through linterpd
//! (DT words; X, Y and R bits), as Panasonic writes them, and each robot's access list: what may
//! be read, what may be written, and never a word of the register contract written.
//!
//! ```text
//!  DT100          data register 100
//!  X1F  R0010     a bit: the word in decimal, then the bit in hex (X1F = word 1, bit 15;
//!                 R0010 = R10 = word 1, bit 0); its index is word * 16 + bit
//!  DT0-DT999      a range, both ends included, in one area
//! ```
//! X (inputs) are read-only. The contract's status block, command block and table areas may be
//! read through the gateway but never written, whatever the access list says: a config that tries
//! is refused, naming the overlap.

mod clients;

pub use clients::{ClientNet, ClientNetError};

use std::fmt;
use std::net::{IpAddr, SocketAddr};
use std::str::FromStr;

use thiserror::Error;

use crate::contract::{BANKS, CHANNELS, COMMAND_WORDS, DT_LAST, Layout, STATUS_WORDS};

/// Highest bit word of X, Y and R on an FP-X (word 0..=109 for X and Y; R0..=R255F in the mock,
/// the FP-X has R0..=R999F); the gateway accepts words 0..=999 and lets the PLC refuse the rest.
pub const BIT_WORD_MAX: u32 = 999;

/// An area of PLC memory.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Area {
    /// Data registers (16-bit words).
    Dt,
    /// External inputs (bits, read-only).
    X,
    /// External outputs (bits).
    Y,
    /// Internal relays (bits).
    R,
}

impl Area {
    /// Its letters.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Dt => "DT",
            Self::X => "X",
            Self::Y => "Y",
            Self::R => "R",
        }
    }

    /// Whether it holds bits (rather than words).
    #[must_use]
    pub fn is_bits(self) -> bool {
        self != Self::Dt
    }

    /// The highest index in the area.
    #[must_use]
    pub fn last(self) -> u32 {
        match self {
            Self::Dt => u32::from(DT_LAST),
            _ => BIT_WORD_MAX * 16 + 15,
        }
    }
}

/// One address: an area and an index (a DT number, or word * 16 + bit).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Address {
    /// The area.
    pub area: Area,
    /// The index in it.
    pub index: u32,
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.area.is_bits() {
            let (word, bit) = (self.index / 16, self.index % 16);
            if word == 0 {
                write!(f, "{}{bit:X}", self.area.name())
            } else {
                write!(f, "{}{word}{bit:X}", self.area.name())
            }
        } else {
            write!(f, "DT{}", self.index)
        }
    }
}

/// An address or range that does not parse, or does not exist.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{text:?} {reason}")]
pub struct AddressError {
    /// The text given.
    pub text: String,
    /// What is wrong with it.
    pub reason: String,
}

fn bad(text: &str, reason: impl Into<String>) -> AddressError {
    AddressError {
        text: text.to_owned(),
        reason: reason.into(),
    }
}

/// A bit address's index from its `digits`: the word in decimal, then its bit in hex (X1F:
/// word 1, bit 15).
fn bit_index(text: &str, digits: &str) -> Result<u32, AddressError> {
    let (word, bit) = digits.split_at(digits.len() - 1);
    if !word.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad(
            text,
            "has a bit word in decimal, then its bit in hex (X1F)",
        ));
    }
    let word: u32 = if word.is_empty() {
        0
    } else {
        word.parse()
            .map_err(|_| bad(text, "has a word number too large"))?
    };
    let bit = u32::from_str_radix(bit, 16).map_err(|_| bad(text, "has a bad bit"))?;
    if word > BIT_WORD_MAX {
        return Err(bad(text, format!("is past word {BIT_WORD_MAX}")));
    }
    Ok(word * 16 + bit)
}

/// A DT word's number from its `digits`, in decimal.
fn dt_index(text: &str, digits: &str) -> Result<u32, AddressError> {
    if !digits.bytes().all(|b| b.is_ascii_digit()) {
        return Err(bad(text, "has a DT number in decimal"));
    }
    let n: u32 = digits
        .parse()
        .map_err(|_| bad(text, "has a DT number too large"))?;
    if n > u32::from(DT_LAST) {
        return Err(bad(text, format!("is past DT{DT_LAST}")));
    }
    Ok(n)
}

impl FromStr for Address {
    type Err = AddressError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let upper = text.trim().to_ascii_uppercase();
        let (area, digits) = if let Some(rest) = upper.strip_prefix("DT") {
            (Area::Dt, rest)
        } else if let Some(rest) = upper.strip_prefix('X') {
            (Area::X, rest)
        } else if let Some(rest) = upper.strip_prefix('Y') {
            (Area::Y, rest)
        } else if let Some(rest) = upper.strip_prefix('R') {
            (Area::R, rest)
        } else {
            return Err(bad(text, "is not an address: DT100, X1F, Y7 or R0010"));
        };
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(bad(text, "needs a number after its area"));
        }
        let index = if area.is_bits() {
            bit_index(text, digits)?
        } else {
            dt_index(text, digits)?
        };
        Ok(Self { area, index })
    }
}

/// Inclusive ranges of addresses in one area.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Range {
    /// The area.
    pub area: Area,
    /// The first index.
    pub first: u32,
    /// The last index (included).
    pub last: u32,
}

impl Range {
    /// `count` addresses from `start`, if they stay inside the area.
    #[must_use]
    pub fn from_count(start: Address, count: u32) -> Option<Self> {
        let last = start.index.checked_add(count.checked_sub(1)?)?;
        (last <= start.area.last()).then_some(Self {
            area: start.area,
            first: start.index,
            last,
        })
    }

    /// How many addresses.
    #[must_use]
    pub fn count(&self) -> u32 {
        self.last - self.first + 1
    }

    /// Whether `other` lies inside this range.
    #[must_use]
    pub fn contains(&self, other: &Self) -> bool {
        self.area == other.area && self.first <= other.first && other.last <= self.last
    }

    /// Whether the two share an address.
    #[must_use]
    pub fn overlaps(&self, other: &Self) -> bool {
        self.area == other.area && self.first <= other.last && other.first <= self.last
    }

    fn at(&self, index: u32) -> Address {
        Address {
            area: self.area,
            index,
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.first == self.last {
            write!(f, "{}", self.at(self.first))
        } else {
            write!(f, "{}-{}", self.at(self.first), self.at(self.last))
        }
    }
}

impl FromStr for Range {
    type Err = AddressError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let (a, b) = text.split_once('-').unwrap_or((text, text));
        let (first, last): (Address, Address) = (a.parse()?, b.parse()?);
        if first.area != last.area {
            return Err(bad(text, "spans two areas"));
        }
        if first.index > last.index {
            return Err(bad(text, "ends before it begins"));
        }
        Ok(Self {
            area: first.area,
            first: first.index,
            last: last.index,
        })
    }
}

/// The contract's words: readable through the gateway, never writable.
#[must_use]
pub fn contract_regions(layout: &Layout) -> Vec<(String, Range)> {
    let dt = |first: u32, words: u32| Range {
        area: Area::Dt,
        first,
        last: first + words - 1,
    };
    let mut out = vec![
        (
            "the contract's status block".to_owned(),
            dt(u32::from(layout.status_base), STATUS_WORDS as u32),
        ),
        (
            "the contract's command block".to_owned(),
            dt(u32::from(layout.command_base), COMMAND_WORDS as u32),
        ),
    ];
    for bank in 0..BANKS {
        for channel in 0..CHANNELS {
            out.push((
                format!("the contract's bank {bank} channel {channel} table area"),
                dt(
                    u32::from(layout.area(bank, channel)),
                    u32::from(layout.area_words),
                ),
            ));
        }
    }
    out
}

/// Why an access list cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum AccessListError {
    /// X is read-only.
    #[error("{range} is in X, the inputs: they cannot be written")]
    InputsWritable {
        /// The range.
        range: Range,
    },
    /// A writable range overlaps the contract.
    #[error(
        "{range} overlaps {region} ({region_range}): the contract is never writable through the gateway"
    )]
    Contract {
        /// The range.
        range: Range,
        /// Which region.
        region: String,
        /// Its words.
        region_range: Range,
    },
}

/// A robot's gateway: its access list, and the Modbus TCP face when there is one.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct GatewaySettings {
    /// What may be read and written.
    pub access: AccessList,
    /// The Modbus TCP server face (off unless configured).
    pub modbus: Option<ModbusFace>,
}

/// The gateway's Modbus TCP server: where it listens, and who may connect.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModbusFace {
    /// IP and port.
    pub listen: SocketAddr,
    /// The clients it serves (IPs or CIDR networks): required, and checked, when `listen` is not
    /// loopback. Without one, loopback clients only.
    pub allow: Vec<ClientNet>,
}

impl ModbusFace {
    /// Whether a client at `peer` may connect: without an allow-list, a loopback client; with
    /// one, a client it lists, and no other (loopback clients too only when listed, e.g.
    /// `127.0.0.1`).
    #[must_use]
    pub fn admits(&self, peer: IpAddr) -> bool {
        if self.allow.is_empty() {
            return peer.to_canonical().is_loopback();
        }
        self.allow.iter().any(|net| net.contains(peer))
    }
}

/// Why a request is refused.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum Denied {
    /// Outside the access list.
    #[error("{range} is not in this robot's gateway {verb} list ({list})")]
    NotListed {
        /// What was asked for.
        range: Range,
        /// `read` or `write`.
        verb: &'static str,
        /// The list, as configured.
        list: String,
    },
    /// X is read-only.
    #[error("{range} is in X, the inputs: they cannot be written")]
    ReadOnly {
        /// What was asked for.
        range: Range,
    },
}

/// A robot's gateway access list.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AccessList {
    read: Vec<Range>,
    write: Vec<Range>,
}

impl AccessList {
    /// The lists, checked: nothing writable in X or in the contract's words (`layout`). Every
    /// writable range is readable too.
    pub fn new(
        read: Vec<Range>,
        write: Vec<Range>,
        layout: &Layout,
    ) -> Result<Self, AccessListError> {
        let regions = contract_regions(layout);
        for range in &write {
            if range.area == Area::X {
                return Err(AccessListError::InputsWritable { range: *range });
            }
            if let Some((region, region_range)) = regions.iter().find(|(_, r)| r.overlaps(range)) {
                return Err(AccessListError::Contract {
                    range: *range,
                    region: region.clone(),
                    region_range: *region_range,
                });
            }
        }
        Ok(Self { read, write })
    }

    /// Whether the list allows nothing at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.read.is_empty() && self.write.is_empty()
    }

    /// May `range` be read?
    pub fn check_read(&self, range: &Range) -> Result<(), Denied> {
        let inside = |list: &[Range]| list.iter().any(|r| r.contains(range));
        if inside(&self.read) || inside(&self.write) {
            return Ok(());
        }
        Err(Denied::NotListed {
            range: *range,
            verb: "read",
            list: list_text(&self.read),
        })
    }

    /// May `range` be written?
    pub fn check_write(&self, range: &Range) -> Result<(), Denied> {
        if range.area == Area::X {
            return Err(Denied::ReadOnly { range: *range });
        }
        if self.write.iter().any(|r| r.contains(range)) {
            return Ok(());
        }
        Err(Denied::NotListed {
            range: *range,
            verb: "write",
            list: list_text(&self.write),
        })
    }
}

fn list_text(list: &[Range]) -> String {
    if list.is_empty() {
        return "empty".to_owned();
    }
    let parts: Vec<String> = list.iter().map(ToString::to_string).collect();
    parts.join(", ")
}

/// What a gateway request reads or writes (read back, an empty list is words).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum Values {
    /// DT words.
    Words(Vec<u16>),
    /// X, Y or R bits.
    Bits(Vec<bool>),
}

impl Values {
    /// How many words or bits.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Self::Words(w) => w.len(),
            Self::Bits(b) => b.len(),
        }
    }

    /// Whether there are none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(text: &str) -> Address {
        text.parse().unwrap()
    }

    fn range(text: &str) -> Range {
        text.parse().unwrap()
    }

    #[test]
    fn addresses_parse_as_panasonic_writes_them() {
        assert_eq!(
            addr("DT100"),
            Address {
                area: Area::Dt,
                index: 100
            }
        );
        assert_eq!(addr("X1F").index, 31);
        assert_eq!(
            addr("r0010"),
            Address {
                area: Area::R,
                index: 16
            }
        );
        assert_eq!(addr("Y7").index, 7);
        assert_eq!(addr("R0010").to_string(), "R10");
        assert_eq!(addr("X1F").to_string(), "X1F");
        assert_eq!(addr("X0").to_string(), "X0");
        for (text, reason) in [
            ("Z1", "is not an address"),
            ("DT", "needs a number"),
            ("DT32765", "past DT32764"),
            ("DT1A", "in decimal"),
            ("XA1", "in decimal, then its bit in hex"),
            ("R1000F", "past word 999"),
        ] {
            let e = text.parse::<Address>().unwrap_err().to_string();
            assert!(e.contains(reason), "{text}: {e}");
        }
    }

    #[test]
    fn ranges_keep_to_one_area_and_order() {
        assert_eq!(range("X0-X1F").count(), 32);
        assert_eq!(range("DT5").count(), 1);
        assert!(
            "DT5-X1"
                .parse::<Range>()
                .unwrap_err()
                .to_string()
                .contains("two areas")
        );
        assert!(
            "DT9-DT1"
                .parse::<Range>()
                .unwrap_err()
                .to_string()
                .contains("ends before")
        );
        assert_eq!(range("R10-R1F").to_string(), "R10-R1F");
    }

    #[test]
    fn the_contract_is_never_writable_whatever_the_list_says() {
        let layout = Layout::default();
        let e = AccessList::new(vec![], vec![range("DT900-DT1005")], &layout).unwrap_err();
        assert_eq!(
            e.to_string(),
            "DT900-DT1005 overlaps the contract's status block (DT1000-DT1025): the contract is never writable through the gateway"
        );
        let e = AccessList::new(vec![], vec![range("DT9990-DT10000")], &layout).unwrap_err();
        assert!(e.to_string().contains("channel 3 table area"), "{e}");
        let e = AccessList::new(vec![], vec![range("X0-X7")], &layout).unwrap_err();
        assert!(e.to_string().contains("cannot be written"), "{e}");
        // Reading the contract is fine.
        assert!(AccessList::new(vec![range("DT1000-DT1021")], vec![], &layout).is_ok());
    }

    #[test]
    fn requests_are_checked_against_the_lists() {
        let list = AccessList::new(
            vec![range("DT0-DT999"), range("X0-X1F")],
            vec![range("DT100-DT199"), range("R10-R1F")],
            &Layout::default(),
        )
        .unwrap();
        assert!(list.check_read(&range("DT0-DT9")).is_ok());
        assert!(
            list.check_read(&range("R12")).is_ok(),
            "writable is readable"
        );
        assert!(list.check_write(&range("DT150-DT160")).is_ok());
        let e = list
            .check_write(&range("DT190-DT200"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "DT190-DT200 is not in this robot's gateway write list (DT100-DT199, R10-R1F)"
        );
        let e = list.check_read(&range("DT1000")).unwrap_err().to_string();
        assert!(e.contains("read list (DT0-DT999, X0-X1F)"), "{e}");
        assert!(matches!(
            list.check_write(&range("X3")),
            Err(Denied::ReadOnly { .. })
        ));
        assert_eq!(
            Range::from_count(addr("DT32760"), 10),
            None,
            "past the end of DT"
        );
    }
}
