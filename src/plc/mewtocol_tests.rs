//! The MEWTOCOL client against a small memory-backed fake PLC built from the module's
//! `ServerCodec`, over `tokio::io::duplex`, on paused time.

use std::sync::{Arc, Mutex};

use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncWriteExt, DuplexStream};
use tokio_util::codec::Framed;

use super::*;
use crate::mewtocol::{
    Frame, PlcError as Bang, PlcStatus, ServerCodec, ServerEvent, response_frames,
};

/// How the fake answers `<` frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Angle {
    Accept,
    Silent,
    Refuse42,
}

#[derive(Debug)]
struct State {
    memory: Vec<u16>,
    relays: Vec<bool>,
    running: bool,
    angle: Angle,
    silent: bool,
    /// Replies that need more than one frame go unanswered.
    one_frame_only: bool,
    refuse_writes: Option<u8>,
    corrupt_replies: usize,
    /// The frame (counted from 0 as they are sent) a fault strikes, and how.
    strike: Option<(usize, Strike)>,
    frames_sent: usize,
    log: Vec<(Header, Command)>,
}

/// What a fault does to the frame it strikes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Strike {
    /// One character of its BCC is wrong.
    Corrupt,
    /// It never leaves.
    Drop,
}

impl State {
    fn new() -> Self {
        Self {
            memory: vec![0; 32_765],
            relays: vec![false; 1000 * 16],
            running: true,
            angle: Angle::Accept,
            silent: false,
            one_frame_only: false,
            refuse_writes: None,
            corrupt_replies: 0,
            strike: None,
            frames_sent: 0,
            log: Vec::new(),
        }
    }

    fn execute(&mut self, command: &Command) -> Response {
        let refuse = |code| {
            Err(Bang {
                code: PlcErrorCode::from_number(code),
            })
        };
        match command {
            Command::ReadDt(range) => {
                let (s, e) = (range.start() as usize, range.end() as usize);
                Ok(Reply::ReadDt(self.memory[s..=e].to_vec()))
            }
            Command::WriteDt { .. } if self.refuse_writes.is_some() => {
                refuse(self.refuse_writes.unwrap_or_default())
            }
            Command::WriteDt { start, words } => {
                let s = *start as usize;
                self.memory[s..s + words.len()].copy_from_slice(words);
                Ok(Reply::WriteDt)
            }
            Command::ReadContact(c) => Ok(Reply::ReadContact(self.relays[index(*c)])),
            Command::ReadContactWords(range) if range.area() == ContactArea::R => {
                let first = usize::from(range.start()) * 16;
                let words = (0..range.len())
                    .map(|w| {
                        (0..16).fold(0_u16, |word, b| {
                            word | (u16::from(self.relays[first + w * 16 + b]) << b)
                        })
                    })
                    .collect();
                Ok(Reply::ReadContactWords(words))
            }
            Command::WriteContact { contact, on } => {
                self.relays[index(*contact)] = *on;
                Ok(Reply::WriteContact)
            }
            Command::Status => Ok(Reply::Status(PlcStatus {
                mode_flags: u8::from(self.running),
                ..PlcStatus::default()
            })),
            _ => refuse(42),
        }
    }

    /// The frames to answer with, or none.
    fn answer(&mut self, header: Header, station: Station, command: &Command) -> Vec<Frame> {
        self.log.push((header, command.clone()));
        let angle = header == Header::Angle;
        if self.silent || (angle && self.angle == Angle::Silent) {
            return Vec::new();
        }
        let response = if angle && self.angle == Angle::Refuse42 {
            Err(Bang {
                code: PlcErrorCode::NotSupported,
            })
        } else {
            self.execute(command)
        };
        let frames = response_frames(header, station, &response);
        if self.one_frame_only && frames.len() > 1 {
            return Vec::new();
        }
        frames
    }

    /// The reads logged, as (header, words) in order.
    fn reads(&self) -> Vec<(Header, usize)> {
        self.log
            .iter()
            .filter_map(|(h, c)| match c {
                Command::ReadDt(range) => Some((*h, range.len())),
                _ => None,
            })
            .collect()
    }

    fn count(&self, header: Header, write: bool) -> usize {
        let is = |c: &Command| matches!(c, Command::WriteDt { .. }) == write;
        self.log
            .iter()
            .filter(|(h, c)| *h == header && is(c))
            .count()
    }
}

