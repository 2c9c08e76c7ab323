//! What the mock PLC answers, protocol by protocol but without any link: MEWTOCOL-COM commands
//! and station rules, executed on a [`MockPlc`].
//!
//! ```text
//!  RDD / WDD   DT words                      memory errors -> ! 61 (range end) / ! 66 (address)
//!  RCS / WCS   R relays (R9020 reads RUN)    X, Y, L: ! 66 (the mock has no I/O)
//!  RCC         R relay words (WR)
//!  RT          status, mode flags bit 0 = RUN
//!  RMR / RMP   switch RUN / PROG
//! ```
//! The `small-requests` variant answers a read or write of more than
//! [`super::SMALL_MEWTOCOL_WORDS`] words with `! 41` (format error), as a PLC whose buffer is
//! shorter than the frame might.
//!
//! Station rules (PLC.md §1, "Frames"): `FF` is executed and never answered; `EE` is answered by
//! any station; a numbered station is answered only by that station, or by a mock configured to
//! answer every station.

use crate::gateway::Area;
use crate::mewtocol::{
    Command, Contact, ContactArea, ContactWords, Mode, PlcError, PlcErrorCode, PlcStatus, Reply,
    Response, Station,
};
use crate::plc::PlcMode;

use super::{MemoryError, MockPlc};

/// Which station (MEWTOCOL-COM) or unit id (Modbus) a server answers as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StationFilter {
    /// Every station number (the reply carries the number asked for).
    Any,
    /// This station only (and `EE` for MEWTOCOL-COM).
    Only(u8),
}

/// `any`, or the station number, as logs show it.
impl std::fmt::Display for StationFilter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Any => f.write_str("any"),
            Self::Only(n) => write!(f, "{n}"),
        }
    }
}

/// What to do with a command sent to some station.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Route {
    /// Execute and reply from this station.
    Answer(Station),
    /// Execute, send nothing (broadcast).
    Silent,
    /// Not for us: neither execute nor reply.
    Ignore,
}

impl StationFilter {
    /// Where a MEWTOCOL-COM command to `station` goes.
    #[must_use]
    pub fn route(self, station: Station) -> Route {
        if station.is_broadcast() {
            return Route::Silent;
        }
        match (self, station.number()) {
            (Self::Any, _) => Route::Answer(station),
            (Self::Only(own), None) => {
                Station::new(own).map_or(Route::Answer(station), Route::Answer)
            }
            (Self::Only(own), Some(n)) if n == own => Route::Answer(station),
            (Self::Only(_), Some(_)) => Route::Ignore,
        }
    }

    /// Whether a Modbus request to `unit` is ours (unit 0, broadcast, is everyone's).
    #[must_use]
    pub fn accepts_unit(self, unit: u8) -> bool {
        match self {
            Self::Any => true,
            Self::Only(own) => unit == own || unit == 0,
        }
    }
}

fn refuse(code: PlcErrorCode) -> Response {
    Err(PlcError { code })
}

/// A memory range error as the `!` code an FP-X answers (61 or 66).
fn memory_refusal(error: MemoryError) -> PlcError {
    tracing::debug!(%error, "mock refused a memory access");
    PlcError {
        code: PlcErrorCode::from_number(error.mewtocol_code()),
    }
}

/// The relay number of an R contact (word * 16 + bit), or `None` for X, Y and L.
/// The gateway's area of a MEWTOCOL contact area (L, the link relays, the mock lacks).
fn bit_area(area: ContactArea) -> Option<Area> {
    match area {
        ContactArea::X => Some(Area::X),
        ContactArea::Y => Some(Area::Y),
        ContactArea::R => Some(Area::R),
        ContactArea::L => None,
    }
}

/// The `RT` status the mock reports: only the mode flags mean anything.
#[must_use]
pub fn plc_status(mock: &MockPlc) -> PlcStatus {
    PlcStatus {
        mode_flags: u8::from(mock.mode() == PlcMode::Run),
        ..PlcStatus::default()
    }
}

/// Words a read or write command carries (0 for other commands).
fn dt_words(command: &Command) -> usize {
    match command {
        Command::ReadDt(range) => range.len(),
        Command::WriteDt { words, .. } => words.len(),
        _ => 0,
    }
}

/// The area and bit number of contact `c` (`None`: not an area of bits).
fn contact_bit(c: Contact) -> Option<(Area, u32)> {
    let area = bit_area(c.area())?;
    Some((area, u32::from(c.word()) * 16 + u32::from(c.bit())))
}

/// RCS: one contact.
fn read_contact(mock: &mut MockPlc, c: Contact) -> Response {
    let Some((area, bit)) = contact_bit(c) else {
        return refuse(PlcErrorCode::AddressError);
    };
    mock.read_bit(area, bit)
        .map(Reply::ReadContact)
        .map_err(memory_refusal)
}

