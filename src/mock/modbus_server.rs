//! IO. The mock PLC's Modbus servers, through tokio-modbus's server side (never Modbus by hand):
//! Modbus TCP on a listener, Modbus RTU on a serial port (a real one or a pty).
//!
//! ```text
//!  03 read holding registers   DT n = register n, 1..=125 a request
//!  06 / 16 write register(s)   16: 1..=123 a request
//!  01 read coils               coil 16 w + b = Y w.b (below 2048), coil 2048 + 16 w + b = R w.b,
//!                              1..=2000; R9020 reads RUN
//!  02 read discrete inputs     input 16 w + b = X w.b, 1..=2000
//!  05 / 15 write coil(s)       15: 1..=1968
//!  out of memory: exception 02 (illegal data address); bad quantity: 03 (illegal data value);
//!  any other function: 01 (illegal function)
//! ```
//! (PLC.md §2; Modbus Application Protocol v1.1b3, §6.) Link faults per request: drop (no reply),
//! delay, exception N, close (TCP: the connection ends; RTU: no reply), a MEWTOCOL error in the
//! script answers exception 04; corrupt is not possible through tokio-modbus and drops the reply.
//! The `small-requests` variant takes at most [`super::SMALL_MODBUS_REGISTERS`] registers a read or
//! write (exception 03 beyond).

use std::future::Future;
use std::io;
use std::pin::Pin;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::task::{Context, Poll};
use std::time::Duration;

use tokio::io::{AsyncRead, ReadBuf};
use tokio::net::{TcpListener, TcpStream};
use tokio_modbus::server::Service;
use tokio_modbus::{ExceptionCode, Request, Response, SlaveRequest};

use super::answer::StationFilter;
use super::shared::SharedMock;
use super::wire::WireStream;
use super::{IO_WORDS, LinkFault, MemoryError, MockPlc, RELAY_LAST};
use crate::gateway::Area;
use crate::plc::{BoxedLink, RELAY_COIL_BASE, ReadFilter, ReadFiltered};

/// Registers one read (03) may ask for (Modbus spec).
const MAX_READ_REGISTERS: u16 = 125;
/// Registers one write (16) may carry.
const MAX_WRITE_REGISTERS: usize = 123;
/// Coils one read (01) may ask for.
const MAX_READ_COILS: u16 = 2000;
/// Coils one write (15) may carry.
const MAX_WRITE_COILS: usize = 1968;

/// How a Modbus server behaves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModbusServerOptions {
    /// Which unit ids it answers.
    pub unit: StationFilter,
    /// Emulated line speed for TCP connections (see [`super::WireStream`]); replies then leave
    /// at the end of the scan in which their request arrived.
    pub baud: Option<u32>,
}

impl Default for ModbusServerOptions {
    fn default() -> Self {
        Self {
            unit: StationFilter::Only(1),
            baud: None,
        }
    }
}

/// A Modbus server on a shared mock.
#[derive(Debug, Clone)]
pub struct ModbusServer {
    mock: SharedMock,
    options: ModbusServerOptions,
}

/// The tokio-modbus service of one connection.
#[derive(Debug, Clone)]
struct MockService {
    server: ModbusServer,
    /// RTU: unit 0 is a broadcast (executed, never answered).
    rtu: bool,
    /// Set to end the connection (TCP).
    closed: Arc<AtomicBool>,
}

impl ModbusServer {
    /// A server on `mock`.
    #[must_use]
    pub fn new(mock: SharedMock, options: ModbusServerOptions) -> Self {
        Self { mock, options }
    }

    /// Serves Modbus TCP on `listener` forever, one task per connection.
    pub async fn serve_tcp(self, listener: TcpListener) -> io::Result<()> {
        let on_connected = self.on_connected(false);
        let on_error = |e: io::Error| tracing::warn!(error = %e, "Modbus TCP connection failed");
        tokio_modbus::server::tcp::Server::new(listener)
            .serve(&on_connected, on_error)
            .await
    }

