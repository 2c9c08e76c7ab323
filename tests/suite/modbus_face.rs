//! The register gateway's Modbus TCP face against an independent Modbus client (rmodbus's request
//! builder and response parser), with the daemon in process on the mock PLC: holding registers are
//! DT, coils Y and R, discrete inputs X; reads and writes land in the mock's memory; what the
//! access list does not allow (the contract's command block above all) is exception 02 and never
//! reaches the PLC; a link that is down is 0x0B; a client not allowed is closed at once.
//!
//! And once end to end: `linterpd serve` with `[robots.press-loader.gateway.modbus]` on a real
//! `linterpd mock-plc` starts the face, serves it, and ends it with the daemon.
//!
//! rmodbus 0.13 maps exception codes 0x0A and 0x0B to `UnknownError` (it matches 0x09 and 0x10),
//! so the tests read the exception code from the reply's PDU: the byte after the function code.

use crate::common;

use std::io;
use std::time::Duration;

use common::daemon::duplex_connector;
use common::exchange::mock_at_seed_start;
use linterpd::contract::Layout;
use linterpd::daemon::modbus_face::ModbusFaceServer;
use linterpd::daemon::{Connector, Daemon, DaemonOptions, RobotHandle, RobotSetup};
use linterpd::gateway::{AccessList, Area, GatewaySettings, ModbusFace, Range};
use linterpd::kinematics::JOINTS;
use linterpd::mock::SharedMock;
use linterpd::plc::exchange::ContractSettings;
use linterpd::robot::seed_robot;
use rmodbus::client::ModbusRequest;
use rmodbus::{ErrorKind, ModbusProto, guess_response_frame_len};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio_util::sync::CancellationToken;

/// Longest wait for one exchange.
const WAIT: Duration = Duration::from_secs(5);
/// Coil of R0 (coils from 2048 are R).
const R_COILS: u16 = 2048;

fn ranges(texts: &[&str]) -> Vec<Range> {
    texts.iter().map(|t| t.parse().unwrap()).collect()
}

/// Reads DT0-DT999 and the status block, X0-X1F, Y0-YF; writes DT100-DT199, Y0-Y7, R10-R1F.
fn access() -> AccessList {
    AccessList::new(
        ranges(&["DT0-DT999", "DT1000-DT1021", "X0-X1F", "Y0-YF"]),
        ranges(&["DT100-DT199", "Y0-Y7", "R10-R1F"]),
        &Layout::default(),
    )
    .unwrap()
}

/// The daemon on `connect` and its Modbus face on 127.0.0.1:0 admitting `allow` (loopback
/// without), until the token is cancelled.
struct Faced {
    daemon: Daemon,
    handle: RobotHandle,
    address: std::net::SocketAddr,
    stop: CancellationToken,
    served: tokio::task::JoinHandle<io::Result<()>>,
}

async fn start(connect: Connector, allow: &[&str]) -> Faced {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let face = ModbusFace {
        listen: listener.local_addr().unwrap(),
        allow: allow.iter().map(|a| a.parse().unwrap()).collect(),
    };
    let setup = RobotSetup {
        robot: seed_robot(),
        settings: ContractSettings::default(),
        connect,
        home_counts: [0; JOINTS],
        cell: linterpd::config::CellSettings::default(),
        gateway: GatewaySettings {
            access: access(),
            modbus: Some(face.clone()),
        },
    };
    let daemon = Daemon::spawn(vec![setup], &DaemonOptions::default());
    let handle = daemon.robot("press-loader").unwrap().clone();
    let server = ModbusFaceServer::on(listener, &face);
    let address = server.local_addr().unwrap();
    let stop = CancellationToken::new();
    let until = stop.clone().cancelled_owned();
    let served = tokio::spawn(server.serve(handle.clone(), until));
    Faced {
        daemon,
        handle,
        address,
        stop,
        served,
    }
}

