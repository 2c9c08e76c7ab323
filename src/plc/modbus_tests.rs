//! The Modbus client against tokio-modbus's own server side: Modbus TCP and RTU-over-TCP servers
//! bound to port 0, and the RTU server on a pseudo-terminal. (tokio-modbus serves only a
//! `TcpListener` or a `SerialStream`, so there is no server over `tokio::io::duplex`.)

use std::future::Future;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::{Arc, Mutex};

use tokio::net::{TcpListener, TcpStream};
use tokio::sync::Notify;
use tokio_modbus::server::{Service, rtu_over_tcp, tcp as tcp_server};

use super::*;
use crate::plc::settings::R9020;

/// Registers the fake holds: fewer than the FP-X's, so a read past them is an exception.
const REGISTERS: usize = 20_000;
/// A read of this register is answered only once the test opens the gate.
const HELD: u16 = 7_000;

#[derive(Debug)]
struct Bank {
    registers: Vec<u16>,
    coils: Vec<bool>,
    requests: Vec<String>,
}

#[derive(Debug, Clone)]
struct Memory {
    bank: Arc<Mutex<Bank>>,
    gate: Arc<Notify>,
}

impl Memory {
    fn new() -> Self {
        let bank = Bank {
            registers: vec![0; REGISTERS],
            coils: vec![false; 2048 + 16_000],
            requests: Vec::new(),
        };
        Self {
            bank: Arc::new(Mutex::new(bank)),
            gate: Arc::new(Notify::new()),
        }
    }

    fn answer(&self, request: &Request<'static>) -> Result<Response, ExceptionCode> {
        let mut bank = self.bank.lock().unwrap();
        bank.requests.push(format!("{request:?}"));
        let span = |start: u16, n: usize| {
            let s = usize::from(start);
            (s + n <= REGISTERS)
                .then_some(s..s + n)
                .ok_or(ExceptionCode::IllegalDataAddress)
        };
        match request {
            Request::ReadHoldingRegisters(start, n) => {
                let range = span(*start, usize::from(*n))?;
                Ok(Response::ReadHoldingRegisters(
                    bank.registers[range].to_vec(),
                ))
            }
            Request::WriteMultipleRegisters(start, words) => {
                let range = span(*start, words.len())?;
                bank.registers[range].copy_from_slice(words);
                Ok(Response::WriteMultipleRegisters(*start, words.len() as u16))
            }
            Request::ReadCoils(coil, 1) => {
                Ok(Response::ReadCoils(vec![bank.coils[usize::from(*coil)]]))
            }
            Request::WriteSingleCoil(coil, on) => {
                bank.coils[usize::from(*coil)] = *on;
                Ok(Response::WriteSingleCoil(*coil, *on))
            }
            _ => Err(ExceptionCode::IllegalFunction),
        }
    }

    fn count(&self, prefix: &str) -> usize {
        let bank = self.bank.lock().unwrap();
        bank.requests
            .iter()
            .filter(|r| r.starts_with(prefix))
            .count()
    }
}

type Answer = Pin<Box<dyn Future<Output = Result<Response, ExceptionCode>> + Send>>;

impl Service for Memory {
    type Request = Request<'static>;
    type Response = Response;
    type Exception = ExceptionCode;
    type Future = Answer;

    fn call(&self, request: Request<'static>) -> Answer {
        let memory = self.clone();
        Box::pin(async move {
            if matches!(request, Request::ReadHoldingRegisters(HELD, _)) {
                memory.gate.notified().await;
            }
            memory.answer(&request)
        })
    }
}

async fn listener() -> (TcpListener, SocketAddr) {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    (listener, address)
}

/// A Modbus TCP server on port 0 serving `memory`.
async fn serve_tcp(memory: &Memory) -> SocketAddr {
    serve(memory, ModbusFraming::Tcp).await
}

/// A Modbus RTU server (RTU frames, no transaction id) over TCP on port 0 serving `memory`.
async fn serve_rtu(memory: &Memory) -> SocketAddr {
    serve(memory, ModbusFraming::Rtu).await
}

/// A server on port 0 serving `memory` in `framing` over TCP.
async fn serve(memory: &Memory, framing: ModbusFraming) -> SocketAddr {
    let (listener, address) = listener().await;
    let memory = memory.clone();
    tokio::spawn(async move {
        let on_connected = move |stream: TcpStream, _| {
            let service = memory.clone();
            async move { Ok(Some((service, stream))) }
        };
        let _ = match framing {
            ModbusFraming::Tcp => {
                tcp_server::Server::new(listener)
                    .serve(&on_connected, |_| {})
                    .await
            }
            ModbusFraming::Rtu => {
                rtu_over_tcp::Server::new(listener)
                    .serve(&on_connected, |_| {})
                    .await
            }
        };
    });
    address
}

