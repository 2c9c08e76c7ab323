//! A [`crate::plc::Plc`] on a shared [`MockPlc`] without any protocol, on a virtual clock: every
//! operation first moves the clock on by the exchange time (default one scan) and advances the
//! mock to it, as a real link would take that long.

use std::future::{Future, ready};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use super::{Clock, MemoryError, MockPlc, VirtualClock};
use crate::gateway::Area;
use crate::plc::{ExchangeSizes, Plc, PlcError, PlcMode, Refusal};

/// An in-process handle on a mock PLC.
#[derive(Debug)]
pub struct InProcess {
    mock: Arc<Mutex<MockPlc>>,
    clock: VirtualClock,
    exchange_s: f64,
}

impl InProcess {
    /// A handle on `mock` whose exchanges take one scan.
    #[must_use]
    pub fn new(mock: Arc<Mutex<MockPlc>>) -> Self {
        let (now_s, scan_s) = {
            let m = mock.lock().unwrap_or_else(PoisonError::into_inner);
            (m.now_s(), m.config().scan_s)
        };
        let mut clock = VirtualClock::new();
        clock.advance(now_s);
        Self {
            mock,
            clock,
            exchange_s: scan_s,
        }
    }

    /// Sets how long every exchange takes, s.
    #[must_use]
    pub fn with_exchange_s(mut self, exchange_s: f64) -> Self {
        self.exchange_s = exchange_s;
        self
    }

    /// The shared mock.
    #[must_use]
    pub fn mock(&self) -> Arc<Mutex<MockPlc>> {
        Arc::clone(&self.mock)
    }

    /// The virtual time now, s.
    #[must_use]
    pub fn now_s(&self) -> f64 {
        self.clock.now_s()
    }

    /// Lets `dt_s` pass (the mock runs its scans and pulses meanwhile).
    pub fn advance(&mut self, dt_s: f64) {
        let now_s = self.clock.advance(dt_s);
        self.lock().advance_to(now_s);
    }

    fn lock(&self) -> MutexGuard<'_, MockPlc> {
        self.mock.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// One exchange: the clock moves on, the mock catches up, then `op` runs on it.
    fn exchange<T>(&mut self, op: impl FnOnce(&mut MockPlc) -> T) -> T {
        let now_s = self.clock.advance(self.exchange_s);
        let mut mock = self.lock();
        mock.advance_to(now_s);
        op(&mut mock)
    }
}

/// A memory range error as the refusal a MEWTOCOL-COM PLC gives.
fn refused(operation: String, error: MemoryError) -> PlcError {
    let code = error.mewtocol_code();
    let meaning = if code == 66 {
        "address error (address format, over or under range)"
    } else {
        "data error (range, start > end, non-hex data)"
    };
    tracing::debug!(%error, "in-process mock refused {operation}");
    PlcError::Refused {
        operation,
        refusal: Refusal::Mewtocol { code, meaning },
    }
}

fn dt_operation(verb: &str, start: u16, count: usize) -> String {
    let end = u32::from(start) + count.max(1) as u32 - 1;
    format!("{verb} DT{start}..=DT{end}")
}

impl Plc for InProcess {
    fn read_words(
        &mut self,
        start: u16,
        count: u16,
    ) -> impl Future<Output = Result<Vec<u16>, PlcError>> + Send {
        let result = self.exchange(|m| m.host_read_words(u32::from(start), usize::from(count)));
        ready(result.map_err(|e| refused(dt_operation("read", start, usize::from(count)), e)))
    }

    fn write_words(
        &mut self,
        start: u16,
        words: &[u16],
    ) -> impl Future<Output = Result<(), PlcError>> + Send {
        let result = self.exchange(|m| m.host_write_words(u32::from(start), words));
        ready(result.map_err(|e| refused(dt_operation("write", start, words.len()), e)))
    }

    fn write_words_once(
        &mut self,
        start: u16,
        words: &[u16],
    ) -> impl Future<Output = Result<(), PlcError>> + Send {
        self.write_words(start, words)
    }

    fn mode(&mut self) -> impl Future<Output = Result<PlcMode, PlcError>> + Send {
        ready(Ok(self.exchange(|m| m.mode())))
    }

    fn read_bits(
        &mut self,
        area: Area,
        start: u32,
        count: u16,
    ) -> impl Future<Output = Result<Vec<bool>, PlcError>> + Send {
        let result = self.exchange(|m| {
            (start..start + u32::from(count))
                .map(|bit| m.read_bit(area, bit))
                .collect::<Result<Vec<bool>, _>>()
        });
        ready(result.map_err(|e| refused(format!("read {count} bits of {}", area.name()), e)))
    }

    fn write_bit(
        &mut self,
        area: Area,
        bit: u32,
        on: bool,
    ) -> impl Future<Output = Result<(), PlcError>> + Send {
        let result = self.exchange(|m| m.host_write_bit(area, bit, on));
        ready(result.map_err(|e| refused(format!("write bit {bit} of {}", area.name()), e)))
    }

    fn exchange_sizes(&self) -> ExchangeSizes {
        ExchangeSizes {
            read_words: 509,
            write_words: 507,
            read_bits: 2000,
        }
    }
}