fn index(contact: Contact) -> usize {
    usize::from(contact.word()) * 16 + usize::from(contact.bit())
}

type Shared = Arc<Mutex<State>>;

/// Serves `state` on `stream` until the client hangs up.
async fn serve<S: AsyncRead + AsyncWrite + Unpin>(state: Shared, stream: S) {
    let mut framed = Framed::new(stream, ServerCodec::new());
    let mut pending: Vec<Frame> = Vec::new();
    while let Some(event) = framed.next().await {
        let Ok(ServerEvent::Request(request)) = event else {
            continue;
        };
        let frame = match request.message {
            Request::NextFrame if !pending.is_empty() => pending.remove(0),
            Request::NextFrame => continue,
            Request::Command(command) => {
                let mut frames =
                    state
                        .lock()
                        .unwrap()
                        .answer(request.header, request.station, &command);
                if frames.is_empty() {
                    continue;
                }
                pending = frames.split_off(1);
                frames.remove(0)
            }
        };
        let (corrupt, drop) = {
            let mut s = state.lock().unwrap();
            let struck = s
                .strike
                .filter(|(at, _)| *at == s.frames_sent)
                .map(|(_, how)| how);
            s.frames_sent += 1;
            let corrupt = s.corrupt_replies > 0 || struck == Some(Strike::Corrupt);
            s.corrupt_replies = s.corrupt_replies.saturating_sub(1);
            (corrupt, struck == Some(Strike::Drop))
        };
        if drop {
            continue;
        }
        if corrupt {
            let mut bytes = frame.to_bytes().unwrap();
            let at = bytes.len() - 2;
            bytes[at] = if bytes[at] == b'0' { b'1' } else { b'0' };
            framed.get_mut().write_all(&bytes).await.unwrap();
        } else {
            framed.send(frame).await.unwrap();
        }
    }
}

fn client(state: &Shared, header: HeaderChoice) -> MewtocolClient<DuplexStream> {
    let (ours, theirs) = tokio::io::duplex(4096);
    tokio::spawn(serve(Arc::clone(state), theirs));
    let options = MewtocolOptions::new(Station::new(1).unwrap(), header);
    MewtocolClient::new(ours, options)
}

fn fake() -> Shared {
    Arc::new(Mutex::new(State::new()))
}

fn ramp(n: u16) -> Vec<u16> {
    (0..n).map(|i| i.wrapping_mul(257) ^ 0x5A5A).collect()
}

#[tokio::test(start_paused = true)]
async fn percent_writes_100_words_in_24_word_chunks_and_reads_them_back_in_one_multi_frame_read() {
    let state = fake();
    let mut plc = client(&state, HeaderChoice::Percent);
    plc.write_words(2_000, &ramp(100)).await.unwrap();
    assert_eq!(plc.read_words(2_000, 100).await.unwrap(), ramp(100));
    let s = state.lock().unwrap();
    assert_eq!(s.memory[2_000..2_100], ramp(100)[..]);
    assert_eq!(s.count(Header::Percent, true), 5); // 24 + 24 + 24 + 24 + 4
    // One RD of 100 words, its reply in 4 frames.
    assert_eq!(s.reads(), [(Header::Percent, 100)]);
}

#[tokio::test(start_paused = true)]
async fn without_multi_frame_reads_percent_reads_27_words_a_frame() {
    let state = fake();
    state.lock().unwrap().memory[2_000..2_100].copy_from_slice(&ramp(100));
    let (ours, theirs) = tokio::io::duplex(4096);
    tokio::spawn(serve(Arc::clone(&state), theirs));
    let mut options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
    options.multi_frame_reads = false;
    let mut plc = MewtocolClient::new(ours, options);
    assert_eq!(plc.read_words(2_000, 100).await.unwrap(), ramp(100));
    let reads = state.lock().unwrap().reads();
    assert_eq!(
        reads.iter().map(|r| r.1).collect::<Vec<_>>(),
        [27, 27, 27, 19]
    );
    assert_eq!(plc.exchange_sizes().read_words, 27);
}