async fn client(address: SocketAddr, framing: ModbusFraming) -> ModbusClient<TcpStream> {
    let stream = TcpStream::connect(address).await.unwrap();
    let mut options = ModbusOptions::new(framing, 1);
    options.timeout = Duration::from_secs(5);
    ModbusClient::new(stream, options)
}

fn ramp(n: u16) -> Vec<u16> {
    (0..n).map(|i| i.wrapping_mul(31) ^ 0xA5A5).collect()
}

#[tokio::test]
async fn tcp_writes_300_registers_in_3_requests_and_reads_them_back() {
    let memory = Memory::new();
    let mut plc = client(serve_tcp(&memory).await, ModbusFraming::Tcp).await;
    plc.write_words(2_000, &ramp(300)).await.unwrap();
    assert_eq!(plc.read_words(2_000, 300).await.unwrap(), ramp(300));
    assert_eq!(
        memory.bank.lock().unwrap().registers[2_000..2_300],
        ramp(300)[..]
    );
    assert_eq!(memory.count("WriteMultipleRegisters"), 3); // 123 + 123 + 54
    assert_eq!(memory.count("ReadHoldingRegisters"), 3); // 125 + 125 + 50
}

#[tokio::test]
async fn rtu_round_trip_of_300_registers() {
    let memory = Memory::new();
    let mut plc = client(serve_rtu(&memory).await, ModbusFraming::Rtu).await;
    plc.write_words(10_000, &ramp(300)).await.unwrap();
    assert_eq!(plc.read_words(10_000, 300).await.unwrap(), ramp(300));
}

/// A TCP client whose requests carry at most `max_write` and ask for at most `max_read` registers.
async fn sized_client(memory: &Memory, max_write: u16, max_read: u16) -> ModbusClient<TcpStream> {
    let stream = TcpStream::connect(serve_tcp(memory).await).await.unwrap();
    let mut options = ModbusOptions::new(ModbusFraming::Tcp, 1);
    options.timeout = Duration::from_secs(5);
    (options.max_write_registers, options.max_read_registers) = (max_write, max_read);
    ModbusClient::new(stream, options)
}

#[tokio::test]
async fn configured_request_sizes_split_reads_and_writes() {
    let memory = Memory::new();
    let mut plc = sized_client(&memory, 100, 60).await;
    plc.write_words(2_000, &ramp(250)).await.unwrap();
    assert_eq!(plc.read_words(2_000, 250).await.unwrap(), ramp(250));
    assert_eq!(memory.count("WriteMultipleRegisters(2000,"), 1);
    assert_eq!(memory.count("WriteMultipleRegisters(2100,"), 1);
    assert_eq!(memory.count("WriteMultipleRegisters"), 3); // 100 + 100 + 50
    assert_eq!(memory.count("ReadHoldingRegisters(2240, 10)"), 1);
    assert_eq!(memory.count("ReadHoldingRegisters"), 5); // 4 x 60 + 10
}

#[tokio::test]
async fn request_sizes_outside_the_spec_are_taken_as_its_bounds() {
    let memory = Memory::new();
    let mut plc = sized_client(&memory, 0, 1_000).await;
    plc.write_words(2_000, &ramp(3)).await.unwrap();
    assert_eq!(memory.count("WriteMultipleRegisters"), 3); // 0 is taken as 1
    plc.read_words(2_000, 300).await.unwrap();
    assert_eq!(memory.count("ReadHoldingRegisters"), 3); // 125 + 125 + 50
}

#[test]
fn options_from_settings_carry_the_request_sizes() {
    let tcp = crate::plc::TcpSettings {
        address: "127.0.0.1:502".into(),
        connect_timeout: Duration::from_secs(1),
    };
    let mut settings = LinkSettings::new(Protocol::ModbusTcp, crate::plc::Transport::Tcp(tcp));
    let defaults = ModbusOptions::from_settings(&settings);
    assert_eq!(
        (defaults.max_write_registers, defaults.max_read_registers),
        (123, 125)
    );
    (settings.modbus_max_write, settings.modbus_max_read) = (100, 64);
    let options = ModbusOptions::from_settings(&settings);
    assert_eq!(
        (options.max_write_registers, options.max_read_registers),
        (100, 64)
    );
}

#[tokio::test]
async fn relays_map_to_coils_from_2048() {
    let memory = Memory::new();
    let mut plc = client(serve_tcp(&memory).await, ModbusFraming::Tcp).await;
    let r12a = 12 * 16 + 0xA;
    plc.write_relay(r12a, true).await.unwrap();
    assert!(plc.read_relay(r12a).await.unwrap());
    assert!(memory.bank.lock().unwrap().coils[2048 + usize::from(r12a)]);
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Prog);
    memory.bank.lock().unwrap().coils[usize::from(2048 + R9020)] = true;
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
}