    /// Serves Modbus RTU framing over TCP connections on `listener` forever, one task per
    /// connection: with `baud`, a serial RTU line emulated at that speed (what the upload
    /// benchmark measures), since tokio-modbus serves RTU on nothing else but a serial port.
    pub async fn serve_rtu_over_tcp(self, listener: TcpListener) -> io::Result<()> {
        let on_connected = self.on_connected(true);
        let on_error =
            |e: io::Error| tracing::warn!(error = %e, "Modbus RTU-over-TCP connection failed");
        tokio_modbus::server::rtu_over_tcp::Server::new(listener)
            .serve(&on_connected, on_error)
            .await
    }

    /// What a new TCP connection gets: the service and the link (through the wire emulation
    /// when a baud rate is set).
    fn on_connected(&self, rtu: bool) -> impl Fn(TcpStream, std::net::SocketAddr) -> Accepted {
        let server = self.clone();
        move |stream: TcpStream, peer| {
            tracing::info!(%peer, rtu, "Modbus client connected");
            let _ = stream.set_nodelay(true);
            let link: BoxedLink = match server.options.baud {
                Some(baud) => Box::new(WireStream::new(stream, baud)),
                None => Box::new(stream),
            };
            let service = server.service(rtu);
            let link = ReadFiltered::new(link, Closing(Arc::clone(&service.closed)));
            std::future::ready(Ok(Some((service, link))))
        }
    }

    /// Serves Modbus RTU on a serial port until it fails or closes.
    pub async fn serve_rtu(self, port: tokio_serial::SerialStream) -> io::Result<()> {
        let service = self.service(true);
        tokio_modbus::server::rtu::Server::new(port)
            .serve_forever(service)
            .await
    }

    fn service(&self, rtu: bool) -> MockService {
        MockService {
            server: self.clone(),
            rtu,
            closed: Arc::new(AtomicBool::new(false)),
        }
    }
}

/// What accepting a TCP connection yields to tokio-modbus's server.
type Accepted =
    std::future::Ready<io::Result<Option<(MockService, ReadFiltered<BoxedLink, Closing>)>>>;

type Answer = Pin<Box<dyn Future<Output = Result<Option<Response>, ExceptionCode>> + Send>>;

impl Service for MockService {
    type Request = SlaveRequest<'static>;
    type Response = Option<Response>;
    type Exception = ExceptionCode;
    type Future = Answer;

    fn call(&self, request: SlaveRequest<'static>) -> Answer {
        let service = self.clone();
        Box::pin(async move { service.answer(request).await })
    }
}

impl MockService {
    async fn answer(
        self,
        request: SlaveRequest<'static>,
    ) -> Result<Option<Response>, ExceptionCode> {
        let options = self.server.options;
        if !options.unit.accepts_unit(request.slave) {
            tracing::debug!(unit = request.slave, "request for another unit");
            return Ok(None);
        }
        let mock = &self.server.mock;
        if options.baud.is_some() {
            mock.wait_scan_end().await;
        }
        let (faults, mut result) = mock.with(|m| (m.on_command(), execute(m, &request.request)));
        for fault in faults {
            tracing::warn!(%fault, "injecting link fault");
            match fault {
                LinkFault::Drop | LinkFault::Corrupt { .. } => return Ok(None),
                LinkFault::Close => {
                    self.closed.store(true, Ordering::SeqCst);
                    return Ok(None);
                }
                LinkFault::Delay { ms } => tokio::time::sleep(Duration::from_millis(ms)).await,
                LinkFault::ModbusException { code } => result = Err(ExceptionCode::new(code)),
                LinkFault::MewtocolError { .. } => result = Err(ExceptionCode::ServerDeviceFailure),
            }
        }
        if self.rtu && request.slave == 0 {
            return Ok(None);
        }
        result.map(Some)
    }
}

fn address_error(error: MemoryError) -> ExceptionCode {
    tracing::debug!(%error, "mock refused a memory access");
    ExceptionCode::new(error.modbus_exception())
}

