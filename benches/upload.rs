//! Upload time of the seed's tables through an emulated serial link, against the wire floor: its
//! constant-period bank at every speed, its bounded-error 0.05 mm bank at the shipped 19200 baud.
//!
//! The mock PLC serves on loopback TCP behind its serial-line emulation (11-bit characters at the
//! given baud rate, replies after the scan in which the frame completed, 2 ms scans); linterpd's
//! own clients upload the bank with `Contract::upload`, with and without read-back, in real time.
//! The floor is the bytes that must cross at that speed (every command and reply frame, chunked
//! as the clients chunk them) plus one scan per exchange.
//!
//! Run: `cargo bench --bench upload`

use std::time::{Duration, Instant};

use linterpd::geometry::Pose;
use linterpd::mewtocol::{Header, Station, max_read_reply_words, max_write_words, reply_wire};
use linterpd::mock::{
    MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, ModbusServer, ModbusServerOptions,
    SharedMock,
};
use linterpd::plan::{MoveRequest, Origin, plan_move};
use linterpd::plc::exchange::{BLOCK_WRITE_WORDS, Contract, ContractSettings};
use linterpd::plc::{
    HeaderChoice, MewtocolClient, MewtocolOptions, ModbusClient, ModbusFraming, ModbusOptions, Plc,
};
use linterpd::robot::{Method, seed_robot};
use linterpd::table::{ValidTable, encode};
use tokio::net::{TcpListener, TcpStream};

const SCAN_S: f64 = 0.002;

#[derive(Clone, Copy)]
enum Link {
    Mewtocol(Header),
    ModbusRtu,
}

impl Link {
    fn name(self) -> &'static str {
        match self {
            Self::Mewtocol(Header::Percent) => "MEWTOCOL %",
            Self::Mewtocol(Header::Angle) => "MEWTOCOL <",
            Self::ModbusRtu => "Modbus RTU",
        }
    }

    /// (bytes both ways, exchanges) to write `words` as one block.
    fn write_cost(self, words: usize) -> (usize, usize) {
        // (words a frame, command bytes = a + b * n, reply bytes)
        let (per, a, b, reply) = match self {
            // % 01 # WDD sssss eeeee data BCC CR ; reply % 01 $ WD BCC CR
            Self::Mewtocol(h) => (max_write_words(h), 20, 4, 9),
            // unit fc start qty count data crc ; reply unit fc start qty crc
            Self::ModbusRtu => (123, 9, 2, 8),
        };
        chunks(words, per).fold((0, 0), |(bytes, e), n| (bytes + a + b * n + reply, e + 1))
    }

    /// (bytes both ways, scans waited) to read `words` back.
    fn read_cost(self, words: usize) -> (usize, usize) {
        match self {
            // % 01 # RDD sssss eeeee BCC CR; the reply in as many frames as it needs (under %
            // up to 509 words, each frame after the first asked for with % 01 ** & CR, each
            // answered after a scan).
            Self::Mewtocol(h) => {
                let per = match h {
                    Header::Percent => max_read_reply_words(Header::Angle),
                    Header::Angle => max_read_reply_words(h),
                };
                chunks(words, per).fold((0, 0), |(bytes, e), n| {
                    let wire = reply_wire(h, 3 + 4 * n);
                    (bytes + 20 + wire.chars, e + wire.frames)
                })
            }
            // unit fc start qty crc ; reply unit fc count data crc
            Self::ModbusRtu => {
                chunks(words, 125).fold((0, 0), |(bytes, e), n| (bytes + 8 + 5 + 2 * n, e + 1))
            }
        }
    }
}

fn chunks(words: usize, per: usize) -> impl Iterator<Item = usize> {
    (0..words.div_ceil(per)).map(move |i| (words - i * per).min(per))
}

/// The seed's move planned by `method`, as tables.
fn seed_tables(method: Method) -> Vec<ValidTable> {
    let mut robot = seed_robot();
    robot.motion.method = method;
    let from = robot
        .pose_with_wrist_at_zero(-926.57, 535.03, 50.0)
        .unwrap();
    let to = Pose {
        a_rad: from.a_rad,
        ..Pose::from_mm_deg(-1144.43, 659.60, 186.60, 0.0)
    };
    let req = MoveRequest {
        from: Origin::Pose(from),
        to,
        motion: robot.motion,
    };
    plan_move(&robot, &req)
        .unwrap()
        .valid_tables(&robot)
        .unwrap()
}

