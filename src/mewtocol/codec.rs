//! tokio-util codecs for both ends of a MEWTOCOL-COM link, over the one [`FrameDecoder`].
//!
//! ```text
//!  host (ClientCodec)                              PLC or mock PLC (ServerCodec)
//!  Encoder<Addressed<Request>> --- %01#RT01 CR ---> Decoder -> ServerEvent::Request
//!  Decoder -> ClientEvent      <-- %01$RT...CR ---- Encoder<Addressed<Response>> / Encoder<Frame>
//! ```
//! The codecs know nothing of sockets. A frame error (bad BCC, too long) is returned as an error
//! after its bytes are dropped; polling again carries on with the next frame. (tokio-util 0.7's
//! `FramedRead` yields that error, then `None` once, then resumes reading if polled again.)
//! A reply to `EE` may carry the PLC's own station number: match replies by order, not station.

use bytes::{Bytes, BytesMut};
use tokio_util::codec::{Decoder, Encoder};

use super::command::Command;
use super::decoder::{Decoded, FrameDecoder};
use super::error::{CodecError, MessageError};
use super::frame::{Frame, Header, Station};
use super::multi::{Progress, ReplyAssembler};
use super::reply::{Response, encode_response, parse_response};

/// A message with the envelope it travels in.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Addressed<T> {
    /// `%` or `<`; a reply uses its command's header.
    pub header: Header,
    /// Addressed (command) or answering (reply) station.
    pub station: Station,
    /// The message.
    pub message: T,
}

/// What the host sends.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Request {
    /// A command.
    Command(Command),
    /// `**&`: the next frame of a multi-frame reply, please.
    NextFrame,
}

/// What the host's decoder yields.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ClientEvent {
    /// Bytes before a header were dropped.
    Skipped(Bytes),
    /// A multi-frame reply has more frames: send [`Request::NextFrame`] to this header and station.
    MoreFollows {
        /// Header to ask with.
        header: Header,
        /// Station to ask.
        station: Station,
    },
    /// A whole reply: data, or the PLC's refusal.
    Response(Addressed<Response>),
}

/// The host's codec: encodes requests, decodes (and joins) replies.
#[derive(Debug, Default)]
pub struct ClientCodec {
    frames: FrameDecoder,
    assembler: ReplyAssembler,
}

impl ClientCodec {
    /// A codec with no reply half joined.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Drops a half-joined multi-frame reply (after a timeout, say).
    pub fn reset(&mut self) {
        self.assembler.reset();
    }
}

impl Encoder<Addressed<Request>> for ClientCodec {
    type Error = CodecError;

    fn encode(&mut self, item: Addressed<Request>, dst: &mut BytesMut) -> Result<(), CodecError> {
        let frame = match &item.message {
            Request::Command(command) => command.to_frame(item.header, item.station)?,
            Request::NextFrame => Frame::next_frame_request(item.header, item.station),
        };
        Ok(frame.encode(dst)?)
    }
}

impl Decoder for ClientCodec {
    type Item = ClientEvent;
    type Error = CodecError;

    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<ClientEvent>, CodecError> {
        let frame = match self.frames.decode(src)? {
            None => return Ok(None),
            Some(Decoded::Skipped(bytes)) => return Ok(Some(ClientEvent::Skipped(bytes))),
            Some(Decoded::Frame(frame)) => frame,
        };
        match self.assembler.push(frame)? {
            Progress::More { header, station } => {
                Ok(Some(ClientEvent::MoreFollows { header, station }))
            }
            Progress::Complete(joined) => {
                let message = parse_response(&joined.body)?;
                let (header, station) = (joined.header, joined.station);
                Ok(Some(ClientEvent::Response(Addressed {
                    header,
                    station,
                    message,
                })))
            }
        }
    }
}

/// What the PLC's (or mock PLC's) decoder yields.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ServerEvent {
    /// Bytes before a header were dropped.
    Skipped(Bytes),
    /// A valid request.
    Request(Addressed<Request>),
    /// A well-formed frame whose text is no valid command; answer `!` with
    /// [`MessageError::plc_code`] (unless the station is `FF`).
    Invalid {
        /// The frame's header.
        header: Header,
        /// The frame's station.
        station: Station,
        /// What is wrong with it.
        error: MessageError,
    },
}

/// The PLC's codec: decodes requests, encodes replies.
#[derive(Debug, Default)]
pub struct ServerCodec {
    frames: FrameDecoder,
}

impl ServerCodec {
    /// A server codec.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }
}