fn quantity(n: usize, max: usize) -> Result<(), ExceptionCode> {
    if (1..=max).contains(&n) {
        Ok(())
    } else {
        Err(ExceptionCode::IllegalDataValue)
    }
}

/// The area and bit a coil addresses: Y below 2048, R from 2048 (PLC.md §2).
fn coil_bit(coil: u32) -> (Area, u32) {
    match coil.checked_sub(u32::from(RELAY_COIL_BASE)) {
        Some(relay) => (Area::R, relay),
        None => (Area::Y, coil),
    }
}

fn read_coil(mock: &MockPlc, coil: u32) -> Result<bool, ExceptionCode> {
    let (area, bit) = coil_bit(coil);
    mock.read_bit(area, bit).map_err(address_error)
}

fn write_coils(mock: &mut MockPlc, first: u16, coils: &[bool]) -> Result<(), ExceptionCode> {
    let (area, start) = coil_bit(u32::from(first));
    let last = coil_bit(u32::from(first) + coils.len() as u32 - 1);
    let size = if area == Area::R {
        u32::from(RELAY_LAST)
    } else {
        u32::from(IO_WORDS) * 16 - 1
    };
    if last.0 != area || last.1 > size {
        return Err(ExceptionCode::IllegalDataAddress);
    }
    for (bit, on) in (start..).zip(coils) {
        mock.host_write_bit(area, bit, *on).map_err(address_error)?;
    }
    Ok(())
}

/// Registers one read (03) or write (16) may hold on this mock.
fn registers_limit(mock: &MockPlc, spec: usize) -> usize {
    let variant = mock.config().variant;
    variant
        .modbus_registers_limit()
        .map_or(spec, |n| n.min(spec))
}

/// Executes one Modbus request on the mock.
fn execute(mock: &mut MockPlc, request: &Request<'_>) -> Result<Response, ExceptionCode> {
    match request {
        Request::ReadHoldingRegisters(start, n) => {
            let most = registers_limit(mock, usize::from(MAX_READ_REGISTERS));
            quantity(usize::from(*n), most)?;
            mock.host_read_words(u32::from(*start), usize::from(*n))
                .map(Response::ReadHoldingRegisters)
                .map_err(address_error)
        }
        Request::WriteSingleRegister(at, word) => mock
            .host_write_words(u32::from(*at), &[*word])
            .map(|()| Response::WriteSingleRegister(*at, *word))
            .map_err(address_error),
        Request::WriteMultipleRegisters(start, words) => {
            quantity(words.len(), registers_limit(mock, MAX_WRITE_REGISTERS))?;
            mock.host_write_words(u32::from(*start), words)
                .map(|()| Response::WriteMultipleRegisters(*start, words.len() as u16))
                .map_err(address_error)
        }
        Request::ReadCoils(first, n) => {
            quantity(usize::from(*n), usize::from(MAX_READ_COILS))?;
            let coils = (0..u32::from(*n)).map(|i| read_coil(mock, u32::from(*first) + i));
            coils.collect::<Result<_, _>>().map(Response::ReadCoils)
        }
        Request::ReadDiscreteInputs(first, n) => {
            quantity(usize::from(*n), usize::from(MAX_READ_COILS))?;
            let inputs = (0..u32::from(*n)).map(|i| {
                mock.read_bit(Area::X, u32::from(*first) + i)
                    .map_err(address_error)
            });
            inputs
                .collect::<Result<_, _>>()
                .map(Response::ReadDiscreteInputs)
        }
        Request::WriteSingleCoil(coil, on) => {
            write_coils(mock, *coil, &[*on]).map(|()| Response::WriteSingleCoil(*coil, *on))
        }
        Request::WriteMultipleCoils(first, coils) => {
            quantity(coils.len(), MAX_WRITE_COILS)?;
            write_coils(mock, *first, coils)
                .map(|()| Response::WriteMultipleCoils(*first, coils.len() as u16))
        }
        _ => Err(ExceptionCode::IllegalFunction),
    }
}

/// A stream's reads as closed (end of stream) once the flag is set, so tokio-modbus ends the
/// connection after a scripted `close`.
#[derive(Debug)]
struct Closing(Arc<AtomicBool>);