/// The floor for writing every block (tables and the command block's words) and reading them back:
/// the bytes both ways at the baud rate, and a scan for every reply frame.
fn floor_s(link: Link, blocks: &[usize], baud: u32, verify: bool) -> (f64, usize) {
    let mut bytes = 0;
    let mut exchanges = 0;
    for &words in blocks {
        let (b, e) = link.write_cost(words);
        bytes += b;
        exchanges += e;
        if verify {
            let (b, e) = link.read_cost(words);
            bytes += b;
            exchanges += e;
        }
    }
    (
        bytes as f64 * 11.0 / f64::from(baud) + exchanges as f64 * SCAN_S,
        bytes,
    )
}

async fn upload_with<P: Plc>(plc: P, tables: &[ValidTable], verify: bool) -> Duration {
    let settings = ContractSettings {
        verify,
        ..ContractSettings::default()
    };
    let mut contract = Contract::new(plc, settings);
    let t = Instant::now();
    let from = std::array::from_fn(|c| {
        tables
            .iter()
            .find(|t| usize::from(t.table().channel) == c)
            .map_or(0, |t| t.table().start as i32)
    });
    let _bank = contract.upload(0, 1, from, tables).await.expect("upload");
    t.elapsed()
}

async fn measure(link: Link, baud: u32, verify: bool, tables: &[ValidTable]) -> Duration {
    let shared = SharedMock::new(MockPlc::new(MockConfig::default()).unwrap());
    tokio::spawn(shared.clone().run_scans());
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let timeout = Duration::from_secs(5);
    match link {
        Link::Mewtocol(header) => {
            let server = MewtocolServer::new(
                shared,
                MewtocolServerOptions {
                    baud: Some(baud),
                    ..MewtocolServerOptions::default()
                },
            );
            tokio::spawn(server.serve_tcp(listener));
            let choice = if header == Header::Percent {
                HeaderChoice::Percent
            } else {
                HeaderChoice::Angle
            };
            let mut options = MewtocolOptions::new(Station::new(1).unwrap(), choice);
            options.timeout = timeout;
            upload_with(
                MewtocolClient::new(TcpStream::connect(address).await.unwrap(), options),
                tables,
                verify,
            )
            .await
        }
        Link::ModbusRtu => {
            let server = ModbusServer::new(
                shared,
                ModbusServerOptions {
                    baud: Some(baud),
                    ..ModbusServerOptions::default()
                },
            );
            tokio::spawn(server.serve_rtu_over_tcp(listener));
            let mut options = ModbusOptions::new(ModbusFraming::Rtu, 1);
            options.timeout = timeout;
            upload_with(
                ModbusClient::new(TcpStream::connect(address).await.unwrap(), options),
                tables,
                verify,
            )
            .await
        }
    }
}

#[tokio::main]
async fn main() {
    let banks = [
        (
            "constant-period 50 ms",
            Method::ConstantPeriod,
            &[9_600, 19_200, 115_200][..],
        ),
        (
            "bounded-error 0.05 mm",
            Method::BoundedError { tolerance_mm: 0.05 },
            &[19_200][..],
        ),
    ];
    for (name, method, bauds) in banks {
        let tables = seed_tables(method);
        let mut blocks: Vec<usize> = tables.iter().map(|t| encode(t).len()).collect();
        blocks.push(BLOCK_WRITE_WORDS);
        println!(
            "\nseed's tables, {name}: {} words in {} blocks ({blocks:?})",
            blocks.iter().sum::<usize>(),
            blocks.len()
        );
        println!("| link | baud | read-back | bytes | floor s | measured s | over floor |");
        println!("|---|---|---|---|---|---|---|");
        for link in [
            Link::Mewtocol(Header::Percent),
            Link::Mewtocol(Header::Angle),
            Link::ModbusRtu,
        ] {
            for &baud in bauds {
                for verify in [false, true] {
                    let (floor, bytes) = floor_s(link, &blocks, baud, verify);
                    let took = measure(link, baud, verify, &tables).await.as_secs_f64();
                    println!(
                        "| {} | {baud} | {} | {bytes} | {floor:.3} | {took:.3} | {:+.1} % |",
                        link.name(),
                        if verify { "yes" } else { "no" },
                        (took / floor - 1.0) * 100.0
                    );
                }
            }
        }
    }
}
