//! What a Modbus request asks of the register gateway, and what a gateway answer or error is in
//! Modbus (Modbus Application Protocol v1.1b3, §6 functions, §7 exceptions). No IO: a request in,
//! an [`Ask`] or an exception out.
//!
//! ```text
//!  03 read holding registers    register n = DTn                      1..=125 a request
//!  04 read input registers      register n = DTn (read-only view)     1..=125
//!  06 / 16 write register(s)    register n = DTn                      16: 1..=123
//!  01 read coils                coil n = Y n (n < 2048: Y word n / 16, bit n % 16),
//!                               coil 2048 + n = R n (R word n / 16, bit n % 16)   1..=2000
//!  05 / 15 write coil(s)        as 01                                 15: 1..=1968
//!  02 read discrete inputs      input n = X n (X word n / 16, bit n % 16)          1..=2000
//!  a request spanning Y and R, or past an area's end:   02 illegal data address
//!  a quantity outside the bounds above:                 03 illegal data value
//!  any other function:                                  01 illegal function
//! ```
//! The bit numbering is the one [`Address`] uses (and PLC.md §2): coil 0x1A = Y1A (word 1,
//! bit A), coil 2048 + 0x10 = R10 (`R0010`).

use tokio_modbus::{ExceptionCode, Request, Response};

use crate::daemon::{GatewayError, Values};
use crate::gateway::{Address, Area, Range};
use crate::plc::RELAY_COIL_BASE;

/// Registers one read (03, 04) may ask for (§6.3, §6.4).
const MAX_READ_REGISTERS: u16 = 125;
/// Registers one write (16) may carry (§6.12).
pub(super) const MAX_WRITE_REGISTERS: usize = 123;
/// Coils or inputs one read (01, 02) may ask for (§6.1, §6.2).
const MAX_READ_BITS: u16 = 2000;
/// Coils one write (15) may carry (§6.11).
pub(super) const MAX_WRITE_COILS: usize = 1968;

/// A request as the gateway carries it out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Ask {
    /// Read `count` from `start`; answer as `kind`.
    Read {
        /// The first address.
        start: Address,
        /// Words or bits.
        count: u32,
        /// Which read it answers.
        kind: ReadKind,
    },
    /// Write `values` from `start`; answer `echo` once written.
    Write {
        /// The first address.
        start: Address,
        /// What to write.
        values: Values,
        /// The reply to a write done.
        echo: Response,
    },
}

/// Which read function a read answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum ReadKind {
    Holding,
    Input,
    Coils,
    Discrete,
}

/// What `request` asks, or the exception it gets without asking the gateway.
pub(super) fn ask(request: &Request<'_>) -> Result<Ask, ExceptionCode> {
    match request {
        Request::ReadHoldingRegisters(at, n) => read_words(*at, *n, ReadKind::Holding),
        Request::ReadInputRegisters(at, n) => read_words(*at, *n, ReadKind::Input),
        Request::ReadCoils(at, n) => {
            quantity(usize::from(*n), usize::from(MAX_READ_BITS))?;
            let start = coils(*at, usize::from(*n))?;
            Ok(read(start, *n, ReadKind::Coils))
        }
        Request::ReadDiscreteInputs(at, n) => {
            quantity(usize::from(*n), usize::from(MAX_READ_BITS))?;
            let start = within(Area::X, u32::from(*at), usize::from(*n))?;
            Ok(read(start, *n, ReadKind::Discrete))
        }
        Request::WriteSingleRegister(at, word) => Ok(Ask::Write {
            start: within(Area::Dt, u32::from(*at), 1)?,
            values: Values::Words(vec![*word]),
            echo: Response::WriteSingleRegister(*at, *word),
        }),
        Request::WriteMultipleRegisters(at, words) => {
            quantity(words.len(), MAX_WRITE_REGISTERS)?;
            Ok(Ask::Write {
                start: within(Area::Dt, u32::from(*at), words.len())?,
                values: Values::Words(words.to_vec()),
                echo: Response::WriteMultipleRegisters(*at, words.len() as u16),
            })
        }
        Request::WriteSingleCoil(at, on) => Ok(Ask::Write {
            start: coils(*at, 1)?,
            values: Values::Bits(vec![*on]),
            echo: Response::WriteSingleCoil(*at, *on),
        }),
        Request::WriteMultipleCoils(at, bits) => {
            quantity(bits.len(), MAX_WRITE_COILS)?;
            Ok(Ask::Write {
                start: coils(*at, bits.len())?,
                values: Values::Bits(bits.to_vec()),
                echo: Response::WriteMultipleCoils(*at, bits.len() as u16),
            })
        }
        _ => Err(ExceptionCode::IllegalFunction),
    }
}