impl<S: AsyncRead + Unpin> ReadFilter<S> for Closing {
    fn poll_read(
        &mut self,
        inner: &mut S,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        if self.0.load(Ordering::SeqCst) {
            return Poll::Ready(Ok(()));
        }
        Pin::new(inner).poll_read(cx, buf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mock::MockConfig;

    fn mock() -> MockPlc {
        MockPlc::new(MockConfig::default()).unwrap()
    }

    #[test]
    fn quantities_outside_the_spec_are_illegal_data_values() {
        let mut m = mock();
        let read = |n| Request::ReadHoldingRegisters(0, n);
        assert_eq!(
            execute(&mut m, &read(126)),
            Err(ExceptionCode::IllegalDataValue)
        );
        assert_eq!(
            execute(&mut m, &read(0)),
            Err(ExceptionCode::IllegalDataValue)
        );
        assert_eq!(
            execute(&mut m, &Request::ReadCoils(2048, 2001)),
            Err(ExceptionCode::IllegalDataValue)
        );
        let big = Request::WriteMultipleRegisters(0, vec![0; 124].into());
        assert_eq!(execute(&mut m, &big), Err(ExceptionCode::IllegalDataValue));
    }

    #[test]
    fn small_requests_take_at_most_100_registers() {
        let mut m = MockPlc::new(MockConfig {
            variant: crate::mock::MockVariant::SmallRequests,
            ..MockConfig::default()
        })
        .unwrap();
        assert!(execute(&mut m, &Request::ReadHoldingRegisters(2000, 100)).is_ok());
        assert_eq!(
            execute(&mut m, &Request::ReadHoldingRegisters(2000, 101)),
            Err(ExceptionCode::IllegalDataValue)
        );
        let big = Request::WriteMultipleRegisters(2000, vec![0; 101].into());
        assert_eq!(execute(&mut m, &big), Err(ExceptionCode::IllegalDataValue));
    }

    #[test]
    fn addresses_outside_memory_are_illegal_data_addresses() {
        let mut m = mock();
        let past = Request::ReadHoldingRegisters(32_760, 10);
        assert_eq!(
            execute(&mut m, &past),
            Err(ExceptionCode::IllegalDataAddress)
        );
        let past_y109f = Request::ReadCoils(110 * 16, 1);
        assert_eq!(
            execute(&mut m, &past_y109f),
            Err(ExceptionCode::IllegalDataAddress)
        );
        let past_r255f = Request::WriteMultipleCoils(2048 + 4095, vec![true; 2].into());
        assert_eq!(
            execute(&mut m, &past_r255f),
            Err(ExceptionCode::IllegalDataAddress)
        );
    }

    #[test]
    fn coils_from_2048_are_r_relays_and_r9020_reads_run() {
        let mut m = mock();
        let r1a = 2048 + 16 + 0xA;
        execute(&mut m, &Request::WriteSingleCoil(r1a, true)).unwrap();
        assert!(m.read_relay(0x1A).unwrap());
        let run = Request::ReadCoils(2048 + crate::plc::R9020, 1);
        assert_eq!(execute(&mut m, &run), Ok(Response::ReadCoils(vec![true])));
    }

    #[test]
    fn coils_below_2048_are_y_outputs_and_discrete_inputs_are_x() {
        let mut m = mock();
        execute(&mut m, &Request::WriteSingleCoil(17, true)).unwrap();
        assert!(m.read_bit(Area::Y, 17).unwrap());
        m.set_input(3, true).unwrap();
        assert_eq!(
            execute(&mut m, &Request::ReadDiscreteInputs(2, 3)),
            Ok(Response::ReadDiscreteInputs(vec![false, true, false]))
        );
        assert_eq!(
            execute(
                &mut m,
                &Request::WriteMultipleCoils(2040, std::borrow::Cow::Borrowed(&[true; 10]))
            ),
            Err(ExceptionCode::IllegalDataAddress),
            "a write from Y into R"
        );
    }
}
