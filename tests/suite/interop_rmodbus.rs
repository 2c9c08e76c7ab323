//! Modbus interoperability with an independent Rust implementation, in process: rmodbus's frame
//! processing (server side) and request builder and response parser (client side).
//!
//! - linterpd's `ModbusClient` against rmodbus servers: Modbus TCP on 127.0.0.1:0 and Modbus RTU
//!   on a `SerialStream::pair()` pseudo-terminal; and an RTU peer that takes at most 100
//!   registers a write, as some devices do.
//! - an rmodbus client against the mock's `ModbusServer`, over TCP and over RTU.
//!
//! rmodbus frames bytes it is given and leaves the transport to its user: the loops here only
//! move bytes. They read as many bytes as rmodbus's `guess_*_frame_len` says a frame has, hand
//! the frame to rmodbus, and write what it answers. No Modbus framing is written here.
//!
//! rmodbus 0.13 frames at most 255 bytes (its frame lengths are `u8`, and its server refuses an
//! MBAP length above 250), while a Modbus TCP frame reaches 260 (rmodbus's issue 55). Over TCP it therefore takes a
//! write of at most [`RMODBUS_TCP_MAX_WRITE`] registers and reads a reply of at most
//! [`RMODBUS_TCP_MAX_READ`]; over RTU it handles the spec's 123 and 125. So linterpd's client
//! writes at most 121 registers a request to the rmodbus TCP server (what `modbus_max_write` is
//! for), and one test shows what the default 123 meets there.

use std::io;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use linterpd::contract::{DT_LAST, Layout, MAGIC, STATUS_WORDS, StatusBlock, VERSION};
use linterpd::mock::{
    MockConfig, MockPlc, ModbusServer, ModbusServerOptions, SharedMock, StationFilter,
};
use linterpd::plc::{
    MAX_WRITE_REGISTERS, ModbusClient, ModbusFraming, ModbusOptions, Plc, PlcError,
    RELAY_COIL_BASE, Refusal,
};
use rmodbus::client::ModbusRequest;
use rmodbus::consts::ModbusFunction;
use rmodbus::server::ModbusFrame;
use rmodbus::server::storage::ModbusStorageFull;
use rmodbus::{ErrorKind, ModbusProto, guess_request_frame_len, guess_response_frame_len};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::task::JoinHandle;
use tokio_serial::SerialStream;

/// Longest wait for one exchange, a connection or a server task's end.
const WAIT: Duration = Duration::from_secs(5);
/// The unit id of the rmodbus servers and of the mock over TCP (over RTU it is 7).
const UNIT: u8 = 1;
/// Holding registers (and coils) an rmodbus server holds: `ModbusStorageFull`'s 10 000, fewer
/// than the FP-X's DT area, so a read past them is an exception linterpd lets through.
const SERVER_REGISTERS: u16 = 10_000;
/// Registers written and read back in one round trip: several requests' worth.
const ROUND_TRIP_WORDS: u16 = 300;
/// Registers one write to an rmodbus TCP server may carry: 7 + 6 + 2 n bytes fit in 255.
const RMODBUS_TCP_MAX_WRITE: u16 = 121;
/// Registers one read reply from a Modbus TCP server may carry for rmodbus: 9 + 2 n <= 255.
const RMODBUS_TCP_MAX_READ: u16 = 123;
/// Registers the rmodbus client asks for or writes at once (within both limits above).
const CLIENT_CHUNK: u16 = 100;
/// The write limit of the narrow peer.
const NARROW_MAX_WRITE: u16 = 100;
/// Relay R3A (word 3, bit A) for the coil round trips.
const RELAY: u16 = 3 * 16 + 0xA;

// ---------------------------------------------------------------------------------------------
// Moving rmodbus's frames
// ---------------------------------------------------------------------------------------------

fn invalid(e: ErrorKind) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, e)
}