#[tokio::test(start_paused = true)]
async fn an_unanswered_multi_frame_read_falls_back_to_one_frame_reads_for_good() {
    let state = fake();
    {
        let mut s = state.lock().unwrap();
        s.memory[2_000..2_100].copy_from_slice(&ramp(100));
        s.one_frame_only = true;
    }
    let mut plc = client(&state, HeaderChoice::Percent);
    let counts = std::sync::Arc::new(crate::plc::ExchangeCounts::default());
    plc.set_exchange_counts(std::sync::Arc::clone(&counts));
    assert_eq!(plc.exchange_sizes().read_words, 509);
    assert_eq!(plc.multi_frame_reads_answered(), None);
    assert_eq!(plc.read_words(2_000, 100).await.unwrap(), ramp(100));
    assert_eq!(plc.multi_frame_reads_answered(), Some(false));
    // The 100-word read got one try (no retries), then 27-word reads.
    let words = |s: &State| s.reads().iter().map(|r| r.1).collect::<Vec<_>>();
    assert_eq!(words(&state.lock().unwrap()), [100, 27, 27, 27, 19]);
    assert_eq!((counts.timeouts(), counts.retries()), (1, 0));
    // From then on one frame a read, at once.
    assert_eq!(plc.read_words(2_000, 30).await.unwrap(), ramp(30));
    assert_eq!(words(&state.lock().unwrap())[5..], [27, 3]);
    assert_eq!(plc.exchange_sizes().read_words, 27);
    assert_eq!(counts.timeouts(), 1);
}

#[tokio::test(start_paused = true)]
async fn once_answered_a_garbled_multi_frame_read_is_read_again_a_frame_at_a_time_only() {
    let state = fake();
    state.lock().unwrap().memory[2_000..2_100].copy_from_slice(&ramp(100));
    let mut plc = client(&state, HeaderChoice::Percent);
    assert_eq!(plc.read_words(2_000, 100).await.unwrap(), ramp(100));
    assert_eq!(plc.multi_frame_reads_answered(), Some(true));
    // The next multi-frame reply's first frame arrives with a bad BCC.
    state.lock().unwrap().corrupt_replies = 1;
    assert_eq!(plc.read_words(2_000, 100).await.unwrap(), ramp(100));
    assert_eq!(plc.read_words(2_000, 60).await.unwrap(), ramp(60));
    let reads = state.lock().unwrap().reads();
    assert_eq!(
        reads.iter().map(|r| r.1).collect::<Vec<_>>(),
        [100, 100, 27, 27, 27, 19, 60],
        "the PLC answered one: the line's fault is no reason to stop"
    );
}

#[tokio::test(start_paused = true)]
async fn a_fault_on_any_frame_of_a_multi_frame_reply_still_gives_every_word_once_and_right() {
    // The invariant, over every frame a corrupt or lost reply can strike (the first frame of
    // the 4-frame reply to a 100-word read, a middle one, the last): the read returns exactly
    // the words in memory, and the words are read again one frame at a time, nothing else.
    for strike in [Strike::Corrupt, Strike::Drop] {
        for frame in 0..4 {
            let state = fake();
            state.lock().unwrap().memory[2_000..2_100].copy_from_slice(&ramp(100));
            let mut plc = client(&state, HeaderChoice::Percent);
            // Answered once (frames 0..=3), so a later failure is the line's.
            assert_eq!(plc.read_words(2_000, 100).await.unwrap(), ramp(100));
            state.lock().unwrap().strike = Some((4 + frame, strike));
            let words = plc.read_words(2_000, 100).await;
            let words = words.unwrap_or_else(|e| panic!("{strike:?} on frame {frame}: {e}"));
            assert_eq!(words, ramp(100), "{strike:?} on frame {frame}");
            let reads = state.lock().unwrap().reads();
            assert_eq!(
                reads.iter().map(|r| r.1).collect::<Vec<_>>(),
                [100, 100, 27, 27, 27, 19],
                "{strike:?} on frame {frame}"
            );
            assert_eq!(plc.multi_frame_reads_answered(), Some(true));
        }
    }
}

