//! Multi-frame replies: splitting a long reply into frames (PLC side) and joining them (host side).
//!
//! ```text
//!  PLC:  %01$RD<data><BCC>&CR      first frame: `&` after the BCC, more follows
//!  host: %01**&CR                  "next frame, please"
//!  PLC:  %01<data><BCC>&CR         middle frame: data only
//!  host: %01**&CR
//!  PLC:  %01<data><BCC>CR          last frame: no `&`
//!  joined body: $RD<data><data><data>
//! ```
//! (PLC.md §1, "Multi-frame replies" \[practice\].) Commands are never split: chunk writes instead
//! ([`super::command::max_write_words`]).

use bytes::{Bytes, BytesMut};

use super::address::DT_MAX;
use super::error::MessageError;
use super::frame::{ENVELOPE_LEN, Frame, Header, Station};
use super::reply::{Response, encode_response};
use super::words::WORD_CHARS;

/// Longest joined reply body accepted: `$RD` and every data register DT0..=DT32764.
pub const MAX_REPLY_BODY: usize = 3 + WORD_CHARS * (DT_MAX as usize + 1);

/// The frames that carry `response` from `station` under `header`: one if it fits, else a
/// multi-frame sequence. Send the first, then each next one when the host asks (`HDR ST ** &`).
#[must_use]
pub fn response_frames(header: Header, station: Station, response: &Response) -> Vec<Frame> {
    let body = encode_response(response);
    if body.len() <= header.max_body_len(false) {
        return vec![Frame::new(header, station, body)];
    }
    let chunk = header.max_body_len(true);
    let count = body.len().div_ceil(chunk);
    (0..count)
        .map(|i| {
            let part = body.slice(i * chunk..body.len().min((i + 1) * chunk));
            Frame {
                more: i + 1 < count,
                ..Frame::new(header, station, part)
            }
        })
        .collect()
}

/// A reply on the wire: the frames it comes in and every character both ways.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplyWire {
    /// Frames the reply takes ([`response_frames`]'s split).
    pub frames: usize,
    /// Characters of those frames, and of the host's "next frame" requests between them.
    pub chars: usize,
}

/// How a reply body of `body_len` characters (`$` or `!` first) travels under `header`: in
/// one frame if it fits, else split as [`response_frames`] splits it, each frame after the
/// first asked for with a `HDR ST ** & CR` request.
#[must_use]
pub fn reply_wire(header: Header, body_len: usize) -> ReplyWire {
    if body_len <= header.max_body_len(false) {
        return ReplyWire {
            frames: 1,
            chars: ENVELOPE_LEN + body_len,
        };
    }
    let frames = body_len.div_ceil(header.max_body_len(true));
    let asks = frames - 1;
    let ask_chars = ENVELOPE_LEN + 1;
    ReplyWire {
        frames,
        // Every frame's envelope, `&` on all but the last, and one request before each of those.
        chars: body_len + frames * ENVELOPE_LEN + asks * (1 + ask_chars),
    }
}

/// A reply body joined from one or more frames.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Joined {
    /// The header of the reply's frames.
    pub header: Header,
    /// The answering station.
    pub station: Station,
    /// The whole body, `$` or `!` first.
    pub body: Bytes,
}

/// What one reply frame did to the reply being joined.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Progress {
    /// More frames follow: ask for the next one with [`Frame::next_frame_request`].
    More {
        /// Header to ask with.
        header: Header,
        /// Station to ask.
        station: Station,
    },
    /// The reply is whole.
    Complete(Joined),
}

/// Joins the frames of a multi-frame reply, host side.
#[derive(Debug, Clone, Default)]
pub struct ReplyAssembler {
    pending: Option<Joining>,
}

#[derive(Debug, Clone)]
struct Joining {
    header: Header,
    station: Station,
    body: BytesMut,
}

impl ReplyAssembler {
    /// Whether a multi-frame reply is half joined.
    #[must_use]
    pub fn is_joining(&self) -> bool {
        self.pending.is_some()
    }