/// Reads one frame: the first bytes `guess` needs, one more at a time while it needs more, then
/// the rest of the length it tells.
async fn read_frame<S: AsyncRead + Unpin>(
    stream: &mut S,
    proto: ModbusProto,
    guess: fn(&[u8], ModbusProto) -> Result<u8, ErrorKind>,
) -> io::Result<Vec<u8>> {
    let first = if proto == ModbusProto::TcpUdp { 6 } else { 2 };
    let mut frame = vec![0; first];
    stream.read_exact(&mut frame).await?;
    let len = loop {
        match guess(&frame, proto) {
            Ok(len) => break usize::from(len),
            Err(ErrorKind::OOB) => frame.push(stream.read_u8().await?),
            Err(e) => return Err(invalid(e)),
        }
    };
    let have = frame.len();
    if len < have {
        return Err(invalid(ErrorKind::FrameBroken));
    }
    frame.resize(len, 0);
    stream.read_exact(&mut frame[have..]).await?;
    Ok(frame)
}

// ---------------------------------------------------------------------------------------------
// rmodbus servers
// ---------------------------------------------------------------------------------------------

/// One request as an rmodbus server saw it: function code and register / coil count.
type Seen = (u8, u16);

/// An rmodbus server's memory and what it was asked.
#[derive(Clone)]
struct Peer {
    storage: Arc<Mutex<ModbusStorageFull>>,
    seen: Arc<Mutex<Vec<Seen>>>,
    /// Writes (16) of more registers than this are answered with exception 03.
    max_write: Option<u16>,
}

impl Peer {
    fn new(max_write: Option<u16>) -> Self {
        Self {
            storage: Arc::new(Mutex::new(ModbusStorageFull::new())),
            seen: Arc::new(Mutex::new(Vec::new())),
            max_write,
        }
    }

    fn holdings(&self, start: u16, count: u16) -> Vec<u16> {
        let storage = self.storage.lock().unwrap_or_else(PoisonError::into_inner);
        storage.holdings[usize::from(start)..usize::from(start + count)].to_vec()
    }

    /// Register counts of the writes (16) seen so far.
    fn writes(&self) -> Vec<u16> {
        let seen = self.seen.lock().unwrap_or_else(PoisonError::into_inner);
        let write = ModbusFunction::SetHoldingsBulk.byte();
        seen.iter()
            .filter(|(func, _)| *func == write)
            .map(|&(_, n)| n)
            .collect()
    }

    /// rmodbus parses, processes and answers one request; `None` when no answer is due.
    fn answer(&self, request: &[u8], proto: ModbusProto) -> Result<Option<Vec<u8>>, ErrorKind> {
        let mut response = Vec::new();
        let mut frame = ModbusFrame::new(UNIT, request, proto, &mut response);
        frame.parse()?;
        if frame.processing_required {
            self.seen
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push((frame.func.byte(), frame.count));
            let too_long = frame.func == ModbusFunction::SetHoldingsBulk
                && self.max_write.is_some_and(|max| frame.count > max);
            let mut storage = self.storage.lock().unwrap_or_else(PoisonError::into_inner);
            if too_long {
                frame.set_modbus_error_if_unset(&ErrorKind::IllegalDataValue)?;
            } else if frame.readonly {
                frame.process_read(&*storage)?;
            } else {
                frame.process_write(&mut *storage)?;
            }
        }
        if !frame.response_required {
            return Ok(None);
        }
        frame.finalize_response()?;
        Ok(Some(response))
    }

    /// Serves `stream` until it closes (`Ok`) or rmodbus cannot frame or parse a request.
    async fn serve<S: AsyncRead + AsyncWrite + Unpin>(
        self,
        mut stream: S,
        proto: ModbusProto,
    ) -> io::Result<()> {
        loop {
            let request = match read_frame(&mut stream, proto, guess_request_frame_len).await {
                Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => return Ok(()),
                other => other?,
            };
            if let Some(response) = self.answer(&request, proto).map_err(invalid)? {
                stream.write_all(&response).await?;
            }
        }
    }