#[tokio::test(start_paused = true)]
async fn a_refused_multi_frame_read_falls_back_and_a_one_frame_read_never_tries_one() {
    // A PLC that answers a read longer than one frame with `! 41`.
    let state = fake();
    state.lock().unwrap().memory[10..70].copy_from_slice(&ramp(60));
    let (ours, theirs) = tokio::io::duplex(4096);
    tokio::spawn(serve_refusing_long_reads(Arc::clone(&state), theirs));
    let options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
    let mut plc = MewtocolClient::new(ours, options);
    // 27 words fit one frame: an ordinary read.
    assert_eq!(plc.read_words(10, 27).await.unwrap(), ramp(27));
    // 60 words: refused once, then read a frame at a time.
    assert_eq!(plc.read_words(10, 60).await.unwrap(), ramp(60));
    let reads = state.lock().unwrap().reads();
    assert_eq!(
        reads.iter().map(|r| r.1).collect::<Vec<_>>(),
        [27, 60, 27, 27, 6]
    );
}

/// Serves `state`, answering any read longer than one `%` frame holds with `! 41`.
async fn serve_refusing_long_reads<S: AsyncRead + AsyncWrite + Unpin>(state: Shared, stream: S) {
    let mut framed = Framed::new(stream, ServerCodec::new());
    while let Some(event) = framed.next().await {
        let Ok(ServerEvent::Request(request)) = event else {
            continue;
        };
        let Request::Command(command) = request.message else {
            continue;
        };
        let too_long = matches!(&command, Command::ReadDt(r) if r.len() > 27);
        let mut frames = state
            .lock()
            .unwrap()
            .answer(request.header, request.station, &command);
        if too_long {
            let refusal = Err(Bang {
                code: PlcErrorCode::FormatError,
            });
            frames = response_frames(request.header, request.station, &refusal);
        }
        framed.send(frames.remove(0)).await.unwrap();
    }
}

#[tokio::test(start_paused = true)]
async fn angle_writes_and_reads_100_words_in_one_frame_each() {
    let state = fake();
    let mut plc = client(&state, HeaderChoice::Angle);
    plc.write_words(2_000, &ramp(100)).await.unwrap();
    assert_eq!(plc.read_words(2_000, 100).await.unwrap(), ramp(100));
    let s = state.lock().unwrap();
    assert_eq!(
        (s.count(Header::Angle, true), s.count(Header::Angle, false)),
        (1, 1)
    );
    assert_eq!(
        s.count(Header::Percent, true) + s.count(Header::Percent, false),
        0
    );
}

#[tokio::test(start_paused = true)]
async fn angle_write_of_600_words_takes_two_frames() {
    let state = fake();
    let mut plc = client(&state, HeaderChoice::Angle);
    plc.write_words(10_000, &ramp(600)).await.unwrap();
    assert_eq!(state.lock().unwrap().count(Header::Angle, true), 2); // 507 + 93
    assert_eq!(plc.read_words(10_000, 600).await.unwrap(), ramp(600));
}

#[tokio::test(start_paused = true)]
async fn auto_uses_angle_when_the_plc_answers_it() {
    let state = fake();
    let mut plc = client(&state, HeaderChoice::Auto);
    assert_eq!(plc.header(), None);
    plc.write_words(100, &[1, 2, 3]).await.unwrap();
    assert_eq!(plc.header(), Some(Header::Angle));
}

#[tokio::test(start_paused = true)]
async fn auto_falls_back_to_percent_when_angle_gets_no_reply() {
    let state = fake();
    state.lock().unwrap().angle = Angle::Silent;
    let mut plc = client(&state, HeaderChoice::Auto);
    plc.write_words(100, &ramp(30)).await.unwrap();
    assert_eq!(plc.header(), Some(Header::Percent));
    assert_eq!(plc.read_words(100, 30).await.unwrap(), ramp(30));
    let s = state.lock().unwrap();
    assert_eq!(
        s.count(Header::Angle, false),
        1,
        "probed once, never retried"
    );
    assert_eq!(s.count(Header::Percent, true), 2);
}

#[tokio::test(start_paused = true)]
async fn auto_falls_back_to_percent_on_error_42_and_remembers_it() {
    let state = fake();
    state.lock().unwrap().angle = Angle::Refuse42;
    let mut plc = client(&state, HeaderChoice::Auto);
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
    assert_eq!(plc.header(), Some(Header::Percent));
    assert_eq!(state.lock().unwrap().count(Header::Angle, false), 1);
}

