//! One contract exchange (status, bank write, compare, start, run to done, final counts) over
//! every link the FP-X is reached by: MEWTOCOL-COM over `tokio::io::duplex`, a pseudo-terminal
//! pair (a real tty, through tokio-serial) and TCP; Modbus RTU over a pseudo-terminal pair and
//! Modbus TCP. (Modbus over `duplex` is not here: tokio-modbus serves only a TCP listener or a
//! serial port, and Modbus is never written by hand.)

use crate::common;

use std::time::Duration;

use common::exchange::{exchange, mock_at_seed_start, settings};
use linterpd::mewtocol::Station;
use linterpd::mock::{MewtocolServer, MewtocolServerOptions, ModbusServer, ModbusServerOptions};
use linterpd::plc::exchange::Contract;
use linterpd::plc::{
    HeaderChoice, MewtocolClient, MewtocolOptions, ModbusClient, ModbusFraming, ModbusOptions,
};
use tokio::net::{TcpListener, TcpStream};
use tokio_serial::SerialStream;

/// What these tests check is the exchange, not the link's speed: an answer may take this long
/// (a pseudo-terminal's round trip on a loaded 2-core machine once took more than 500 ms).
const ANSWER_LIMIT: Duration = Duration::from_secs(3);

fn mewtocol_options(header: HeaderChoice) -> MewtocolOptions {
    let mut o = MewtocolOptions::new(Station::new(1).unwrap(), header);
    o.timeout = ANSWER_LIMIT;
    o
}

fn modbus_options(framing: ModbusFraming) -> ModbusOptions {
    let mut o = ModbusOptions::new(framing, 1);
    o.timeout = ANSWER_LIMIT;
    o
}

#[tokio::test]
async fn mewtocol_over_duplex() {
    let shared = mock_at_seed_start("");
    let (ours, theirs) = tokio::io::duplex(4_096);
    let server = MewtocolServer::new(shared.clone(), MewtocolServerOptions::default());
    tokio::spawn(async move { server.serve(theirs).await });
    let plc = MewtocolClient::new(ours, mewtocol_options(HeaderChoice::Percent));
    exchange(&mut Contract::new(plc, settings()), 1)
        .await
        .unwrap();
}

#[tokio::test]
async fn mewtocol_over_a_pseudo_terminal() {
    let shared = mock_at_seed_start("");
    let (ours, theirs) = SerialStream::pair().unwrap();
    let server = MewtocolServer::new(shared.clone(), MewtocolServerOptions::default());
    tokio::spawn(async move { server.serve(theirs).await });
    let plc = MewtocolClient::new(ours, mewtocol_options(HeaderChoice::Auto));
    exchange(&mut Contract::new(plc, settings()), 1)
        .await
        .unwrap();
}

#[tokio::test]
async fn mewtocol_over_tcp() {
    let shared = mock_at_seed_start("");
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let server = MewtocolServer::new(shared.clone(), MewtocolServerOptions::default());
    tokio::spawn(server.serve_tcp(listener));
    let plc = MewtocolClient::new(
        TcpStream::connect(address).await.unwrap(),
        mewtocol_options(HeaderChoice::Angle),
    );
    exchange(&mut Contract::new(plc, settings()), 1)
        .await
        .unwrap();
}

#[tokio::test]
async fn modbus_rtu_over_a_pseudo_terminal() {
    let shared = mock_at_seed_start("");
    let (ours, theirs) = SerialStream::pair().unwrap();
    let server = ModbusServer::new(shared.clone(), ModbusServerOptions::default());
    tokio::spawn(server.serve_rtu(theirs));
    let plc = ModbusClient::new(ours, modbus_options(ModbusFraming::Rtu));
    exchange(&mut Contract::new(plc, settings()), 1)
        .await
        .unwrap();
}

#[tokio::test]
async fn modbus_tcp() {
    let shared = mock_at_seed_start("");
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let server = ModbusServer::new(shared.clone(), ModbusServerOptions::default());
    tokio::spawn(server.serve_tcp(listener));
    let plc = ModbusClient::new(
        TcpStream::connect(address).await.unwrap(),
        modbus_options(ModbusFraming::Tcp),
    );
    exchange(&mut Contract::new(plc, settings()), 1)
        .await
        .unwrap();
}
