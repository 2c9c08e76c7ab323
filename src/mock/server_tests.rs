//! The MEWTOCOL-COM server against linterpd's own client and codec, over `tokio::io::duplex`, on
//! paused time.

use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncReadExt, AsyncWriteExt, DuplexStream};
use tokio::time::Instant;
use tokio_util::codec::Framed;

use super::*;
use crate::mewtocol::{
    Addressed, ClientCodec, ClientEvent, Command, DtRange, Header, Reply, Request, Station, bcc,
};
use crate::plc::{HeaderChoice, MewtocolClient, MewtocolOptions, Plc, PlcError, Refusal};

fn serve_with(options: MewtocolServerOptions, script: &str) -> (SharedMock, DuplexStream) {
    let mut mock = MockPlc::new(MockConfig::default()).unwrap();
    mock.set_faults(FaultScript::parse(script).unwrap());
    let shared = SharedMock::new(mock);
    let (ours, theirs) = tokio::io::duplex(8192);
    let server = MewtocolServer::new(shared.clone(), options);
    tokio::spawn(async move { server.serve(theirs).await });
    (shared, ours)
}

fn serve(script: &str) -> (SharedMock, DuplexStream) {
    serve_with(MewtocolServerOptions::default(), script)
}

fn client(stream: DuplexStream, station: Station) -> MewtocolClient<DuplexStream> {
    MewtocolClient::new(stream, MewtocolOptions::new(station, HeaderChoice::Percent))
}

fn st(n: u8) -> Station {
    Station::new(n).unwrap()
}

fn ramp(n: u16) -> Vec<u16> {
    (0..n).map(|i| i.wrapping_mul(257) ^ 0x5A5A).collect()
}

/// A frame with its BCC, as bytes.
fn framed(text: &str) -> Vec<u8> {
    format!("{text}{:02X}\r", bcc(text.as_bytes())).into_bytes()
}

/// Sends raw bytes and reads one reply up to CR.
async fn raw_exchange(stream: &mut DuplexStream, bytes: &[u8]) -> Vec<u8> {
    stream.write_all(bytes).await.unwrap();
    let mut reply = Vec::new();
    let mut byte = [0_u8];
    while reply.last() != Some(&b'\r') {
        stream.read_exact(&mut byte).await.unwrap();
        reply.push(byte[0]);
    }
    reply
}

#[tokio::test(start_paused = true)]
async fn client_writes_and_reads_600_words() {
    let (shared, stream) = serve("");
    let mut plc = client(stream, st(1));
    plc.write_words(2_000, &ramp(600)).await.unwrap();
    assert_eq!(plc.read_words(2_000, 600).await.unwrap(), ramp(600));
    assert_eq!(
        shared.with(|m| m.read_words(2_000, 600).unwrap()),
        ramp(600)
    );
}

#[tokio::test(start_paused = true)]
async fn a_600_word_read_is_a_multi_frame_reply_under_percent() {
    let (shared, stream) = serve("");
    shared.with(|m| m.write_words(5_000, &ramp(600)).unwrap());
    let mut codec = Framed::new(stream, ClientCodec::new());
    let command = Command::ReadDt(DtRange::from_len(5_000, 600).unwrap());
    let ask = |message| Addressed {
        header: Header::Percent,
        station: st(1),
        message,
    };
    codec.send(ask(Request::Command(command))).await.unwrap();
    let mut frames = 1;
    let words = loop {
        match codec.next().await.unwrap().unwrap() {
            ClientEvent::MoreFollows { .. } => {
                frames += 1;
                codec.send(ask(Request::NextFrame)).await.unwrap();
            }
            ClientEvent::Response(reply) => break reply.message.unwrap(),
            ClientEvent::Skipped(bytes) => panic!("skipped {bytes:?}"),
        }
    };
    assert_eq!(words, Reply::ReadDt(ramp(600)));
    assert!(frames >= 600 / 27, "{frames} frames");
}

#[tokio::test(start_paused = true)]
async fn rt_reports_run_and_prog() {
    let (shared, mut stream) = serve("");
    assert_eq!(
        raw_exchange(&mut stream, &framed("%01#RMP")).await,
        framed("%01$RM")
    );
    assert_eq!(shared.with(|m| m.mode()), PlcMode::Prog);
    let mut plc = client(stream, st(1));
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Prog);
    shared.with(|m| m.set_mode(PlcMode::Run));
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
}