#[tokio::test(start_paused = true)]
async fn error_61_is_refused_with_its_code_and_not_retried() {
    let state = fake();
    state.lock().unwrap().refuse_writes = Some(61);
    let mut plc = client(&state, HeaderChoice::Percent);
    let e = plc.write_words(2_000, &[7; 10]).await.unwrap_err();
    let PlcError::Refused { operation, refusal } = &e else {
        panic!("{e:?}")
    };
    assert_eq!(operation, "write DT2000..=DT2009");
    assert!(matches!(refusal, Refusal::Mewtocol { code: 61, meaning } if meaning.contains("data")));
    assert!(!e.is_link_failure());
    assert_eq!(state.lock().unwrap().count(Header::Percent, true), 1);
}

#[tokio::test(start_paused = true)]
async fn reply_with_a_bad_bcc_is_retried_and_succeeds() {
    let state = fake();
    state.lock().unwrap().memory[500] = 0x1234;
    state.lock().unwrap().corrupt_replies = 1;
    let mut plc = client(&state, HeaderChoice::Percent);
    assert_eq!(plc.read_words(500, 1).await.unwrap(), [0x1234]);
    assert_eq!(state.lock().unwrap().count(Header::Percent, false), 2);
}

#[tokio::test(start_paused = true)]
async fn too_many_bad_replies_give_bad_reply() {
    let state = fake();
    state.lock().unwrap().corrupt_replies = 10;
    let mut plc = client(&state, HeaderChoice::Percent);
    let e = plc.write_words(500, &[1]).await.unwrap_err();
    assert!(matches!(e, PlcError::BadReply { .. }), "{e:?}");
    assert_eq!(state.lock().unwrap().count(Header::Percent, true), 3); // 1 + 2 retries
}

#[tokio::test(start_paused = true)]
async fn silent_plc_gives_a_timeout_after_the_retries() {
    let state = fake();
    state.lock().unwrap().silent = true;
    let mut plc = client(&state, HeaderChoice::Percent);
    let counts = std::sync::Arc::new(crate::plc::ExchangeCounts::default());
    plc.set_exchange_counts(std::sync::Arc::clone(&counts));
    let e = plc.read_words(0, 4).await.unwrap_err();
    // Three attempts timed out, two of them were retries.
    assert_eq!((counts.timeouts(), counts.retries()), (3, 2));
    assert!(
        matches!(
            e,
            // The 300 ms margin and two 10 ms scans (no wire time on a network link).
            PlcError::Timeout {
                timeout_ms: 320,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.is_link_failure());
    assert_eq!(state.lock().unwrap().count(Header::Percent, false), 3);
}

#[tokio::test(start_paused = true)]
async fn rt_mode_flags_give_run_or_prog() {
    let state = fake();
    let mut plc = client(&state, HeaderChoice::Percent);
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
    state.lock().unwrap().running = false;
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Prog);
}

#[tokio::test(start_paused = true)]
async fn relays_are_written_and_read_through_rcs_and_wcs() {
    let state = fake();
    let mut plc = client(&state, HeaderChoice::Percent);
    let r12a = 12 * 16 + 0xA;
    assert!(!plc.read_relay(r12a).await.unwrap());
    plc.write_relay(r12a, true).await.unwrap();
    assert!(plc.read_relay(r12a).await.unwrap());
    assert!(state.lock().unwrap().relays[usize::from(r12a)]);
    // Many bits at once: contact words (RCC), cut to the bits asked for.
    plc.write_bit(Area::R, 195, true).await.unwrap();
    let bits = plc.read_bits(Area::R, 190, 20).await.unwrap();
    assert_eq!(bits.len(), 20);
    assert!(bits[5] && bits[usize::from(r12a) - 190]);
    assert_eq!(bits.iter().filter(|b| **b).count(), 2);
    let e = plc.read_bits(Area::Dt, 0, 2).await.unwrap_err();
    assert!(e.to_string().contains("DT holds words, not bits"), "{e}");
}

#[tokio::test(start_paused = true)]
async fn closed_link_is_a_link_error_without_retries() {
    let (ours, theirs) = tokio::io::duplex(64);
    drop(theirs);
    let options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
    let mut plc = MewtocolClient::new(ours, options);
    assert!(matches!(plc.mode().await, Err(PlcError::Link { .. })));
}

#[test]
fn relay_names_are_decimal_word_and_hex_bit() {
    assert_eq!(relay_name(super::super::settings::R9020), "R9020");
    assert_eq!(relay_name(12 * 16 + 0xA), "R12A");
}

#[test]
fn chunks_cover_the_range_exactly() {
    let pieces: Vec<_> = chunks(100, 60, 27).collect();
    assert_eq!(pieces, [(100, 27), (127, 27), (154, 6)]);
    assert_eq!(chunks(0, 0, 27).count(), 0);
}

#[tokio::test]
async fn connect_opens_a_tcp_link_to_what_the_settings_name() {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let state = fake();
    let served = Arc::clone(&state);
    tokio::spawn(async move {
        let (stream, _) = listener.accept().await.unwrap();
        serve(served, stream).await;
    });
    let tcp = crate::plc::TcpSettings {
        address,
        connect_timeout: Duration::from_secs(5),
    };
    let settings = LinkSettings::new(
        crate::plc::Protocol::Mewtocol,
        crate::plc::Transport::Tcp(tcp),
    );
    let mut plc = crate::plc::connect(&settings).await.unwrap();
    assert!(matches!(plc, crate::plc::AnyPlc::Mewtocol(_)));
    plc.write_words(1_032, &[1, 2, 3]).await.unwrap();
    assert_eq!(plc.read_words(1_032, 3).await.unwrap(), [1, 2, 3]);
    assert_eq!(plc.mode().await.unwrap(), PlcMode::Run);
}

#[tokio::test(start_paused = true)]
async fn on_a_19200_baud_line_frames_are_cut_to_a_quarter_second_and_timeouts_grow_with_them() {
    let state = fake();
    let (ours, theirs) = tokio::io::duplex(4096);
    tokio::spawn(serve(Arc::clone(&state), theirs));
    let mut options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Angle);
    options.char_time = Some(Duration::from_secs_f64(11.0 / 19_200.0));
    let mut plc = MewtocolClient::new(ours, options);
    let words = ramp(340);
    plc.write_words(2_000, &words).await.unwrap();
    assert_eq!(plc.read_words(2_000, 340).await.unwrap(), words);
    let s = state.lock().unwrap();
    // 250 ms at 19200 baud is 436 characters: 104 words a write, 106 a read reply.
    assert_eq!(s.count(Header::Angle, true), 4, "340 words in 4 writes");
    assert_eq!(s.count(Header::Angle, false), 4, "340 words in 4 reads");
    // A read of 106 words: 20 characters out, 433 back, at 0.57 ms each, two scans, the margin.
    let read = Command::ReadDt(DtRange::from_len(0, 106).unwrap());
    let t = plc.exchange_timeout(Header::Angle, &read).as_secs_f64();
    let expected = (20.0 + 433.0) * 11.0 / 19_200.0 + 0.020 + 0.300;
    assert!((t - expected).abs() < 1e-3, "{t} s, expected {expected} s");
}