    /// Drops a half-joined reply (after a timeout, say).
    pub fn reset(&mut self) {
        self.pending = None;
    }

    /// Takes the next reply frame. A broken sequence is an error and starts over.
    pub fn push(&mut self, frame: Frame) -> Result<Progress, MessageError> {
        let starts_reply = matches!(frame.body.first(), Some(b'$' | b'!'));
        match self.pending.take() {
            None if !starts_reply => Err(broken("a continuation frame came without a first frame")),
            None => Ok(self.start(frame)),
            Some(_) if frame.body.first() == Some(&b'!') => Ok(Progress::Complete(whole(frame))),
            Some(_) if starts_reply => Err(broken("a new reply began before the last frame")),
            Some(joining) => self.continue_with(joining, &frame),
        }
    }

    fn start(&mut self, frame: Frame) -> Progress {
        if !frame.more || frame.body.first() == Some(&b'!') {
            return Progress::Complete(whole(frame));
        }
        let (header, station) = (frame.header, frame.station);
        self.pending = Some(Joining {
            header,
            station,
            body: BytesMut::from(&frame.body[..]),
        });
        Progress::More { header, station }
    }

    fn continue_with(
        &mut self,
        mut joining: Joining,
        frame: &Frame,
    ) -> Result<Progress, MessageError> {
        if (frame.header, frame.station) != (joining.header, joining.station) {
            return Err(broken(
                "a frame from another station or header came mid-reply",
            ));
        }
        if joining.body.len() + frame.body.len() > MAX_REPLY_BODY {
            return Err(broken(
                "the joined reply is longer than any read of the whole DT area",
            ));
        }
        joining.body.extend_from_slice(&frame.body);
        let (header, station) = (joining.header, joining.station);
        if frame.more {
            self.pending = Some(joining);
            return Ok(Progress::More { header, station });
        }
        Ok(Progress::Complete(Joined {
            header,
            station,
            body: joining.body.freeze(),
        }))
    }
}

fn whole(frame: Frame) -> Joined {
    Joined {
        header: frame.header,
        station: frame.station,
        body: frame.body,
    }
}