#[tokio::test]
async fn exception_becomes_a_refusal_and_is_not_retried() {
    let memory = Memory::new();
    let mut plc = client(serve_tcp(&memory).await, ModbusFraming::Tcp).await;
    let e = plc.read_words(19_990, 20).await.unwrap_err();
    let PlcError::Refused { refusal, .. } = &e else {
        panic!("{e:?}")
    };
    assert_eq!(
        *refusal,
        Refusal::Modbus {
            code: 2,
            meaning: "illegal data address"
        }
    );
    assert_eq!(memory.count("ReadHoldingRegisters"), 1);
    assert_eq!(
        plc.reattach_count(),
        0,
        "an exception leaves the link as it is"
    );
}

#[tokio::test]
async fn range_past_dt32764_is_refused_before_sending() {
    let memory = Memory::new();
    let mut plc = client(serve_tcp(&memory).await, ModbusFraming::Tcp).await;
    let e = plc.write_words(32_760, &[0; 10]).await.unwrap_err();
    assert!(matches!(e, PlcError::InvalidRequest { .. }), "{e:?}");
    assert_eq!(memory.count("Write"), 0);
}

#[tokio::test]
async fn rtu_late_reply_after_a_timeout_is_not_taken_for_the_next_answer() {
    let memory = Memory::new();
    memory.bank.lock().unwrap().registers[usize::from(HELD)] = 0xDEAD;
    memory.bank.lock().unwrap().registers[100] = 0x0001;
    let stream = TcpStream::connect(serve_rtu(&memory).await).await.unwrap();
    let mut options = ModbusOptions::new(ModbusFraming::Rtu, 1);
    (options.timeout, options.retries) = (Duration::from_millis(100), 0);
    let mut plc = ModbusClient::new(stream, options);

    let e = plc.read_words(HELD, 1).await.unwrap_err();
    assert!(matches!(e, PlcError::Timeout { .. }), "{e:?}");
    memory.gate.notify_one(); // the server now sends its late 0xDEAD reply

    assert_eq!(plc.read_words(100, 1).await.unwrap(), [0x0001]);
    assert_eq!(plc.reattach_count(), 1);
    assert_eq!(plc.read_words(100, 1).await.unwrap(), [0x0001]);
}

#[tokio::test]
async fn rtu_over_a_pseudo_terminal() {
    let (ours, theirs) = tokio_serial::SerialStream::pair().unwrap();
    let memory = Memory::new();
    let server = tokio_modbus::server::rtu::Server::new(theirs);
    tokio::spawn(server.serve_forever(memory.clone()));
    let mut options = ModbusOptions::new(ModbusFraming::Rtu, 1);
    options.timeout = Duration::from_secs(5);
    let mut plc = ModbusClient::new(ours, options);
    plc.write_words(3_000, &ramp(40)).await.unwrap();
    assert_eq!(plc.read_words(3_000, 40).await.unwrap(), ramp(40));
}

#[test]
fn exception_meanings_follow_the_modbus_spec() {
    assert_eq!(exception_meaning(2), "illegal data address");
    assert_eq!(
        exception_meaning(0x0B),
        "gateway target device failed to respond"
    );
    assert_eq!(exception_meaning(0x7F), "unknown exception code");
}

#[tokio::test]
async fn connect_opens_modbus_tcp_from_settings() {
    let memory = Memory::new();
    let tcp = crate::plc::TcpSettings {
        address: serve_tcp(&memory).await.to_string(),
        connect_timeout: Duration::from_secs(5),
    };
    let mut settings = LinkSettings::new(Protocol::ModbusTcp, crate::plc::Transport::Tcp(tcp));
    settings.timeout = Duration::from_secs(5);
    let mut plc = crate::plc::connect(&settings).await.unwrap();
    assert!(matches!(plc, crate::plc::AnyPlc::Modbus(_)));
    plc.write_words(1_000, &[7, 8]).await.unwrap();
    assert_eq!(plc.read_words(1_000, 2).await.unwrap(), [7, 8]);
}

#[test]
fn an_rtu_call_at_19200_baud_waits_for_its_frames_two_scans_and_the_margin() {
    let mut options = ModbusOptions::new(ModbusFraming::Rtu, 1);
    options.char_time = Some(Duration::from_secs_f64(11.0 / 19_200.0));
    let (ours, _theirs) = tokio::io::duplex(64);
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let _guard = rt.enter();
    let client = ModbusClient::new(ours, options);
    // 125 registers: 8 bytes out, 255 back, each frame followed by its silence.
    let t = client.call_timeout(&Request::ReadHoldingRegisters(0, 125));
    let expected = (12.0 + 259.0) * 11.0 / 19_200.0 + 0.020 + 0.300;
    assert!((t.as_secs_f64() - expected).abs() < 1e-3, "{t:?}");
    // Over TCP (no line) only the scans and the margin.
    let tcp = ModbusClient::new(
        tokio::io::duplex(64).0,
        ModbusOptions::new(ModbusFraming::Tcp, 1),
    );
    assert_eq!(
        tcp.call_timeout(&Request::ReadHoldingRegisters(0, 125)),
        Duration::from_millis(320)
    );
}