#[tokio::test(start_paused = true)]
async fn a_wrong_station_gets_no_reply() {
    let options = MewtocolServerOptions {
        station: StationFilter::Only(3),
        baud: None,
    };
    let (shared, stream) = serve_with(options, "");
    let mut plc = client(stream, st(4));
    let e = plc.read_words(0, 1).await.unwrap_err();
    assert!(matches!(e, PlcError::Timeout { .. }), "{e:?}");
    assert_eq!(shared.with(|m| m.commands()), 0);
}

#[tokio::test(start_paused = true)]
async fn ee_is_answered_by_a_numbered_station_and_ff_never() {
    let options = MewtocolServerOptions {
        station: StationFilter::Only(3),
        baud: None,
    };
    let (shared, mut stream) = serve_with(options, "");
    stream
        .write_all(&framed("%FF#WDD00010000100700"))
        .await
        .unwrap();
    let reply = raw_exchange(&mut stream, &framed("%EE#RDD0001000010")).await;
    assert_eq!(
        reply,
        framed("%03$RD0700"),
        "the broadcast write was executed silently"
    );
    assert_eq!(shared.with(|m| m.commands()), 2);
}

#[tokio::test(start_paused = true)]
async fn refusals_carry_the_manual_codes() {
    let (_, mut stream) = serve("");
    let cases = [
        (framed("%01#RDD3276532765"), "%01!66"), // address past DT32764
        (b"%01#RT02\r".to_vec(), "%01!40"),      // bad BCC (RT's is 01)
        (framed("%01#XX"), "%01!42"),            // no such command
        (framed("%01#RDD0001000005"), "%01!61"), // start after end
        (framed("%01#RDD12"), "%01!41"),         // format
    ];
    for (command, expected) in cases {
        let reply = raw_exchange(&mut stream, &command).await;
        assert_eq!(
            reply,
            framed(expected),
            "{}",
            String::from_utf8_lossy(&command)
        );
    }
}

#[tokio::test(start_paused = true)]
async fn garbage_before_a_command_is_skipped() {
    let (_, mut stream) = serve("");
    let mut bytes = b"\x00noise".to_vec();
    bytes.extend(framed("%01#RT"));
    let reply = raw_exchange(&mut stream, &bytes).await;
    assert!(reply.starts_with(b"%01$RT"), "{reply:?}");
}

#[tokio::test(start_paused = true)]
async fn a_scripted_error_reply_is_a_refusal() {
    let (_, stream) = serve("error63@1");
    let e = client(stream, st(1)).read_words(0, 1).await.unwrap_err();
    let PlcError::Refused { refusal, .. } = e else {
        panic!("{e:?}")
    };
    assert!(matches!(refusal, Refusal::Mewtocol { code: 63, .. }));
}

#[tokio::test(start_paused = true)]
async fn a_corrupt_reply_is_retried_and_succeeds() {
    let (shared, stream) = serve("corrupt@1");
    shared.with(|m| m.write_words(100, &[0x1234]).unwrap());
    let mut plc = client(stream, st(1));
    assert_eq!(plc.read_words(100, 1).await.unwrap(), [0x1234]);
    assert_eq!(shared.with(|m| m.commands()), 2, "one retry");
}

#[tokio::test(start_paused = true)]
async fn a_dropped_reply_is_retried_after_the_timeout() {
    let (shared, stream) = serve("drop@1,delay50@2");
    let mut plc = client(stream, st(1));
    let started = Instant::now();
    plc.write_words(10, &[1, 2, 3]).await.unwrap();
    assert!(started.elapsed() >= Duration::from_millis(350));
    assert_eq!(shared.with(|m| m.commands()), 2);
}

#[tokio::test(start_paused = true)]
async fn a_scripted_close_ends_the_connection() {
    let (_, mut stream) = serve("close@1");
    stream.write_all(&framed("%01#RT")).await.unwrap();
    let mut buf = [0_u8; 16];
    assert_eq!(stream.read(&mut buf).await.unwrap(), 0, "closed, no reply");
}