    /// Serves Modbus TCP to one connection on a fresh loopback port; returns the port's client
    /// end, connected, and the server's task.
    async fn serve_tcp(&self) -> (TcpStream, JoinHandle<io::Result<()>>) {
        let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
        let address = listener.local_addr().unwrap();
        let peer = self.clone();
        let server = tokio::spawn(async move {
            let (stream, _) = listener.accept().await?;
            peer.serve(stream, ModbusProto::TcpUdp).await
        });
        let stream = tokio::time::timeout(WAIT, TcpStream::connect(address))
            .await
            .expect("connect in time")
            .unwrap_or_else(|e| panic!("connect to the rmodbus server at {address}: {e}"));
        (stream, server)
    }

    /// Serves Modbus RTU on one end of a pseudo-terminal pair; returns the other end and the
    /// server's task.
    fn serve_rtu(&self) -> (SerialStream, JoinHandle<io::Result<()>>) {
        let (ours, theirs) = SerialStream::pair().expect("a pseudo-terminal pair");
        let server = tokio::spawn(self.clone().serve(theirs, ModbusProto::Rtu));
        (ours, server)
    }
}

/// How a server task ended (it ends when the client's end closes or on an rmodbus error).
async fn ended(server: JoinHandle<io::Result<()>>) -> io::Result<()> {
    tokio::time::timeout(WAIT, server)
        .await
        .expect("the rmodbus server should end once its client is gone")
        .expect("the rmodbus server task should not panic")
}

// ---------------------------------------------------------------------------------------------
// linterpd's client against rmodbus servers
// ---------------------------------------------------------------------------------------------

fn options(framing: ModbusFraming) -> ModbusOptions {
    ModbusOptions {
        timeout: Duration::from_secs(2),
        ..ModbusOptions::new(framing, UNIT)
    }
}

/// Distinct words, none zero, different in both bytes from one address to the next.
fn pattern(start: u16, count: u16) -> Vec<u16> {
    (0..count)
        .map(|i| start.wrapping_add(i).wrapping_mul(0x0101) ^ 0x5AA5)
        .collect()
}

fn assert_refused(outcome: Result<impl std::fmt::Debug, PlcError>, code: u8, what: &str) {
    match outcome {
        Err(PlcError::Refused {
            refusal: Refusal::Modbus { code: got, .. },
            ..
        }) if got == code => {}
        other => panic!("{what} should be refused with exception {code:#04x}, got {other:?}"),
    }
}

/// Writes and reads back 300 registers, checks them in the peer's memory, switches a relay on
/// and off, reads past the peer's registers (exception 02) and reads once more.
async fn round_trip<P: Plc>(plc: &mut P, peer: &Peer) {
    let start = Layout::default().table_base;
    let words = pattern(start, ROUND_TRIP_WORDS);
    plc.write_words(start, &words)
        .await
        .unwrap_or_else(|e| panic!("write {ROUND_TRIP_WORDS} registers: {e:?}"));
    let read = plc
        .read_words(start, ROUND_TRIP_WORDS)
        .await
        .unwrap_or_else(|e| panic!("read {ROUND_TRIP_WORDS} registers: {e:?}"));
    assert_eq!(read, words, "registers read back");
    assert_eq!(peer.holdings(start, ROUND_TRIP_WORDS), words, "in rmodbus");

    for on in [true, false, true] {
        plc.write_relay(RELAY, on)
            .await
            .unwrap_or_else(|e| panic!("write R3A = {on}: {e:?}"));
        let state = plc
            .read_relay(RELAY)
            .await
            .unwrap_or_else(|e| panic!("read R3A: {e:?}"));
        assert_eq!(state, on, "R3A read back");
        let storage = peer.storage.lock().unwrap();
        assert_eq!(storage.coils[usize::from(RELAY_COIL_BASE + RELAY)], on);
    }
    assert!(!plc.read_relay(RELAY + 1).await.expect("read R3B"));

    // The peer holds DT0..DT9999: a read across its end is a refusal, not a link failure.
    let held = peer.storage.lock().unwrap().holdings.len();
    assert_eq!(held, usize::from(SERVER_REGISTERS));
    let past = plc.read_words(SERVER_REGISTERS - 5, 10).await;
    assert_refused(past, 2, "a read past the server's registers");
    let again = plc
        .read_words(start, 2)
        .await
        .expect("read after the exception");
    assert_eq!(again, words[..2]);
}