fn read(start: Address, count: u16, kind: ReadKind) -> Ask {
    Ask::Read {
        start,
        count: u32::from(count),
        kind,
    }
}

fn read_words(at: u16, n: u16, kind: ReadKind) -> Result<Ask, ExceptionCode> {
    quantity(usize::from(n), usize::from(MAX_READ_REGISTERS))?;
    let start = within(Area::Dt, u32::from(at), usize::from(n))?;
    Ok(read(start, n, kind))
}

/// 03 illegal data value unless `n` is within 1..=`most`.
fn quantity(n: usize, most: usize) -> Result<(), ExceptionCode> {
    if (1..=most).contains(&n) {
        Ok(())
    } else {
        Err(ExceptionCode::IllegalDataValue)
    }
}

/// The first of `n` addresses from `index` in `area`; 02 illegal data address past its end.
fn within(area: Area, index: u32, n: usize) -> Result<Address, ExceptionCode> {
    let start = Address { area, index };
    let fits = index <= area.last() && Range::from_count(start, n as u32).is_some();
    fits.then_some(start)
        .ok_or(ExceptionCode::IllegalDataAddress)
}

/// The first of `n` coils from `coil`: Y below 2048, R from 2048, never both in one request.
fn coils(coil: u16, n: usize) -> Result<Address, ExceptionCode> {
    let last = u32::from(coil) + n as u32 - 1;
    let base = u32::from(RELAY_COIL_BASE);
    match (u32::from(coil).checked_sub(base), last < base) {
        (None, true) => within(Area::Y, u32::from(coil), n),
        (Some(relay), _) => within(Area::R, relay, n),
        (None, false) => Err(ExceptionCode::IllegalDataAddress),
    }
}

/// The reply to a read of `kind` that read `values`: words for a DT read, bits for a bit read,
/// as the gateway answers them (anything else is a device failure, 04).
pub(super) fn read_response(kind: ReadKind, values: Values) -> Result<Response, ExceptionCode> {
    Ok(match (kind, values) {
        (ReadKind::Holding, Values::Words(w)) => Response::ReadHoldingRegisters(w),
        (ReadKind::Input, Values::Words(w)) => Response::ReadInputRegisters(w),
        (ReadKind::Coils, Values::Bits(b)) => Response::ReadCoils(b),
        (ReadKind::Discrete, Values::Bits(b)) => Response::ReadDiscreteInputs(b),
        _ => return Err(ExceptionCode::ServerDeviceFailure),
    })
}