#[tokio::test(start_paused = true)]
async fn on_a_19200_baud_line_a_percent_multi_frame_read_is_cut_to_a_quarter_second() {
    let state = fake();
    let (ours, theirs) = tokio::io::duplex(4096);
    tokio::spawn(serve(Arc::clone(&state), theirs));
    let mut options = MewtocolOptions::new(Station::new(1).unwrap(), HeaderChoice::Percent);
    options.char_time = Some(Duration::from_secs_f64(11.0 / 19_200.0));
    let mut plc = MewtocolClient::new(ours, options);
    // 436 characters: 91 words take a 20-character request, a reply body of 367 in 4 frames
    // (6 each, `&` on 3) and 3 requests of 7 for the next frame: 435. 92 words would take 439.
    assert_eq!(plc.exchange_sizes().read_words, 91);
    let words = ramp(200);
    plc.write_words(2_000, &words).await.unwrap();
    assert_eq!(plc.read_words(2_000, 200).await.unwrap(), words);
    let reads = state.lock().unwrap().reads();
    assert_eq!(reads.iter().map(|r| r.1).collect::<Vec<_>>(), [91, 91, 18]);
    // Its timeout: those characters, two scans and one more for each of the 3 frames asked for,
    // the margin.
    let read = Command::ReadDt(DtRange::from_len(0, 91).unwrap());
    let t = plc.exchange_timeout(Header::Percent, &read).as_secs_f64();
    let expected = 435.0 * 11.0 / 19_200.0 + 0.050 + 0.300;
    assert!((t - expected).abs() < 1e-3, "{t} s, expected {expected} s");
}
