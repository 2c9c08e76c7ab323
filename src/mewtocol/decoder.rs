//! The one frame decoder that client and server share: bytes in a `BytesMut` to [`Frame`]s.
//!
//! Check, then parse (as mini-redis does): first find out whether the buffer holds a whole frame
//! (a header, then a CR within the header's length limit), and only then take it apart.
//!
//! ```text
//!  buffer:  g a r b a g e % 0 1 $ R C 0 2 1 CR % 0 1 ...
//!           '-- Skipped --''------ Frame -----''-- need more bytes
//!  frame:   HEADER STATION BODY BCC [&] CR      (see super::frame)
//! ```
//!
//! Garbage before a header is dropped and *reported* as [`Decoded::Skipped`]. A bad frame is an
//! error, but its bytes are consumed first, so the next call carries on with what follows. The
//! decoder never panics and never holds more than one frame's worth of bytes waiting for a CR.

use bytes::{Buf, Bytes, BytesMut};

use super::frame::FrameError;
use super::frame::{BccMode, CR, ENVELOPE_LEN, Frame, Header, MORE, NO_CHECK, Station};
use super::frame::{bcc, parse_hex_byte};

/// What one call of [`FrameDecoder::decode`] found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decoded {
    /// Bytes before the next header that were dropped (noise, or the tail of a lost frame).
    Skipped(Bytes),
    /// One whole, BCC-checked frame.
    Frame(Frame),
}

/// Splits a byte stream into frames. Holds no state: everything lives in the caller's buffer.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrameDecoder;

impl FrameDecoder {
    /// Takes the next frame (or the garbage before it) off the front of `buf`.
    ///
    /// `Ok(None)`: `buf` holds only the start of a frame; call again with more bytes.
    /// `Err`: the bytes at the front were a bad frame; they have been removed from `buf`.
    pub fn decode(&mut self, buf: &mut BytesMut) -> Result<Option<Decoded>, FrameError> {
        match buf.iter().position(|&b| is_header(b)) {
            None if buf.is_empty() => Ok(None),
            None => Ok(Some(Decoded::Skipped(buf.split().freeze()))),
            Some(0) => {
                let Some(len) = check(buf)? else {
                    return Ok(None);
                };
                let raw = buf.split_to(len).freeze();
                parse(&raw).map(|frame| Some(Decoded::Frame(frame)))
            }
            Some(start) => Ok(Some(Decoded::Skipped(buf.split_to(start).freeze()))),
        }
    }
}

fn is_header(byte: u8) -> bool {
    Header::from_byte(byte).is_some()
}

/// With a header at `buf[0]`: the length of the whole frame (CR included) if it is all there.
/// Consumes the bad bytes of a frame cut off by a new header or longer than its limit.
fn check(buf: &mut BytesMut) -> Result<Option<usize>, FrameError> {
    let max = Header::from_byte(buf[0]).map_or(0, Header::max_frame_len);
    let window = &buf[1..buf.len().min(max)];
    match window.iter().position(|&b| b == CR || is_header(b)) {
        Some(i) if window[i] == CR => Ok(Some(i + 2)),
        Some(i) => {
            buf.advance(i + 1);
            Err(FrameError::Truncated { len: i + 1 })
        }
        None if buf.len() >= max => {
            buf.advance(1);
            Err(FrameError::FrameTooLong { len: max + 1, max })
        }
        None => Ok(None),
    }
}

/// Takes apart one whole frame `raw`, header to CR.
fn parse(raw: &Bytes) -> Result<Frame, FrameError> {
    let len = raw.len();
    let too_short = FrameError::FrameTooShort {
        len,
        min: ENVELOPE_LEN,
    };
    let header = Header::from_byte(raw[0]).ok_or(too_short.clone())?;
    if len < ENVELOPE_LEN {
        return Err(too_short);
    }
    let more = raw[len - 2] == MORE;
    let bcc_at = len - 3 - usize::from(more);
    if bcc_at < 3 {
        return Err(too_short);
    }
    let bcc = check_bcc(&raw[..bcc_at], [raw[bcc_at], raw[bcc_at + 1]])?;
    let station = Station::from_ascii([raw[1], raw[2]])?;
    Ok(Frame {
        header,
        station,
        body: raw.slice(3..bcc_at),
        bcc,
        more,
    })
}