fn request_event(frame: &Frame) -> ServerEvent {
    let (header, station) = (frame.header, frame.station);
    let parsed = if frame.is_next_frame_request() {
        Ok(Request::NextFrame)
    } else if frame.more {
        Err(MessageError::MultiFrame {
            reason: "multi-frame commands are not supported",
        })
    } else {
        Command::parse(&frame.body).map(Request::Command)
    };
    match parsed {
        Ok(message) => ServerEvent::Request(Addressed {
            header,
            station,
            message,
        }),
        Err(error) => ServerEvent::Invalid {
            header,
            station,
            error,
        },
    }
}

impl Decoder for ServerCodec {
    type Item = ServerEvent;
    type Error = CodecError;

    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<ServerEvent>, CodecError> {
        Ok(self.frames.decode(src)?.map(|decoded| match decoded {
            Decoded::Skipped(bytes) => ServerEvent::Skipped(bytes),
            Decoded::Frame(frame) => request_event(&frame),
        }))
    }
}

impl Encoder<Addressed<Response>> for ServerCodec {
    type Error = CodecError;

    /// Encodes a reply that fits one frame; for longer ones send
    /// [`super::multi::response_frames`] one by one through `Encoder<Frame>`.
    fn encode(&mut self, item: Addressed<Response>, dst: &mut BytesMut) -> Result<(), CodecError> {
        let body = encode_response(&item.message);
        Ok(Frame::new(item.header, item.station, body).encode(dst)?)
    }
}

impl Encoder<Frame> for ServerCodec {
    type Error = CodecError;

