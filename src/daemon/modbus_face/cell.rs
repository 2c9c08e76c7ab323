//! Requests for the cell face's block on the Modbus face: registers from `registers` (above
//! every DT word, so the block hides none). No IO: a request in, a [`FaceAsk`] or an exception
//! out, or `None` when the request is not for the block.
//!
//! ```text
//!  03 / 04 read      any words of the block (+0..+17)        1..=125, within the block
//!  06 / 16 write     the command words only (+0..+3)         else 02 illegal data address
//! ```

use tokio_modbus::{ExceptionCode, Request, Response};

use super::map::{MAX_WRITE_REGISTERS, ReadKind};
use crate::cell::face::{BLOCK_WORDS, COMMAND_WORDS};

/// A request for the block.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum FaceAsk {
    /// Read `count` words from `offset`, answered as `kind`.
    Read {
        offset: usize,
        count: usize,
        kind: ReadKind,
    },
    /// Write `values` from command word `offset`; answer `echo`.
    Write {
        offset: usize,
        values: Vec<u16>,
        echo: Response,
    },
}

/// What `request` asks of the block at `base`; `None` when it is not a register request from
/// `base` on.
pub(super) fn ask(request: &Request<'_>, base: u16) -> Option<Result<FaceAsk, ExceptionCode>> {
    let (at, kind, count, values) = match request {
        Request::ReadHoldingRegisters(at, n) => (*at, Some(ReadKind::Holding), *n, None),
        Request::ReadInputRegisters(at, n) => (*at, Some(ReadKind::Input), *n, None),
        Request::WriteSingleRegister(at, w) => (*at, None, 1, Some(vec![*w])),
        Request::WriteMultipleRegisters(at, w) => (
            *at,
            None,
            u16::try_from(w.len()).unwrap_or(u16::MAX),
            Some(w.to_vec()),
        ),
        _ => return None,
    };
    let offset = usize::from(at.checked_sub(base)?);
    let count = usize::from(count);
    Some(match (kind, values) {
        (Some(kind), _) => read_ask(offset, count, kind),
        (None, Some(values)) => write_ask(request, (at, offset), values),
        (None, None) => return None,
    })
}

/// A read of `count` words of `kind` from word `offset` of the block: within the block, and
/// within what one Modbus read carries.
fn read_ask(offset: usize, count: usize, kind: ReadKind) -> Result<FaceAsk, ExceptionCode> {
    if !(1..=125).contains(&count) {
        Err(ExceptionCode::IllegalDataValue)
    } else if offset + count > BLOCK_WORDS {
        Err(ExceptionCode::IllegalDataAddress)
    } else {
        Ok(FaceAsk::Read {
            offset,
            count,
            kind,
        })
    }
}

/// `request`, a write of `values` from register `at` (word `offset` of the block): within the
/// command words, and within what one Modbus write carries; its echo.
fn write_ask(
    request: &Request<'_>,
    (at, offset): (u16, usize),
    values: Vec<u16>,
) -> Result<FaceAsk, ExceptionCode> {
    if !(1..=MAX_WRITE_REGISTERS).contains(&values.len()) {
        Err(ExceptionCode::IllegalDataValue)
    } else if offset + values.len() > COMMAND_WORDS {
        Err(ExceptionCode::IllegalDataAddress)
    } else {
        let echo = match request {
            Request::WriteSingleRegister(a, w) => Response::WriteSingleRegister(*a, *w),
            _ => Response::WriteMultipleRegisters(at, values.len() as u16),
        };
        Ok(FaceAsk::Write {
            offset,
            values,
            echo,
        })
    }
}

/// The reply to a read of `kind`.
pub(super) fn read_response(kind: ReadKind, words: Vec<u16>) -> Response {
    match kind {
        ReadKind::Input => Response::ReadInputRegisters(words),
        _ => Response::ReadHoldingRegisters(words),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: u16 = 50_000;

    #[test]
    fn registers_below_the_block_and_bit_requests_are_not_the_faces() {
        assert_eq!(ask(&Request::ReadHoldingRegisters(100, 2), BASE), None);
        assert_eq!(ask(&Request::WriteSingleRegister(BASE - 1, 2), BASE), None);
        assert_eq!(ask(&Request::ReadCoils(BASE, 2), BASE), None);
    }

    #[test]
    fn the_whole_block_reads_and_only_the_command_words_write() {
        assert_eq!(
            ask(&Request::ReadInputRegisters(BASE, 18), BASE),
            Some(Ok(FaceAsk::Read {
                offset: 0,
                count: 18,
                kind: ReadKind::Input
            }))
        );
        assert_eq!(
            ask(&Request::ReadHoldingRegisters(BASE + 8, 15), BASE),
            Some(Ok(FaceAsk::Read {
                offset: 8,
                count: 15,
                kind: ReadKind::Holding
            }))
        );
        let write = Request::WriteMultipleRegisters(BASE, vec![3, 0xFFFC, 1, 0].into());
        assert!(matches!(
            ask(&write, BASE),
            Some(Ok(FaceAsk::Write { offset: 0, .. }))
        ));
        let address = Some(Err(ExceptionCode::IllegalDataAddress));
        assert_eq!(
            // The block is 23 words, the pallet's +18..+22 with them (zero when none is shown).
            ask(&Request::ReadHoldingRegisters(BASE + 8, 16), BASE),
            address
        );
        assert_eq!(
            ask(&Request::WriteSingleRegister(BASE + 4, 1), BASE),
            address
        );
        assert_eq!(
            ask(&Request::WriteSingleRegister(BASE + 9, 1), BASE),
            address
        );
        let spans = Request::WriteMultipleRegisters(BASE + 2, vec![1, 2, 3].into());
        assert_eq!(ask(&spans, BASE), address);
        assert_eq!(
            ask(&Request::ReadHoldingRegisters(BASE, 0), BASE),
            Some(Err(ExceptionCode::IllegalDataValue))
        );
    }
}