#[tokio::test]
async fn linterpd_client_round_trips_with_an_rmodbus_tcp_server() {
    let peer = Peer::new(None);
    let (stream, server) = peer.serve_tcp().await;
    let mut options = options(ModbusFraming::Tcp);
    options.max_write_registers = RMODBUS_TCP_MAX_WRITE;
    let mut plc = ModbusClient::new(stream, options);
    round_trip(&mut plc, &peer).await;
    assert_eq!(plc.reattach_count(), 0, "no call should have failed");
    assert_eq!(peer.writes(), [121, 121, 58]);
    drop(plc);
    ended(server).await.expect("the server should end cleanly");
}

#[tokio::test]
async fn linterpd_default_write_is_past_what_rmodbus_frames_over_tcp() {
    let peer = Peer::new(None);
    let (stream, server) = peer.serve_tcp().await;
    let mut plc = ModbusClient::new(stream, options(ModbusFraming::Tcp));
    let words = pattern(0, MAX_WRITE_REGISTERS);
    let e = plc.write_words(0, &words).await.unwrap_err();
    assert!(e.is_link_failure(), "{e:?}");
    let refused = ended(server).await.unwrap_err();
    assert_eq!(refused.kind(), io::ErrorKind::InvalidData, "{refused}");
    assert_eq!(refused.to_string(), ErrorKind::FrameBroken.to_string());
    assert!(peer.writes().is_empty(), "rmodbus never parsed the write");
}

#[tokio::test]
async fn linterpd_client_round_trips_with_an_rmodbus_rtu_server_on_a_pty_pair() {
    let peer = Peer::new(None);
    let (port, server) = peer.serve_rtu();
    let mut plc = ModbusClient::new(port, options(ModbusFraming::Rtu));
    round_trip(&mut plc, &peer).await;
    assert_eq!(plc.reattach_count(), 0, "no call should have failed");
    assert_eq!(peer.writes(), [123, 123, 54], "the default write size");
    drop(plc);
    ended(server).await.expect("the server should end cleanly");
}

#[tokio::test]
async fn peer_taking_100_registers_a_write_needs_the_configured_write_size() {
    let peer = Peer::new(Some(NARROW_MAX_WRITE));
    let (port, server) = peer.serve_rtu();
    let mut plc = ModbusClient::new(port, options(ModbusFraming::Rtu));
    let start = Layout::default().table_base;
    let words = pattern(start, ROUND_TRIP_WORDS);

    let refused = plc.write_words(start, &words).await;
    assert_refused(
        refused,
        3,
        "a write of 123 registers to a 100-register peer",
    );
    assert_eq!(
        peer.writes(),
        [123],
        "the first request is refused, no more sent"
    );
    assert_eq!(peer.holdings(start, 1), [0], "nothing written");
    drop(plc);
    ended(server).await.expect("the server should end cleanly");

    let (port, server) = peer.serve_rtu();
    let mut options = options(ModbusFraming::Rtu);
    options.max_write_registers = NARROW_MAX_WRITE;
    let mut plc = ModbusClient::new(port, options);
    plc.write_words(start, &words)
        .await
        .unwrap_or_else(|e| panic!("write in requests of 100: {e:?}"));
    assert_eq!(
        plc.read_words(start, ROUND_TRIP_WORDS).await.unwrap(),
        words
    );
    assert_eq!(peer.writes(), [123, 100, 100, 100]);
    assert_eq!(peer.holdings(start, ROUND_TRIP_WORDS), words);
    drop(plc);
    ended(server).await.expect("the server should end cleanly");
}

// ---------------------------------------------------------------------------------------------
// An rmodbus client against the mock
// ---------------------------------------------------------------------------------------------

/// rmodbus's request builder and response parser over `stream`.
struct RmodbusClient<S> {
    stream: S,
    request: ModbusRequest,
}

impl<S: AsyncRead + AsyncWrite + Unpin> RmodbusClient<S> {
    fn new(stream: S, unit: u8, proto: ModbusProto) -> Self {
        Self {
            stream,
            request: ModbusRequest::new(unit, proto),
        }
    }