async fn wait_connected(h: &RobotHandle) {
    for _ in 0..500 {
        let s = h.state();
        if s.link.connected && s.counts.is_some() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("never connected: {:?}", h.state());
}

/// rmodbus's requests and replies over one TCP connection.
struct Client {
    stream: TcpStream,
    request: ModbusRequest,
}

/// What a request came back with: rmodbus's parse of a normal reply, or an exception code.
type Outcome<T> = Result<T, u8>;

impl Client {
    async fn connect(address: std::net::SocketAddr) -> Self {
        Self {
            stream: TcpStream::connect(address).await.unwrap(),
            request: ModbusRequest::new(1, ModbusProto::TcpUdp),
        }
    }

    /// Sends `frame` and reads one reply frame (or how the connection ended).
    async fn exchange(&mut self, frame: &[u8]) -> io::Result<Vec<u8>> {
        let stream = &mut self.stream;
        let reply = async {
            stream.write_all(frame).await?;
            let mut reply = vec![0; 6];
            stream.read_exact(&mut reply).await?;
            let len = guess_response_frame_len(&reply, ModbusProto::TcpUdp)
                .map_err(|e| io::Error::new(io::ErrorKind::InvalidData, e))?;
            reply.resize(usize::from(len), 0);
            stream.read_exact(&mut reply[6..]).await?;
            Ok(reply)
        };
        tokio::time::timeout(WAIT, reply)
            .await
            .unwrap_or_else(|_| panic!("no reply to {frame:02x?} within {WAIT:?}"))
    }

    /// The reply to the request `build` makes, parsed by `parse` unless it is an exception.
    async fn call<T>(
        &mut self,
        build: impl FnOnce(&mut ModbusRequest, &mut Vec<u8>) -> Result<(), ErrorKind>,
        parse: impl FnOnce(&ModbusRequest, &[u8]) -> Result<T, ErrorKind>,
    ) -> Outcome<T> {
        let mut frame = Vec::new();
        self.request.tr_id = self.request.tr_id.wrapping_add(1);
        build(&mut self.request, &mut frame).unwrap();
        let reply = self.exchange(&frame).await.expect("a reply");
        // MBAP (7 bytes), then the function code; an exception sets its high bit.
        if reply[7] & 0x80 != 0 {
            return Err(reply[8]);
        }
        Ok(parse(&self.request, &reply).expect("rmodbus parses the reply"))
    }

    async fn read_holdings(&mut self, start: u16, n: u16) -> Outcome<Vec<u16>> {
        self.call(
            |r, f| r.generate_get_holdings(start, n, f),
            |r, reply| {
                let mut out = Vec::new();
                r.parse_u16(reply, &mut out).map(|()| out)
            },
        )
        .await
    }

    async fn read_inputs(&mut self, start: u16, n: u16) -> Outcome<Vec<u16>> {
        self.call(
            |r, f| r.generate_get_inputs(start, n, f),
            |r, reply| {
                let mut out = Vec::new();
                r.parse_u16(reply, &mut out).map(|()| out)
            },
        )
        .await
    }

    async fn write_holdings(&mut self, start: u16, words: &[u16]) -> Outcome<()> {
        self.call(
            |r, f| r.generate_set_holdings_bulk(start, words, f),
            ModbusRequest::parse_ok,
        )
        .await
    }

    async fn write_holding(&mut self, at: u16, word: u16) -> Outcome<()> {
        self.call(
            |r, f| r.generate_set_holding(at, word, f),
            ModbusRequest::parse_ok,
        )
        .await
    }

    async fn read_coils(&mut self, start: u16, n: u16) -> Outcome<Vec<bool>> {
        self.call(
            |r, f| r.generate_get_coils(start, n, f),
            |r, reply| {
                let mut out = Vec::new();
                r.parse_bool(reply, &mut out).map(|()| out)
            },
        )
        .await
    }

    async fn read_discretes(&mut self, start: u16, n: u16) -> Outcome<Vec<bool>> {
        self.call(
            |r, f| r.generate_get_discretes(start, n, f),
            |r, reply| {
                let mut out = Vec::new();
                r.parse_bool(reply, &mut out).map(|()| out)
            },
        )
        .await
    }

    async fn write_coil(&mut self, coil: u16, on: bool) -> Outcome<()> {
        self.call(
            |r, f| r.generate_set_coil(coil, on, f),
            ModbusRequest::parse_ok,
        )
        .await
    }

    async fn write_coils(&mut self, coil: u16, bits: &[bool]) -> Outcome<()> {
        self.call(
            |r, f| r.generate_set_coils_bulk(coil, bits, f),
            ModbusRequest::parse_ok,
        )
        .await
    }
}

fn words(shared: &SharedMock, start: u32, count: usize) -> Vec<u16> {
    shared.with(|m| m.read_words(start, count).unwrap())
}

#[tokio::test]
async fn reads_and_writes_land_in_the_plcs_memory() {
    let shared = mock_at_seed_start("");
    shared.with(|m| {
        m.write_words(0, &(0..200).map(|i| i * 7).collect::<Vec<_>>())
            .unwrap();
        m.set_input(0x13, true).unwrap(); // X13
    });
    let f = start(duplex_connector(&shared, None), &[]).await;
    wait_connected(&f.handle).await;
    let mut client = Client::connect(f.address).await;

    let expected: Vec<u16> = (0..100).map(|i| i * 7).collect();
    assert_eq!(client.read_holdings(0, 100).await, Ok(expected.clone()));
    assert_eq!(
        client.read_inputs(0, 10).await,
        Ok(expected[..10].to_vec()),
        "input registers are DT too"
    );

    let written: Vec<u16> = (0..50).map(|i| 40_000 + i).collect();
    assert_eq!(client.write_holdings(120, &written).await, Ok(()));
    assert_eq!(client.write_holding(199, 0xBEEF).await, Ok(()));
    assert_eq!(words(&shared, 120, 50), written);
    assert_eq!(
        words(&shared, 119, 1),
        [119 * 7],
        "the word before is untouched"
    );
    assert_eq!(words(&shared, 199, 1), [0xBEEF]);
    assert_eq!(
        client.read_holdings(120, 2).await,
        Ok(written[..2].to_vec())
    );

    // Coils: R10 is coil 2048 + 0x10; Y3 is coil 3. Inputs: X13 is input 0x13.
    assert_eq!(client.write_coil(R_COILS + 0x10, true).await, Ok(()));
    assert_eq!(
        client.write_coils(R_COILS + 0x1E, &[true, true]).await,
        Ok(())
    );
    assert_eq!(client.write_coil(3, true).await, Ok(()));
    shared.with(|m| {
        assert!(m.read_bit(Area::R, 0x10).unwrap(), "R10");
        assert!(!m.read_bit(Area::R, 0x11).unwrap(), "R11");
        assert!(m.read_bit(Area::R, 0x1E).unwrap() && m.read_bit(Area::R, 0x1F).unwrap());
        assert!(m.read_bit(Area::Y, 3).unwrap(), "Y3");
    });
    let coils = client.read_coils(R_COILS + 0x10, 2).await.unwrap();
    assert_eq!(&coils[..2], [true, false]);
    let inputs = client.read_discretes(0x12, 2).await.unwrap();
    assert_eq!(&inputs[..2], [false, true]);

    let stats = f.handle.state().gateway;
    assert_eq!(stats.failed, 0, "{stats:?}");
    assert!(
        stats.requests >= 10,
        "each request went through the gateway: {stats:?}"
    );

    // The face ends with its token; the client's connection with it.
    f.stop.cancel();
    f.served.await.unwrap().unwrap();
    let mut byte = [0; 1];
    let end = tokio::time::timeout(WAIT, client.stream.read(&mut byte)).await;
    assert!(
        matches!(end, Ok(Ok(0) | Err(_))),
        "the connection is closed: {end:?}"
    );
    f.daemon.shut_down().await;
}

#[tokio::test]
async fn what_the_list_does_not_allow_is_exception_02_and_never_reaches_the_plc() {
    let shared = mock_at_seed_start("");
    let f = start(duplex_connector(&shared, None), &[]).await;
    wait_connected(&f.handle).await;
    let mut client = Client::connect(f.address).await;
    let command_block = words(&shared, 1_032, 17);
    let exchanges = f.handle.state().gateway.exchanges;

    // The contract's command block: never writable through the gateway, whatever the list.
    assert_eq!(client.write_holdings(1_032, &[1, 2, 3]).await, Err(0x02));
    assert_eq!(client.write_holding(1_032, 1).await, Err(0x02));
    // The status block is readable (listed) but not writable.
    assert_eq!(client.write_holding(1_000, 1).await, Err(0x02));
    // Half inside the writable range, half out; outside the read list.
    assert_eq!(client.write_holdings(190, &[7; 20]).await, Err(0x02));
    assert_eq!(client.read_holdings(2_000, 1).await, Err(0x02));
    // Y8 is readable, not writable; R20 is in no list; X is read-only by function.
    assert_eq!(client.write_coil(8, true).await, Err(0x02));
    assert_eq!(client.write_coil(R_COILS + 0x20, true).await, Err(0x02));
    // A request spanning Y and R.
    assert_eq!(client.read_coils(R_COILS - 8, 16).await, Err(0x02));
    // Bad counts.
    assert_eq!(client.read_holdings(0, 126).await, Err(0x03));
    assert_eq!(client.read_coils(0, 2001).await, Err(0x03));

    assert_eq!(words(&shared, 1_032, 17), command_block);
    assert_eq!(words(&shared, 190, 20), vec![0; 20]);
    shared.with(|m| {
        assert!(!m.read_bit(Area::Y, 8).unwrap());
        assert!(!m.read_bit(Area::R, 0x20).unwrap());
    });
    assert_eq!(
        f.handle.state().gateway.exchanges,
        exchanges,
        "nothing refused was sent to the PLC"
    );
    // The connection goes on after exceptions.
    assert!(client.read_holdings(0, 1).await.is_ok());
    f.daemon.shut_down().await;
}

/// A raw Write Multiple Registers (16) frame of `n` words from `start`, transaction `tr`, with
/// the byte count a client would send (its low byte past 127 words): rmodbus refuses to build
/// one over the limit.
fn raw_write_registers(tr: u16, start: u16, n: u16) -> Vec<u8> {
    let values = usize::from(n) * 2;
    let mut frame = tr.to_be_bytes().to_vec();
    frame.extend_from_slice(&[0, 0]); // protocol 0
    frame.extend_from_slice(&((7 + values) as u16).to_be_bytes()); // unit + PDU
    frame.push(1); // unit
    frame.push(0x10);
    frame.extend_from_slice(&start.to_be_bytes());
    frame.extend_from_slice(&n.to_be_bytes());
    frame.push(values as u8);
    frame.extend(std::iter::repeat_n(0x55, values));
    frame
}

/// A raw Write Multiple Coils (15) frame of `n` coils from `start`.
fn raw_write_coils(tr: u16, start: u16, n: u16) -> Vec<u8> {
    let bytes = usize::from(n).div_ceil(8);
    let mut frame = tr.to_be_bytes().to_vec();
    frame.extend_from_slice(&[0, 0]);
    frame.extend_from_slice(&((7 + bytes) as u16).to_be_bytes());
    frame.extend_from_slice(&[1, 0x0F]);
    frame.extend_from_slice(&start.to_be_bytes());
    frame.extend_from_slice(&n.to_be_bytes());
    frame.push(bytes as u8);
    frame.extend(std::iter::repeat_n(0, bytes));
    frame
}

#[tokio::test]
async fn a_write_over_the_modbus_quantity_limit_is_exception_03_and_the_connection_stays_open() {
    let shared = mock_at_seed_start("");
    let f = start(duplex_connector(&shared, None), &[]).await;
    wait_connected(&f.handle).await;
    let mut client = Client::connect(f.address).await;
    let before = words(&shared, 100, 100);
    let exchanges = f.handle.state().gateway.exchanges;
    for (tr, frame, function) in [
        (0x0701, raw_write_registers(0x0701, 100, 124), 0x10),
        (0x0702, raw_write_registers(0x0702, 100, 127), 0x10),
        (0x0703, raw_write_coils(0x0703, 0, 1_969), 0x0F),
        (0x0704, raw_write_coils(0x0704, 0, 2_000), 0x0F),
    ] {
        let reply = client
            .exchange(&frame)
            .await
            .expect("an answer, not a closed connection");
        // Its transaction, protocol 0, length 3, unit 1, the function with its high bit, 03.
        let [hi, lo] = u16::to_be_bytes(tr);
        assert_eq!(
            reply,
            [hi, lo, 0, 0, 0, 3, 1, 0x80 | function, 0x03],
            "{reply:02x?}"
        );
    }
    // Nothing reached the PLC, and the connection goes on.
    assert_eq!(f.handle.state().gateway.exchanges, exchanges);
    assert_eq!(words(&shared, 100, 100), before);
    assert_eq!(client.read_holdings(0, 1).await.map(|w| w.len()), Ok(1));
    // At the limit the write is decoded and judged by the access list (DT100-DT199 writable).
    let most: Vec<u16> = (0..123).collect();
    assert_eq!(client.write_holdings(100, &most).await, Err(0x02));
    assert_eq!(client.write_holdings(100, &most[..100]).await, Ok(()));
    assert_eq!(words(&shared, 100, 100), most[..100]);
    f.daemon.shut_down().await;
}

#[tokio::test]
async fn a_link_that_is_down_is_exception_0b() {
    let connect: Connector = Box::new(|| {
        Box::pin(async {
            Err(linterpd::plc::PlcError::Link {
                operation: "connect".into(),
                source: io::Error::new(io::ErrorKind::ConnectionRefused, "refused"),
            })
        })
    });
    let f = start(connect, &[]).await;
    let mut client = Client::connect(f.address).await;
    assert_eq!(client.read_holdings(0, 1).await, Err(0x0B));
    assert_eq!(client.write_coil(R_COILS + 0x10, true).await, Err(0x0B));
    f.daemon.shut_down().await;
}

#[tokio::test]
async fn a_client_not_allowed_is_closed_at_once() {
    let shared = mock_at_seed_start("");
    // An allow-list is the whole list: loopback is not on it.
    let f = start(
        duplex_connector(&shared, None),
        &["10.0.0.5", "10.0.1.0/24"],
    )
    .await;
    wait_connected(&f.handle).await;
    let mut client = Client::connect(f.address).await;
    let mut frame = Vec::new();
    client
        .request
        .generate_get_holdings(0, 1, &mut frame)
        .unwrap();
    let outcome = client.exchange(&frame).await;
    assert!(
        outcome.is_err(),
        "no reply, the connection closed: {outcome:?}"
    );
    assert_eq!(f.handle.state().gateway.requests, 0);

    // Listed, it is served.
    f.daemon.shut_down().await;
    let f = start(duplex_connector(&shared, None), &["127.0.0.1"]).await;
    wait_connected(&f.handle).await;
    let mut client = Client::connect(f.address).await;
    assert!(client.read_holdings(0, 1).await.is_ok());
    f.daemon.shut_down().await;
}

#[tokio::test]
async fn serve_starts_the_face_from_the_config_and_ends_it_with_the_daemon() {
    let gateway = "[robots.press-loader.gateway]\nread = [\"DT0-DT999\"]\n\
                   write = [\"DT100-DT199\"]\nmodbus = { listen = \"127.0.0.1:0\" }\n";
    let mut running = common::serve::start_with_config(&[], gateway);
    let line = running
        .serve
        .wait_for("the Modbus face's address", common::serve::READY, |out| {
            out.stderr
                .iter()
                .find(|l| l.contains("Modbus face listening"))
                .cloned()
        });
    let address: std::net::SocketAddr = without_ansi(&line)
        .split_whitespace()
        .find_map(|field| field.strip_prefix("listen="))
        .unwrap_or_else(|| panic!("no listen= in {line:?}"))
        .parse()
        .unwrap();
    let mut client = Client::connect(address).await;
    assert_eq!(client.write_holdings(100, &[11, 22, 33]).await, Ok(()));
    assert_eq!(client.read_holdings(100, 3).await, Ok(vec![11, 22, 33]));
    assert_eq!(
        client.write_holding(1_032, 1).await,
        Err(0x02),
        "the command block"
    );

    let status = running.serve.terminate(common::serve::READY);
    assert!(status.success(), "{status:?}");
    let mut byte = [0; 1];
    let end = tokio::time::timeout(WAIT, client.stream.read(&mut byte)).await;
    assert!(
        matches!(end, Ok(Ok(0) | Err(_))),
        "the connection ended with the daemon: {end:?}"
    );
    assert!(
        TcpStream::connect(address).await.is_err(),
        "nothing listens any more"
    );
}

/// `line` without ANSI colour sequences (`ESC [ ... m`), whether or not the log has them.
fn without_ansi(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            chars.by_ref().find(|c| *c == 'm');
        } else {
            out.push(c);
        }
    }
    out
}