    fn encode(&mut self, item: Frame, dst: &mut BytesMut) -> Result<(), CodecError> {
        Ok(item.encode(dst)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mewtocol::address::{Contact, ContactArea, DtRange};
    use crate::mewtocol::error::{PlcError, PlcErrorCode};
    use crate::mewtocol::frame::FrameError;
    use crate::mewtocol::multi::response_frames;
    use crate::mewtocol::reply::Reply;

    fn st(n: u8) -> Station {
        Station::new(n).unwrap()
    }

    fn addressed<T>(station: Station, message: T) -> Addressed<T> {
        Addressed {
            header: Header::Percent,
            station,
            message,
        }
    }

    fn encode_request(request: Request, station: Station) -> BytesMut {
        let mut dst = BytesMut::new();
        ClientCodec::new()
            .encode(addressed(station, request), &mut dst)
            .unwrap();
        dst
    }

    fn client_decode(bytes: &[u8]) -> (Result<Option<ClientEvent>, CodecError>, BytesMut) {
        let mut buf = BytesMut::from(bytes);
        (ClientCodec::new().decode(&mut buf), buf)
    }

    fn server_decode(bytes: &[u8]) -> (Result<Option<ServerEvent>, CodecError>, BytesMut) {
        let mut buf = BytesMut::from(bytes);
        (ServerCodec::new().decode(&mut buf), buf)
    }

    #[allow(clippy::unnecessary_wraps)] // compared with what `decode` returns
    fn ok_response(station: Station, reply: Reply) -> Option<ClientEvent> {
        Some(ClientEvent::Response(addressed(station, Ok(reply))))
    }

    // ---- client: encoding ----

    #[test]
    fn client_encodes_golden_command_frames() {
        let x0 = Contact::new(ContactArea::X, 0, 0).unwrap();
        assert_eq!(
            &encode_request(Request::Command(Command::ReadContact(x0)), st(1))[..],
            b"%01#RCSX00001D\r"
        );
        assert_eq!(
            &encode_request(Request::Command(Command::Status), Station::ANY)[..],
            b"%EE#RT00\r"
        );
        assert_eq!(&encode_request(Request::NextFrame, st(1))[..], b"%01**&\r");
    }

    #[test]
    fn client_refuses_a_write_too_long_for_one_frame() {
        let write = Command::write_dt(0, vec![0; 25]).unwrap();
        let mut dst = BytesMut::new();
        let err = ClientCodec::new().encode(addressed(st(1), Request::Command(write)), &mut dst);
        assert!(matches!(
            err,
            Err(CodecError::Message(MessageError::TooManyWords { .. }))
        ));
        assert!(dst.is_empty());
    }

    // ---- client: decoding (the decoder checklist) ----

    #[test]
    fn client_decode_empty_input_needs_more() {
        assert!(matches!(client_decode(b"").0, Ok(None)));
    }

    #[test]
    fn client_decode_one_byte_needs_more() {
        assert!(matches!(client_decode(b"%").0, Ok(None)));
    }

    #[test]
    fn client_decode_partial_frame_waits_for_cr() {
        let (out, buf) = client_decode(b"%01$WD13");
        assert!(matches!(out, Ok(None)));
        assert_eq!(buf.len(), 8);
    }

    #[test]
    fn client_decode_two_frames_in_one_buffer() {
        let mut codec = ClientCodec::new();
        let mut buf = BytesMut::from(&b"%01$WD13\r%01$RC021\r"[..]);
        assert_eq!(
            codec.decode(&mut buf).unwrap(),
            ok_response(st(1), Reply::WriteDt)
        );
        assert_eq!(
            codec.decode(&mut buf).unwrap(),
            ok_response(st(1), Reply::ReadContact(false))
        );
        assert_eq!(codec.decode(&mut buf).unwrap(), None);
    }

    #[test]
    fn client_decode_garbage_before_header_is_reported() {
        let mut codec = ClientCodec::new();
        let mut buf = BytesMut::from(&b"\x00zz%01$WD13\r"[..]);
        let skipped = codec.decode(&mut buf).unwrap();
        assert_eq!(
            skipped,
            Some(ClientEvent::Skipped(Bytes::from_static(b"\x00zz")))
        );
        assert_eq!(
            codec.decode(&mut buf).unwrap(),
            ok_response(st(1), Reply::WriteDt)
        );
    }

    #[test]
    fn client_decode_bad_bcc_is_a_frame_error() {
        let out = client_decode(b"%01$WD12\r").0;
        assert!(matches!(
            out,
            Err(CodecError::Frame(FrameError::BadBcc {
                expected: 0x13,
                found: 0x12
            }))
        ));
    }

    #[test]
    fn client_decode_over_long_frame_is_a_frame_error() {
        let long = [b"%01$RD".as_slice(), &[b'0'; 120]].concat();
        let out = client_decode(&long).0;
        assert!(matches!(
            out,
            Err(CodecError::Frame(FrameError::FrameTooLong { max: 118, .. }))
        ));
    }

    #[test]
    fn client_decode_error_reply_is_a_plc_error_not_a_codec_error() {
        let out = client_decode(b"%01!6102\r").0.unwrap();
        let refusal = Err(PlcError {
            code: PlcErrorCode::DataError,
        });
        assert_eq!(out, Some(ClientEvent::Response(addressed(st(1), refusal))));
    }

    #[test]
    fn client_decode_the_eight_word_write_reply() {
        assert_eq!(
            client_decode(b"%01$WD13\r").0.unwrap(),
            ok_response(st(1), Reply::WriteDt)
        );
    }

    #[test]
    fn client_decode_ee_reply_keeps_the_station() {
        let mut wire = BytesMut::new();
        ServerCodec::new()
            .encode(addressed(Station::ANY, Ok(Reply::WriteDt)), &mut wire)
            .unwrap();
        assert_eq!(
            client_decode(&wire).0.unwrap(),
            ok_response(Station::ANY, Reply::WriteDt)
        );
    }

    #[test]
    fn client_joins_a_multi_frame_reply_and_asks_for_more() {
        let words: Vec<u16> = (0..40).collect();
        let mut wire = BytesMut::new();
        let mut server = ServerCodec::new();
        for frame in response_frames(Header::Percent, st(1), &Ok(Reply::ReadDt(words.clone()))) {
            server.encode(frame, &mut wire).unwrap();
        }
        let mut client = ClientCodec::new();
        let more = Some(ClientEvent::MoreFollows {
            header: Header::Percent,
            station: st(1),
        });
        assert_eq!(client.decode(&mut wire).unwrap(), more);
        assert_eq!(
            client.decode(&mut wire).unwrap(),
            ok_response(st(1), Reply::ReadDt(words))
        );
    }

    // ---- server: decoding (the decoder checklist) ----

    #[test]
    fn server_decode_empty_and_one_byte_need_more() {
        assert!(matches!(server_decode(b"").0, Ok(None)));
        assert!(matches!(server_decode(b"<").0, Ok(None)));
    }

    #[test]
    fn server_decode_partial_frame_waits_for_cr() {
        assert!(matches!(server_decode(b"%01#RT01").0, Ok(None)));
    }

    #[test]
    fn server_decodes_the_eight_word_write() {
        let wire = b"%01#WDD001000010700010000E803000088130000000000002A\r";
        let expected = Command::write_dt(100, vec![0x0100, 0, 1000, 0, 5000, 0, 0, 0]).unwrap();
        let out = server_decode(wire).0.unwrap();
        assert_eq!(
            out,
            Some(ServerEvent::Request(addressed(
                st(1),
                Request::Command(expected)
            )))
        );
    }

    #[test]
    fn server_decodes_a_2048_byte_angle_write_of_507_words() {
        let write = Command::write_dt(0, vec![0x5678; 507]).unwrap();
        let frame = write.to_frame(Header::Angle, st(1)).unwrap();
        let wire = frame.to_bytes().unwrap();
        assert_eq!(wire.len(), Header::Angle.max_frame_len());
        let out = server_decode(&wire).0.unwrap();
        let Some(ServerEvent::Request(request)) = out else {
            panic!("{out:?}")
        };
        assert_eq!(request.message, Request::Command(write));
    }

    #[test]
    fn server_decode_two_frames_in_one_buffer() {
        let mut codec = ServerCodec::new();
        let mut buf = BytesMut::from(&b"%01#RT01\r%01**&\r"[..]);
        let status = Some(ServerEvent::Request(addressed(
            st(1),
            Request::Command(Command::Status),
        )));
        assert_eq!(codec.decode(&mut buf).unwrap(), status);
        let next = Some(ServerEvent::Request(addressed(st(1), Request::NextFrame)));
        assert_eq!(codec.decode(&mut buf).unwrap(), next);
    }

    #[test]
    fn server_decode_garbage_before_header_is_reported() {
        let mut codec = ServerCodec::new();
        let mut buf = BytesMut::from(&b"\r\n%EE#RT00\r"[..]);
        assert_eq!(
            codec.decode(&mut buf).unwrap(),
            Some(ServerEvent::Skipped(Bytes::from_static(b"\r\n")))
        );
        let status = Some(ServerEvent::Request(addressed(
            Station::ANY,
            Request::Command(Command::Status),
        )));
        assert_eq!(codec.decode(&mut buf).unwrap(), status);
    }

    #[test]
    fn server_decode_bad_bcc_and_over_long_frame_are_frame_errors() {
        assert!(matches!(
            server_decode(b"%01#RT02\r").0,
            Err(CodecError::Frame(FrameError::BadBcc { .. }))
        ));
        let long = [b"<01#WDD".as_slice(), &[b'0'; 2100]].concat();
        let out = server_decode(&long).0;
        assert!(matches!(
            out,
            Err(CodecError::Frame(FrameError::FrameTooLong {
                max: 2048,
                ..
            }))
        ));
    }

    #[test]
    fn server_decode_broadcast_command() {
        let out = server_decode(b"%FF#RT00\r").0.unwrap();
        let status = Some(ServerEvent::Request(addressed(
            Station::BROADCAST,
            Request::Command(Command::Status),
        )));
        assert_eq!(out, status);
    }

    #[test]
    fn server_decode_invalid_command_keeps_station_for_an_error_reply() {
        let out = server_decode(b"%01#XX**\r").0.unwrap();
        let Some(ServerEvent::Invalid { station, error, .. }) = out else {
            panic!("{out:?}")
        };
        assert_eq!(station, st(1));
        assert_eq!(error.plc_code(), PlcErrorCode::NotSupported);
    }

    #[test]
    fn server_decode_error_reply_is_not_a_command() {
        let out = server_decode(b"%01!6102\r").0.unwrap();
        assert!(matches!(
            out,
            Some(ServerEvent::Invalid {
                error: MessageError::BadMarker { .. },
                ..
            })
        ));
    }

    // ---- server: encoding ----

    #[test]
    fn server_encodes_golden_replies() {
        let mut wire = BytesMut::new();
        let mut codec = ServerCodec::new();
        codec
            .encode(addressed(st(1), Ok(Reply::WriteDt)), &mut wire)
            .unwrap();
        codec
            .encode(addressed(st(1), Ok(Reply::ReadContact(false))), &mut wire)
            .unwrap();
        codec
            .encode(
                addressed(
                    st(1),
                    Err(PlcError {
                        code: PlcErrorCode::DataError,
                    }),
                ),
                &mut wire,
            )
            .unwrap();
        assert_eq!(&wire[..], b"%01$WD13\r%01$RC021\r%01!6102\r");
    }

    #[test]
    fn client_and_server_round_trip_a_read() {
        let read = Command::ReadDt(DtRange::new(100, 101).unwrap());
        let wire = encode_request(Request::Command(read.clone()), st(3));
        let Some(ServerEvent::Request(request)) = server_decode(&wire).0.unwrap() else {
            panic!()
        };
        assert_eq!(request.message, Request::Command(read.clone()));
        let mut reply_wire = BytesMut::new();
        let reply = Reply::ReadDt(vec![0xEC78, 0xFFFF]);
        ServerCodec::new()
            .encode(
                addressed(request.station, Ok(reply.clone())),
                &mut reply_wire,
            )
            .unwrap();
        assert_eq!(&reply_wire[3..14], b"$RD78ECFFFF");
        let Some(ClientEvent::Response(back)) = client_decode(&reply_wire).0.unwrap() else {
            panic!()
        };
        assert!(back.message.as_ref().unwrap().answers(&read));
    }
}