/// WCS: one contact set or reset.
fn write_contact(mock: &mut MockPlc, c: Contact, on: bool) -> Response {
    let Some((area, bit)) = contact_bit(c) else {
        return refuse(PlcErrorCode::AddressError);
    };
    mock.host_write_bit(area, bit, on)
        .map(|()| Reply::WriteContact)
        .map_err(memory_refusal)
}

/// RCC: words of contacts.
fn read_contact_words(mock: &mut MockPlc, words: ContactWords) -> Response {
    let Some(area) = bit_area(words.area()) else {
        return refuse(PlcErrorCode::AddressError);
    };
    mock.memory()
        .read_bit_words(area, u32::from(words.start()), words.len())
        .map(|w| Reply::ReadContactWords(w.to_vec()))
        .map_err(memory_refusal)
}

/// Executes one MEWTOCOL-COM command on the mock and gives its response.
pub fn execute(mock: &mut MockPlc, command: &Command) -> Response {
    tracing::trace!(?command, at_s = mock.now_s(), "MEWTOCOL command");
    if let Some(limit) = mock.config().variant.mewtocol_words_limit()
        && dt_words(command) > limit
    {
        tracing::warn!(words = dt_words(command), limit, "small-requests: refused");
        return refuse(PlcErrorCode::FormatError);
    }
    match command {
        Command::ReadDt(range) => mock
            .host_read_words(range.start(), range.len())
            .map(Reply::ReadDt)
            .map_err(memory_refusal),
        Command::WriteDt { start, words } => mock
            .host_write_words(*start, words)
            .map(|()| Reply::WriteDt)
            .map_err(memory_refusal),
        Command::ReadContact(c) => read_contact(mock, *c),
        Command::WriteContact { contact, on } => write_contact(mock, *contact, *on),
        Command::ReadContactWords(words) => read_contact_words(mock, *words),
        Command::Status => Ok(Reply::Status(plc_status(mock))),
        Command::SetMode(mode) => {
            mock.set_mode(match mode {
                Mode::Run => PlcMode::Run,
                Mode::Prog => PlcMode::Prog,
            });
            Ok(Reply::SetMode)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mewtocol::{Contact, DtRange};
    use crate::mock::MockConfig;

    fn st(n: u8) -> Station {
        Station::new(n).unwrap()
    }

    #[test]
    fn station_rules_follow_the_manual() {
        let own = StationFilter::Only(3);
        assert_eq!(own.route(st(3)), Route::Answer(st(3)));
        assert_eq!(own.route(st(4)), Route::Ignore);
        assert_eq!(own.route(Station::ANY), Route::Answer(st(3)));
        assert_eq!(own.route(Station::BROADCAST), Route::Silent);
        assert_eq!(StationFilter::Any.route(st(42)), Route::Answer(st(42)));
        assert_eq!(StationFilter::Any.route(Station::BROADCAST), Route::Silent);
        assert!(own.accepts_unit(0) && own.accepts_unit(3) && !own.accepts_unit(4));
    }

    #[test]
    fn reads_past_dt32764_are_address_errors_and_ends_past_it_data_errors() {
        let mut mock = MockPlc::new(MockConfig::default()).unwrap();
        let special = Command::ReadDt(DtRange::new(90_000, 90_001).unwrap());
        let code = |r: Response| r.unwrap_err().code.number();
        assert_eq!(code(execute(&mut mock, &special)), 66);
        let status = execute(&mut mock, &Command::Status).unwrap();
        assert_eq!(status, Reply::Status(plc_status(&mock)));
        let r9020 = Contact::new(ContactArea::R, 902, 0).unwrap();
        assert_eq!(
            execute(&mut mock, &Command::ReadContact(r9020)),
            Ok(Reply::ReadContact(true))
        );
        let y0 = Contact::new(ContactArea::Y, 0, 0).unwrap();
        assert_eq!(
            execute(&mut mock, &Command::ReadContact(y0)),
            Ok(Reply::ReadContact(false))
        );
        let l0 = Contact::new(ContactArea::L, 0, 0).unwrap();
        assert_eq!(code(execute(&mut mock, &Command::ReadContact(l0))), 66);
    }

    #[test]
    fn small_requests_refuse_more_than_64_words_with_a_format_error() {
        let mut mock = MockPlc::new(MockConfig {
            variant: crate::mock::MockVariant::SmallRequests,
            ..MockConfig::default()
        })
        .unwrap();
        let read = |n| Command::ReadDt(DtRange::from_len(2000, n).unwrap());
        assert!(execute(&mut mock, &read(64)).is_ok());
        assert_eq!(execute(&mut mock, &read(65)).unwrap_err().code.number(), 41);
        let write = Command::write_dt(2000, vec![0; 65]).unwrap();
        assert_eq!(execute(&mut mock, &write).unwrap_err().code.number(), 41);
    }

    #[test]
    fn rm_switches_the_mode() {
        let mut mock = MockPlc::new(MockConfig::default()).unwrap();
        execute(&mut mock, &Command::SetMode(Mode::Prog)).unwrap();
        assert_eq!(mock.mode(), PlcMode::Prog);
        assert!(!plc_status(&mock).is_running());
    }
}