    /// Sends `frame` and reads the reply within [`WAIT`]; a link failure fails the test.
    async fn exchange(&mut self, frame: &[u8]) -> Vec<u8> {
        let proto = self.request.proto;
        let stream = &mut self.stream;
        let reply = async {
            stream.write_all(frame).await?;
            read_frame(stream, proto, guess_response_frame_len).await
        };
        tokio::time::timeout(WAIT, reply)
            .await
            .unwrap_or_else(|_| panic!("no reply to {frame:02x?} within {WAIT:?}"))
            .unwrap_or_else(|e| panic!("exchange of {frame:02x?} failed: {e}"))
    }

    /// A fresh transaction id for TCP, so a stale reply cannot pass.
    fn next_transaction(&mut self) {
        self.request.tr_id = self.request.tr_id.wrapping_add(1);
    }

    async fn read_holdings(&mut self, start: u16, count: u16) -> Result<Vec<u16>, ErrorKind> {
        let mut frame = Vec::new();
        let mut words = Vec::new();
        for offset in (0..count).step_by(usize::from(CLIENT_CHUNK)) {
            self.next_transaction();
            let n = (count - offset).min(CLIENT_CHUNK);
            self.request
                .generate_get_holdings(start + offset, n, &mut frame)?;
            let reply = self.exchange(&frame).await;
            // parse_u16 stops once its output holds `count` words, so each reply gets its own.
            let mut chunk = Vec::new();
            self.request.parse_u16(&reply, &mut chunk)?;
            words.extend(chunk);
        }
        Ok(words)
    }

    async fn write_holdings(&mut self, start: u16, words: &[u16]) -> Result<(), ErrorKind> {
        let mut frame = Vec::new();
        for (index, chunk) in words.chunks(usize::from(CLIENT_CHUNK)).enumerate() {
            self.next_transaction();
            let at = start + (index * usize::from(CLIENT_CHUNK)) as u16;
            self.request
                .generate_set_holdings_bulk(at, chunk, &mut frame)?;
            let reply = self.exchange(&frame).await;
            self.request.parse_ok(&reply)?;
        }
        Ok(())
    }

    async fn write_coil(&mut self, coil: u16, on: bool) -> Result<(), ErrorKind> {
        let mut frame = Vec::new();
        self.next_transaction();
        self.request.generate_set_coil(coil, on, &mut frame)?;
        let reply = self.exchange(&frame).await;
        self.request.parse_ok(&reply)
    }

    async fn read_coil(&mut self, coil: u16) -> Result<bool, ErrorKind> {
        let mut frame = Vec::new();
        self.next_transaction();
        self.request.generate_get_coils(coil, 1, &mut frame)?;
        let reply = self.exchange(&frame).await;
        let mut bits = Vec::new();
        self.request.parse_bool(&reply, &mut bits)?;
        Ok(bits[0])
    }
}

fn shared_mock() -> SharedMock {
    SharedMock::new(MockPlc::new(MockConfig::default()).expect("a default mock"))
}

fn mock_options(unit: u8) -> ModbusServerOptions {
    ModbusServerOptions {
        unit: StationFilter::Only(unit),
        ..ModbusServerOptions::default()
    }
}