/// Compares the BCC field with the XOR of `covered`; `**` passes unchecked.
fn check_bcc(covered: &[u8], field: [u8; 2]) -> Result<BccMode, FrameError> {
    if field == NO_CHECK {
        return Ok(BccMode::Unchecked);
    }
    let found = parse_hex_byte(field).ok_or(FrameError::BadBccDigits { found: field })?;
    let expected = bcc(covered);
    if found == expected {
        Ok(BccMode::Checked)
    } else {
        Err(FrameError::BadBcc { expected, found })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(bytes: &[u8]) -> (Result<Option<Decoded>, FrameError>, BytesMut) {
        let mut buf = BytesMut::from(bytes);
        let out = FrameDecoder.decode(&mut buf);
        (out, buf)
    }

    fn frame(bytes: &[u8]) -> Frame {
        match decode(bytes).0 {
            Ok(Some(Decoded::Frame(frame))) => frame,
            other => panic!("expected a frame, got {other:?}"),
        }
    }

    /// Decodes everything in `bytes`, fed `chunk` bytes at a time.
    fn decode_all(bytes: &[u8], chunk: usize) -> Vec<Result<Decoded, FrameError>> {
        let mut buf = BytesMut::new();
        let mut out = Vec::new();
        for piece in bytes.chunks(chunk) {
            buf.extend_from_slice(piece);
            loop {
                match FrameDecoder.decode(&mut buf) {
                    Ok(None) => break,
                    Ok(Some(item)) => out.push(Ok(item)),
                    Err(err) => out.push(Err(err)),
                }
            }
        }
        out
    }

    #[test]
    fn decode_empty_input_needs_more() {
        let (out, buf) = decode(b"");
        assert_eq!(out, Ok(None));
        assert!(buf.is_empty());
    }

    #[test]
    fn decode_one_header_byte_needs_more() {
        let (out, buf) = decode(b"%");
        assert_eq!(out, Ok(None));
        assert_eq!(&buf[..], b"%");
    }

    #[test]
    fn decode_one_garbage_byte_is_reported_as_skipped() {
        let (out, buf) = decode(b"x");
        assert_eq!(out, Ok(Some(Decoded::Skipped(Bytes::from_static(b"x")))));
        assert!(buf.is_empty());
    }

    #[test]
    fn decode_partial_frame_waits_for_cr() {
        let (out, buf) = decode(b"%01$RC021");
        assert_eq!(out, Ok(None));
        assert_eq!(buf.len(), 9, "nothing consumed");
    }

    #[test]
    fn decode_ok_reply_splits_envelope_from_body() {
        let got = frame(b"%01$RC021\r");
        assert_eq!(got.header, Header::Percent);
        assert_eq!(got.station, Station::new(1).unwrap());
        assert_eq!(&got.body[..], b"$RC0");
        assert_eq!((got.bcc, got.more), (BccMode::Checked, false));
    }

    #[test]
    fn decode_error_reply_is_a_frame() {
        // '%' '0' '1' '!' '6' '1' -> BCC 0x25^0x30^0x31^0x21^0x36^0x31 = 0x02
        let got = frame(b"%01!6102\r");
        assert_eq!(&got.body[..], b"!61");
    }

    #[test]
    fn decode_two_frames_in_one_buffer() {
        let mut buf = BytesMut::from(&b"%01$WD13\r%01$WC14\r"[..]);
        let first = FrameDecoder.decode(&mut buf).unwrap();
        let second = FrameDecoder.decode(&mut buf).unwrap();
        assert!(matches!(first, Some(Decoded::Frame(f)) if &f.body[..] == b"$WD"));
        assert!(matches!(second, Some(Decoded::Frame(f)) if &f.body[..] == b"$WC"));
        assert_eq!(FrameDecoder.decode(&mut buf), Ok(None));
    }

    #[test]
    fn decode_garbage_before_header_is_reported_then_frame_follows() {
        let mut buf = BytesMut::from(&b"\0\xffnoise%01$WD13\r"[..]);
        let skipped = FrameDecoder.decode(&mut buf).unwrap();
        assert_eq!(
            skipped,
            Some(Decoded::Skipped(Bytes::from_static(b"\0\xffnoise")))
        );
        assert!(matches!(
            FrameDecoder.decode(&mut buf),
            Ok(Some(Decoded::Frame(_)))
        ));
    }

    #[test]
    fn decode_bad_bcc_is_an_error_and_consumes_the_frame() {
        let (out, buf) = decode(b"%01$WD14\r%01$WC14\r");
        assert_eq!(
            out,
            Err(FrameError::BadBcc {
                expected: 0x13,
                found: 0x14
            })
        );
        assert_eq!(&buf[..], b"%01$WC14\r");
    }

    #[test]
    fn decode_non_hex_bcc_is_an_error() {
        let (out, _) = decode(b"%01$WDZZ\r");
        assert_eq!(out, Err(FrameError::BadBccDigits { found: *b"ZZ" }));
    }

    #[test]
    fn decode_no_check_bcc_is_accepted() {
        let got = frame(b"%01#RT**\r");
        assert_eq!(got.bcc, BccMode::Unchecked);
        assert_eq!(&got.body[..], b"#RT");
    }

    #[test]
    fn decode_over_long_frame_is_an_error_then_resyncs() {
        let mut bytes = b"%01$RD".to_vec();
        bytes.extend(std::iter::repeat_n(b'0', 200));
        bytes.extend_from_slice(b"\r%01$WD13\r");
        let out = decode_all(&bytes, bytes.len());
        assert_eq!(out[0], Err(FrameError::FrameTooLong { len: 119, max: 118 }));
        assert!(matches!(&out[1], Ok(Decoded::Skipped(s)) if s.len() == 2 + 3 + 200 + 1));
        assert!(matches!(&out[2], Ok(Decoded::Frame(f)) if &f.body[..] == b"$WD"));
    }

    #[test]
    fn decode_angle_header_allows_long_frames() {
        let mut bytes = b"<01$RD".to_vec();
        bytes.extend(std::iter::repeat_n(b'0', 400));
        let check = crate::mewtocol::frame::hex_byte(bcc(&bytes));
        bytes.extend_from_slice(&check);
        bytes.push(CR);
        assert_eq!(frame(&bytes).body.len(), 403);
    }

    #[test]
    fn decode_frame_cut_off_by_a_new_header_is_truncated() {
        let out = decode_all(b"%01$RD00%01$WD13\r", 64);
        assert_eq!(out[0], Err(FrameError::Truncated { len: 8 }));
        assert!(matches!(&out[1], Ok(Decoded::Frame(f)) if &f.body[..] == b"$WD"));
    }

    #[test]
    fn decode_too_short_frame_is_an_error() {
        assert_eq!(
            decode(b"%01\r").0,
            Err(FrameError::FrameTooShort { len: 4, min: 6 })
        );
        assert_eq!(
            decode(b"%01*&\r").0,
            Err(FrameError::FrameTooShort { len: 6, min: 6 })
        );
    }

    #[test]
    fn decode_bad_station_is_an_error() {
        assert_eq!(
            decode(b"%00#RT**\r").0,
            Err(FrameError::BadStation { found: *b"00" })
        );
    }

    #[test]
    fn decode_more_marker_after_bcc() {
        let got = frame(b"%01**&\r");
        assert!(got.is_next_frame_request());
        let mut first = b"%01$RD6400".to_vec();
        first.extend_from_slice(&crate::mewtocol::frame::hex_byte(bcc(&first)));
        first.extend_from_slice(b"&\r");
        let got = frame(&first);
        assert!(got.more);
        assert_eq!(&got.body[..], b"$RD6400");
    }

    #[test]
    fn decode_byte_by_byte_gives_the_same_frames() {
        let bytes = b"xx%01$WD13\r%01#RT01\r<01#RDD00000000014D\r";
        let whole = decode_all(bytes, bytes.len());
        let single = decode_all(bytes, 1);
        let frames = |v: &[Result<Decoded, FrameError>]| -> Vec<Frame> {
            v.iter()
                .filter_map(|d| match d {
                    Ok(Decoded::Frame(f)) => Some(f.clone()),
                    _ => None,
                })
                .collect()
        };
        assert_eq!(frames(&whole).len(), 3);
        assert_eq!(frames(&whole), frames(&single));
    }
}