/// The exception a gateway error answers with (§7).
pub(super) fn exception(e: &GatewayError) -> ExceptionCode {
    match e {
        // Outside the access list, a write to X or into the contract: not an address it has.
        GatewayError::Denied(_) => ExceptionCode::IllegalDataAddress,
        GatewayError::BadRequest(_) => ExceptionCode::IllegalDataValue,
        // The gateway stands, the device behind it does not answer.
        GatewayError::LinkDown { .. } => ExceptionCode::GatewayTargetDevice,
        GatewayError::Plc(_) | GatewayError::Untrusted { .. } => ExceptionCode::ServerDeviceFailure,
        // The path through the gateway is going away.
        GatewayError::ShuttingDown => ExceptionCode::GatewayPathUnavailable,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gateway::Denied;

    fn at(text: &str) -> Address {
        text.parse().unwrap()
    }

    fn asked(request: &Request<'_>) -> (Address, u32) {
        match ask(request).unwrap() {
            Ask::Read { start, count, .. } => (start, count),
            Ask::Write { start, values, .. } => (start, values.len() as u32),
        }
    }

    #[test]
    fn registers_are_dt_words() {
        assert_eq!(
            asked(&Request::ReadHoldingRegisters(100, 10)),
            (at("DT100"), 10)
        );
        assert_eq!(
            asked(&Request::ReadInputRegisters(0, 125)),
            (at("DT0"), 125)
        );
        assert_eq!(
            asked(&Request::WriteSingleRegister(150, 7)),
            (at("DT150"), 1)
        );
        let write = Request::WriteMultipleRegisters(1_032, vec![1, 2].into());
        assert_eq!(asked(&write), (at("DT1032"), 2));
    }

    #[test]
    fn coils_are_y_below_2048_and_r_from_2048_inputs_are_x() {
        assert_eq!(asked(&Request::ReadCoils(0x1A, 1)), (at("Y1A"), 1));
        assert_eq!(asked(&Request::ReadCoils(2047, 1)), (at("Y127F"), 1));
        assert_eq!(
            asked(&Request::WriteSingleCoil(2048 + 0x10, true)),
            (at("R0010"), 1)
        );
        let write = Request::WriteMultipleCoils(2048 + 0x1E, vec![true, false].into());
        assert_eq!(asked(&write), (at("R1E"), 2));
        assert_eq!(asked(&Request::ReadDiscreteInputs(0x13, 4)), (at("X13"), 4));
    }

    #[test]
    fn bad_quantities_are_illegal_values_bad_addresses_illegal_addresses() {
        let value = Err(ExceptionCode::IllegalDataValue);
        assert_eq!(ask(&Request::ReadHoldingRegisters(0, 0)), value);
        assert_eq!(ask(&Request::ReadHoldingRegisters(0, 126)), value);
        assert_eq!(ask(&Request::ReadCoils(0, 2001)), value);
        assert_eq!(
            ask(&Request::WriteMultipleRegisters(0, vec![0; 124].into())),
            value
        );
        let address = Err(ExceptionCode::IllegalDataAddress);
        assert_eq!(ask(&Request::ReadHoldingRegisters(32_764, 2)), address);
        assert_eq!(ask(&Request::WriteSingleRegister(32_765, 0)), address);
        assert_eq!(
            ask(&Request::ReadCoils(2040, 16)),
            address,
            "Y and R in one"
        );
        assert_eq!(
            ask(&Request::ReadCoils(2048 + 16_000, 1)),
            address,
            "past R999F"
        );
        assert_eq!(
            ask(&Request::ReadDiscreteInputs(16_000, 1)),
            address,
            "past X999F"
        );
        assert_eq!(
            ask(&Request::MaskWriteRegister(0, 0, 0)),
            Err(ExceptionCode::IllegalFunction)
        );
        assert_eq!(
            ask(&Request::ReportServerId),
            Err(ExceptionCode::IllegalFunction)
        );
    }

    #[test]
    fn gateway_errors_are_the_exceptions_a_gateway_answers() {
        let denied = GatewayError::Denied(Denied::ReadOnly {
            range: "X0".parse().unwrap(),
        });
        let cases = [
            (denied, 0x02),
            (GatewayError::BadRequest("x".into()), 0x03),
            (GatewayError::Plc("x".into()), 0x04),
            (GatewayError::ShuttingDown, 0x0A),
            (GatewayError::LinkDown { detail: None }, 0x0B),
        ];
        for (e, code) in cases {
            assert_eq!(u8::from(exception(&e)), code, "{e}");
        }
        assert_eq!(
            read_response(ReadKind::Coils, Values::Bits(vec![true])),
            Ok(Response::ReadCoils(vec![true]))
        );
        assert_eq!(
            read_response(ReadKind::Holding, Values::Bits(vec![true])),
            Err(ExceptionCode::ServerDeviceFailure)
        );
    }
}