/// The status block's magic and version, 300 registers in a table area written and read back
/// (and seen by the mock), a relay through its coil, and exception 02 past DT32764.
async fn mock_checks<S: AsyncRead + AsyncWrite + Unpin>(
    client: &mut RmodbusClient<S>,
    mock: &SharedMock,
) {
    let layout = Layout::default();
    let status_words = client
        .read_holdings(layout.status_base, STATUS_WORDS as u16)
        .await
        .expect("read the status block");
    let status = StatusBlock::from_words(&status_words).expect("a whole status block");
    assert_eq!(
        (status.magic, status.version),
        (MAGIC, VERSION),
        "{status:?}"
    );

    let start = layout.table_base;
    let words = pattern(start, ROUND_TRIP_WORDS);
    client
        .write_holdings(start, &words)
        .await
        .expect("write a table area");
    let read = client
        .read_holdings(start, ROUND_TRIP_WORDS)
        .await
        .expect("read the table area back");
    assert_eq!(read, words);
    let stored = mock.with(|m| m.read_words(u32::from(start), usize::from(ROUND_TRIP_WORDS)));
    assert_eq!(stored.expect("the mock's memory"), words);

    let coil = RELAY_COIL_BASE + RELAY;
    for on in [true, false] {
        client.write_coil(coil, on).await.expect("write R3A's coil");
        assert_eq!(client.read_coil(coil).await, Ok(on), "R3A's coil");
    }

    let last = client.read_holdings(DT_LAST, 1).await;
    assert_eq!(last.map(|w| w.len()), Ok(1), "DT32764 is the last word");
    for (start, count) in [(DT_LAST + 1, 1), (DT_LAST, 2)] {
        let past = client.read_holdings(start, count).await;
        assert_eq!(
            past,
            Err(ErrorKind::IllegalDataAddress),
            "DT{start} x {count}"
        );
    }
    let past = client.write_holdings(DT_LAST, &[1, 2]).await;
    assert_eq!(
        past,
        Err(ErrorKind::IllegalDataAddress),
        "write across DT32764"
    );
    let again = client.read_holdings(start, 2).await;
    assert_eq!(
        again.as_deref(),
        Ok(&words[..2]),
        "read after the exceptions"
    );
}

#[tokio::test]
async fn rmodbus_client_round_trips_with_the_mock_over_tcp() {
    let mock = shared_mock();
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let server = ModbusServer::new(mock.clone(), mock_options(UNIT));
    let serving = tokio::spawn(server.serve_tcp(listener));
    let stream = tokio::time::timeout(WAIT, TcpStream::connect(address))
        .await
        .expect("connect in time")
        .unwrap_or_else(|e| panic!("connect to the mock at {address}: {e}"));
    let mut client = RmodbusClient::new(stream, UNIT, ModbusProto::TcpUdp);
    mock_checks(&mut client, &mock).await;
    serving.abort();
}

#[tokio::test]
async fn rmodbus_client_round_trips_with_the_mock_over_rtu_on_a_pty_pair() {
    let mock = shared_mock();
    let (ours, theirs) = SerialStream::pair().expect("a pseudo-terminal pair");
    let unit = 7;
    let server = ModbusServer::new(mock.clone(), mock_options(unit));
    let serving = tokio::spawn(server.serve_rtu(theirs));
    let mut client = RmodbusClient::new(ours, unit, ModbusProto::Rtu);
    mock_checks(&mut client, &mock).await;
    serving.abort();
}

#[test]
fn rmodbus_tcp_limits_are_what_the_module_says() {
    let peer = Peer::new(None);
    let tcp = ModbusProto::TcpUdp;
    let mut request = ModbusRequest::new(UNIT, tcp);
    let mut frame = Vec::new();
    for (n, framed) in [
        (RMODBUS_TCP_MAX_WRITE, true),
        (RMODBUS_TCP_MAX_WRITE + 1, false),
    ] {
        let words = vec![0; usize::from(n)];
        request
            .generate_set_holdings_bulk(0, &words, &mut frame)
            .unwrap();
        let guessed = guess_request_frame_len(&frame, tcp);
        assert_eq!(guessed.is_ok(), framed, "a write of {n}: {guessed:?}");
        let answered = peer.answer(&frame, tcp);
        assert_eq!(answered.is_ok(), framed, "a write of {n}: {answered:?}");
    }
    for (n, framed) in [
        (RMODBUS_TCP_MAX_READ, true),
        (RMODBUS_TCP_MAX_READ + 1, false),
    ] {
        request.generate_get_holdings(0, n, &mut frame).unwrap();
        let reply = peer.answer(&frame, tcp).unwrap().expect("a reply");
        let guessed = guess_response_frame_len(&reply, tcp);
        assert_eq!(guessed.is_ok(), framed, "a read reply of {n}: {guessed:?}");
    }
}
