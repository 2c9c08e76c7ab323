//! The register gateway as the daemon runs it: a request for the PLC's other registers, checked
//! against the robot's access list by the handle, carried out by the robot's worker over the link
//! it owns, one exchange at a time between its own: a motion exchange never waits behind more
//! than one gateway exchange.

use thiserror::Error;
use tokio::sync::oneshot;

use crate::gateway::{Address, Area, Denied, Range};
use crate::plc::ExchangeSizes;

/// Words or bits at most one gateway request may read or write.
pub const MAX_WORDS: u32 = 1_000;
/// Bits at most one gateway request may read or write.
pub const MAX_BITS: u32 = 2_000;

pub use crate::gateway::Values;

/// Why a gateway request failed.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum GatewayError {
    /// Outside the robot's access list (or a write to X).
    #[error(transparent)]
    Denied(#[from] Denied),
    /// A request that cannot be: a count out of bounds, values of the wrong kind.
    #[error("{0}")]
    BadRequest(String),
    /// The PLC link is down.
    #[error("the PLC link is down{}", detail.as_ref().map(|d| format!(": {d}")).unwrap_or_default())]
    LinkDown {
        /// The last link error.
        detail: Option<String>,
    },
    /// The PLC refused or failed the exchange.
    #[error("{0}")]
    Plc(String),
    /// The daemon is shutting down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// Asked for before the PLC restarted, stalled or was lost (a cycle's output): not written.
    #[error("not written: {why} since it was asked for")]
    Untrusted {
        /// What happened.
        why: String,
    },
}

/// The range `count` addresses from `start` cover, checked against the gateway's bounds.
pub(super) fn range(start: Address, count: u32) -> Result<Range, GatewayError> {
    let max = if start.area.is_bits() {
        MAX_BITS
    } else {
        MAX_WORDS
    };
    if !(1..=max).contains(&count) {
        return Err(GatewayError::BadRequest(format!(
            "count = {count}: must be within 1..={max} for {}",
            start.area.name()
        )));
    }
    Range::from_count(start, count).ok_or_else(|| {
        GatewayError::BadRequest(format!(
            "{count} addresses from {start} run past the end of {}",
            start.area.name()
        ))
    })
}

/// Checks that `values` suit `area` (words for DT, bits for X, Y and R).
pub(super) fn check_values(area: Area, values: &Values) -> Result<(), GatewayError> {
    match (area.is_bits(), values) {
        (false, Values::Words(_)) | (true, Values::Bits(_)) => Ok(()),
        (false, Values::Bits(_)) => Err(GatewayError::BadRequest(
            "DT holds 16-bit words: give numbers 0..=65535".to_owned(),
        )),
        (true, Values::Words(_)) => Err(GatewayError::BadRequest(format!(
            "{} holds bits: give true/false or 1/0",
            area.name()
        ))),
    }
}

/// Values from JSON as given for `area`: DT words as numbers -32768..=65535 (a negative number is
/// written as its 16-bit two's complement), X, Y and R bits as `true`/`false` or `1`/`0`.
pub fn values_from_json(area: Area, given: &[serde_json::Value]) -> Result<Values, GatewayError> {
    let bad = |i: usize, v: &serde_json::Value, what: &str| {
        GatewayError::BadRequest(format!("values[{i}] = {v}: {what}"))
    };
    if area.is_bits() {
        let bits = given
            .iter()
            .enumerate()
            .map(|(i, v)| match v {
                serde_json::Value::Bool(b) => Ok(*b),
                v if v.as_u64() == Some(0) => Ok(false),
                v if v.as_u64() == Some(1) => Ok(true),
                v => Err(bad(
                    i,
                    v,
                    &format!("{} holds bits: give true/false or 1/0", area.name()),
                )),
            })
            .collect::<Result<_, _>>()?;
        return Ok(Values::Bits(bits));
    }
    let words = given
        .iter()
        .enumerate()
        .map(|(i, v)| {
            v.as_i64()
                .filter(|n| (-32_768..=65_535).contains(n))
                .map(|n| n as u16)
                .ok_or_else(|| bad(i, v, "a DT word is a whole number within -32768..=65535"))
        })
        .collect::<Result<_, _>>()?;
    Ok(Values::Words(words))
}

/// One request as the worker carries it out, piece by piece.
#[derive(Debug)]
pub(super) struct Job {
    /// The addresses.
    pub range: Range,
    /// What to write (a write), or nothing (a read).
    pub write: Option<Values>,
    /// What was read so far.
    pub read: Values,
    /// Addresses done so far.
    pub done: u32,
    /// The answer.
    pub reply: oneshot::Sender<Result<Values, GatewayError>>,
    /// The PLC's incident count it was asked under (a cycle's outputs): refused once another
    /// incident came ([`GatewayError::Untrusted`]); `None`: whenever.
    pub epoch: Option<u64>,
}

/// One exchange of a job: the next piece.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Piece {
    ReadWords { start: u16, count: u16 },
    WriteWords { start: u16, words: Vec<u16> },
    ReadBits { area: Area, start: u32, count: u16 },
    WriteBit { area: Area, bit: u32, on: bool },
}

impl Job {
    /// A job for `range`, reading or writing `write`.
    pub(super) fn new(
        range: Range,
        write: Option<Values>,
        reply: oneshot::Sender<Result<Values, GatewayError>>,
    ) -> Self {
        let read = if range.area.is_bits() {
            Values::Bits(Vec::new())
        } else {
            Values::Words(Vec::new())
        };
        Self {
            range,
            write,
            read,
            done: 0,
            reply,
            epoch: None,
        }
    }