fn broken(reason: &'static str) -> MessageError {
    MessageError::MultiFrame { reason }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mewtocol::decoder::{Decoded, FrameDecoder};
    use crate::mewtocol::reply::{Reply, parse_response};

    fn station() -> Station {
        Station::new(1).unwrap()
    }

    fn body_frame(body: &'static [u8], more: bool) -> Frame {
        Frame {
            more,
            ..Frame::new(Header::Percent, station(), body)
        }
    }

    #[test]
    fn reply_wire_counts_every_frame_and_request_response_frames_make() {
        for words in [1, 27, 28, 54, 55, 90, 200, 509] {
            let response = Ok(Reply::ReadDt(vec![0x1234; words]));
            let body_len = 3 + 4 * words;
            let frames = response_frames(Header::Percent, station(), &response);
            let frame_chars: usize = frames.iter().map(|f| f.to_bytes().unwrap().len()).sum();
            let ask = Frame::next_frame_request(Header::Percent, station());
            let asks = (frames.len() - 1) * ask.to_bytes().unwrap().len();
            assert_eq!(
                reply_wire(Header::Percent, body_len),
                ReplyWire {
                    frames: frames.len(),
                    chars: frame_chars + asks
                },
                "{words} words"
            );
        }
        // 27 words fill one % frame; 28 take two; < carries 509 in one.
        assert_eq!(reply_wire(Header::Percent, 3 + 4 * 27).frames, 1);
        assert_eq!(reply_wire(Header::Percent, 3 + 4 * 28).frames, 2);
        assert_eq!(reply_wire(Header::Angle, 3 + 4 * 509).frames, 1);
    }

    #[test]
    fn three_frame_reply_is_joined_in_order() {
        let mut assembler = ReplyAssembler::default();
        let more = Progress::More {
            header: Header::Percent,
            station: station(),
        };
        assert_eq!(
            assembler.push(body_frame(b"$RD6400", true)),
            Ok(more.clone())
        );
        assert!(assembler.is_joining());
        assert_eq!(assembler.push(body_frame(b"3412", true)), Ok(more));
        let Ok(Progress::Complete(joined)) = assembler.push(body_frame(b"0100", false)) else {
            panic!("not complete")
        };
        assert_eq!(&joined.body[..], b"$RD640034120100");
        assert_eq!(
            parse_response(&joined.body),
            Ok(Ok(Reply::ReadDt(vec![100, 0x1234, 1])))
        );
        assert!(!assembler.is_joining());
    }

    #[test]
    fn multi_frame_wire_bytes_decode_and_join() {
        // first: % 01 $RD 6400 BCC & CR; last: % 01 3412 BCC CR
        let mut wire = BytesMut::new();
        body_frame(b"$RD6400", true).encode(&mut wire).unwrap();
        body_frame(b"3412", false).encode(&mut wire).unwrap();
        assert!(wire.starts_with(b"%01$RD6400") && wire[12] == b'&');
        let mut assembler = ReplyAssembler::default();
        let mut last = None;
        while let Ok(Some(Decoded::Frame(frame))) = FrameDecoder.decode(&mut wire) {
            last = Some(assembler.push(frame).unwrap());
        }
        let Some(Progress::Complete(joined)) = last else {
            panic!("{last:?}")
        };
        assert_eq!(&joined.body[..], b"$RD64003412");
    }

    #[test]
    fn single_frame_reply_completes_at_once() {
        let mut assembler = ReplyAssembler::default();
        let progress = assembler.push(body_frame(b"$WD", false)).unwrap();
        assert!(matches!(progress, Progress::Complete(j) if &j.body[..] == b"$WD"));
    }

    #[test]
    fn continuation_without_a_first_frame_is_an_error() {
        let mut assembler = ReplyAssembler::default();
        assert!(matches!(
            assembler.push(body_frame(b"3412", false)),
            Err(MessageError::MultiFrame { .. })
        ));
    }

    #[test]
    fn error_reply_mid_sequence_ends_the_reply() {
        let mut assembler = ReplyAssembler::default();
        assembler.push(body_frame(b"$RD6400", true)).unwrap();
        let progress = assembler.push(body_frame(b"!43", false)).unwrap();
        assert!(matches!(progress, Progress::Complete(j) if &j.body[..] == b"!43"));
        assert!(!assembler.is_joining());
    }

    #[test]
    fn new_reply_mid_sequence_is_an_error_and_starts_over() {
        let mut assembler = ReplyAssembler::default();
        assembler.push(body_frame(b"$RD6400", true)).unwrap();
        assert!(assembler.push(body_frame(b"$WD", false)).is_err());
        assert!(!assembler.is_joining());
    }

    #[test]
    fn long_read_reply_splits_into_frames_that_join_back() {
        let words: Vec<u16> = (0..100).collect();
        let response = Ok(Reply::ReadDt(words.clone()));
        let frames = response_frames(Header::Percent, station(), &response);
        assert_eq!(frames.len(), 4);
        assert!(frames[..3].iter().all(|f| f.more) && !frames[3].more);
        assert!(
            frames
                .iter()
                .all(|f| f.encoded_len() <= Header::Percent.max_frame_len())
        );
        let mut assembler = ReplyAssembler::default();
        let mut last = None;
        for frame in frames {
            last = Some(assembler.push(frame).unwrap());
        }
        let Some(Progress::Complete(joined)) = last else {
            panic!("{last:?}")
        };
        assert_eq!(parse_response(&joined.body), Ok(Ok(Reply::ReadDt(words))));
    }

    #[test]
    fn reply_of_27_words_fits_one_frame() {
        let response = Ok(Reply::ReadDt(vec![0xFFFF; 27]));
        assert_eq!(
            response_frames(Header::Percent, station(), &response).len(),
            1
        );
        let response = Ok(Reply::ReadDt(vec![0xFFFF; 28]));
        assert_eq!(
            response_frames(Header::Percent, station(), &response).len(),
            2
        );
    }
}