#[tokio::test(start_paused = true)]
async fn at_9600_baud_a_100_word_write_takes_its_wire_time() {
    let options = MewtocolServerOptions {
        station: StationFilter::Any,
        baud: Some(9600),
    };
    let (_, stream) = serve_with(options, "");
    let mut plc = client(stream, st(1));
    let started = Instant::now();
    plc.write_words(3_000, &ramp(100)).await.unwrap();
    // 5 commands (24 + 24 + 24 + 24 + 4 words): 20 characters of envelope and range, 4 a word;
    // 5 replies `%01$WD13` CR of 9 characters each.
    let bytes = 5 * 20 + 4 * 100 + 5 * 9;
    assert!(
        started.elapsed() >= wire_time(bytes, 9600),
        "{:?} < {:?}",
        started.elapsed(),
        wire_time(bytes, 9600)
    );
}

#[tokio::test(start_paused = true)]
async fn at_9600_baud_the_reply_leaves_after_the_scan_boundary() {
    let options = MewtocolServerOptions {
        station: StationFilter::Any,
        baud: Some(9600),
    };
    let (shared, mut stream) = serve_with(options, "");
    tokio::time::sleep(Duration::from_micros(500)).await;
    let command = framed("%01#RDD0000000000");
    let sent_s = shared.now_s();
    let reply = raw_exchange(&mut stream, &command).await;
    let arrived_command_s = sent_s + wire_time(command.len(), 9600).as_secs_f64();
    let scan_end_s = shared.scan_end_after_s(arrived_command_s);
    let earliest_s = scan_end_s + wire_time(reply.len(), 9600).as_secs_f64();
    assert!(
        shared.now_s() >= earliest_s - 1e-9,
        "{} < {earliest_s}",
        shared.now_s()
    );
}

#[tokio::test(start_paused = true)]
async fn angle_refused_leaves_angle_frames_unanswered_and_answers_percent() {
    let mock = MockPlc::new(MockConfig {
        variant: MockVariant::AngleRefused,
        ..MockConfig::default()
    })
    .unwrap();
    let shared = SharedMock::new(mock);
    let (mut ours, theirs) = tokio::io::duplex(8192);
    let server = MewtocolServer::new(shared, MewtocolServerOptions::default());
    tokio::spawn(async move { server.serve(theirs).await });
    ours.write_all(&framed("<01#RDD0100001000")).await.unwrap();
    let mut byte = [0_u8];
    let silent = tokio::time::timeout(Duration::from_secs(1), ours.read_exact(&mut byte)).await;
    assert!(silent.is_err(), "no answer to <");
    let reply = raw_exchange(&mut ours, &framed("%01#RDD0100001000")).await;
    assert!(reply.starts_with(b"%01$RD494C"), "{reply:?}");
}

#[tokio::test(start_paused = true)]
async fn one_frame_replies_leave_a_multi_frame_read_unanswered_and_the_client_reads_a_frame_at_a_time()
 {
    let mock = MockPlc::new(MockConfig {
        variant: MockVariant::OneFrameReplies,
        ..MockConfig::default()
    })
    .unwrap();
    let shared = SharedMock::new(mock);
    shared.with(|m| m.write_words(2_000, &ramp(60)).unwrap());
    let (mut ours, theirs) = tokio::io::duplex(8192);
    let server = MewtocolServer::new(shared.clone(), MewtocolServerOptions::default());
    tokio::spawn(async move { server.serve(theirs).await });
    // 28 words take two frames: no answer. 27 fit one.
    ours.write_all(&framed("%01#RDD0200002027")).await.unwrap();
    let mut byte = [0_u8];
    let silent = tokio::time::timeout(Duration::from_secs(1), ours.read_exact(&mut byte)).await;
    assert!(silent.is_err(), "no answer to a read of two frames");
    let reply = raw_exchange(&mut ours, &framed("%01#RDD0200002026")).await;
    assert!(reply.starts_with(b"%01$RD5A5A"), "{reply:?}");
    // linterpd's client gets every word all the same.
    let mut plc = client(ours, st(1));
    assert_eq!(plc.read_words(2_000, 60).await.unwrap(), ramp(60));
    assert_eq!(plc.exchange_sizes().read_words, 27);
}