    /// The next exchange, sized to what one exchange carries; `None` once all is done.
    pub(super) fn next_piece(&self, sizes: ExchangeSizes) -> Option<Piece> {
        let left = self.range.count() - self.done;
        if left == 0 {
            return None;
        }
        let at = self.range.first + self.done;
        let take = |most: u16| left.min(u32::from(most.max(1))) as u16;
        Some(match (&self.write, self.range.area) {
            (None, Area::Dt) => Piece::ReadWords {
                start: at as u16,
                count: take(sizes.read_words),
            },
            (Some(Values::Words(words)), _) => {
                let n = usize::from(take(sizes.write_words));
                let from = self.done as usize;
                Piece::WriteWords {
                    start: at as u16,
                    words: words[from..from + n].to_vec(),
                }
            }
            (None, area) => Piece::ReadBits {
                area,
                start: at,
                count: take(sizes.read_bits),
            },
            (Some(Values::Bits(bits)), area) => Piece::WriteBit {
                area,
                bit: at,
                on: bits[self.done as usize],
            },
        })
    }

    /// Notes a piece done (with what it read).
    pub(super) fn piece_done(&mut self, piece: &Piece, read: Option<Values>) {
        self.done += match piece {
            Piece::ReadWords { count, .. } | Piece::ReadBits { count, .. } => u32::from(*count),
            Piece::WriteWords { words, .. } => words.len() as u32,
            Piece::WriteBit { .. } => 1,
        };
        match (&mut self.read, read) {
            (Values::Words(all), Some(Values::Words(w))) => all.extend(w),
            (Values::Bits(all), Some(Values::Bits(b))) => all.extend(b),
            _ => {}
        }
    }

    /// Answers the request: what was read, or what was written.
    pub(super) fn finish(self) {
        let _ = self.reply.send(Ok(self.write.unwrap_or(self.read)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sizes() -> ExchangeSizes {
        ExchangeSizes {
            read_words: 27,
            write_words: 24,
            read_bits: 432,
        }
    }

    #[test]
    fn a_request_is_cut_into_single_exchanges() {
        let start: Address = "DT100".parse().unwrap();
        let (tx, _rx) = oneshot::channel();
        let mut job = Job::new(range(start, 60).unwrap(), None, tx);
        let mut pieces = Vec::new();
        while let Some(p) = job.next_piece(sizes()) {
            let Piece::ReadWords { count, .. } = p else {
                panic!("{p:?}")
            };
            job.piece_done(&p, Some(Values::Words(vec![7; usize::from(count)])));
            pieces.push(p);
        }
        assert_eq!(
            pieces,
            [
                Piece::ReadWords {
                    start: 100,
                    count: 27
                },
                Piece::ReadWords {
                    start: 127,
                    count: 27
                },
                Piece::ReadWords {
                    start: 154,
                    count: 6
                }
            ]
        );
        assert_eq!(job.read, Values::Words(vec![7; 60]));
    }

    #[test]
    fn bits_are_written_one_exchange_each() {
        let start: Address = "R10".parse().unwrap();
        let (tx, _rx) = oneshot::channel();
        let mut job = Job::new(
            range(start, 2).unwrap(),
            Some(Values::Bits(vec![true, false])),
            tx,
        );
        let first = job.next_piece(sizes()).unwrap();
        assert_eq!(
            first,
            Piece::WriteBit {
                area: Area::R,
                bit: 16,
                on: true
            }
        );
        job.piece_done(&first, None);
        assert_eq!(
            job.next_piece(sizes()),
            Some(Piece::WriteBit {
                area: Area::R,
                bit: 17,
                on: false
            })
        );
    }

    #[test]
    fn counts_and_kinds_are_checked() {
        let dt: Address = "DT0".parse().unwrap();
        assert!(range(dt, 0).is_err());
        assert!(
            range(dt, 1_001)
                .unwrap_err()
                .to_string()
                .contains("1..=1000 for DT")
        );
        assert!(range("DT32760".parse().unwrap(), 10).is_err());
        assert!(check_values(Area::Y, &Values::Words(vec![1])).is_err());
        assert!(check_values(Area::Dt, &Values::Words(vec![1])).is_ok());
    }

    #[test]
    fn json_values_are_checked_for_their_area() {
        let json = |t: &str| serde_json::from_str::<Vec<serde_json::Value>>(t).unwrap();
        assert_eq!(
            values_from_json(Area::Dt, &json("[0, 65535, -1]")).unwrap(),
            Values::Words(vec![0, 65535, 65535])
        );
        let e = values_from_json(Area::Dt, &json("[1, 70000]")).unwrap_err();
        assert!(e.to_string().contains("values[1] = 70000"), "{e}");
        assert!(values_from_json(Area::Dt, &json("[1.5]")).is_err());
        assert!(values_from_json(Area::Dt, &json("[true]")).is_err());
        assert_eq!(
            values_from_json(Area::R, &json("[true, 0, 1]")).unwrap(),
            Values::Bits(vec![true, false, true])
        );
        let e = values_from_json(Area::Y, &json("[2]")).unwrap_err();
        assert!(e.to_string().contains("Y holds bits"), "{e}");
    }
}
