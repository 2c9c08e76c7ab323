//! The harness both fuzz targets share: decode the input twice, all at once and fed in chunks,
//! and check that the decoder never panics, always makes progress, waits without consuming, and
//! gives the same events either way.

use std::fmt::Debug;

use bytes::BytesMut;
use tokio_util::codec::Decoder;

/// What a target tells the harness about its codec's events.
pub trait Events: Decoder<Item: Debug, Error: std::fmt::Display> {
    /// The bytes an event reports as skipped garbage, if it is such an event.
    fn skipped(event: &Self::Item) -> Option<&[u8]>;
    /// Checks a decoded event (e.g. that it re-encodes to what it was decoded from).
    fn check(event: &Self::Item);
}

/// Runs one fuzz input: its first byte picks a chunk size, the rest is decoded both ways.
pub fn fuzz<C: Events>(data: &[u8], new: impl Fn() -> C) {
    let Some((&split, bytes)) = data.split_first() else { return };
    let whole = run(&mut new(), bytes, bytes.len().max(1));
    let chunked = run(&mut new(), bytes, usize::from(split % 17) + 1);
    assert_eq!(whole, chunked);
}

/// Decodes `bytes` fed `chunk` bytes at a time; returns the events, consecutive skips merged.
fn run<C: Events>(codec: &mut C, bytes: &[u8], chunk: usize) -> Vec<String> {
    let mut buf = BytesMut::new();
    let mut events = Vec::new();
    let mut skipped = Vec::new();
    for piece in bytes.chunks(chunk) {
        buf.extend_from_slice(piece);
        loop {
            let before = buf.len();
            let event = match codec.decode(&mut buf) {
                Ok(None) => {
                    assert_eq!(buf.len(), before, "need-more consumed bytes");
                    break;
                }
                Ok(Some(event)) => match C::skipped(&event) {
                    Some(bytes) => {
                        assert!(!bytes.is_empty());
                        skipped.extend_from_slice(bytes);
                        None
                    }
                    None => {
                        C::check(&event);
                        Some(format!("{event:?}"))
                    }
                },
                Err(err) => Some(format!("error: {err}")),
            };
            assert!(buf.len() < before, "decoder made no progress");
            if let Some(event) = event {
                flush(&mut events, &mut skipped);
                events.push(event);
            }
        }
    }
    flush(&mut events, &mut skipped);
    events
}

fn flush(events: &mut Vec<String>, skipped: &mut Vec<u8>) {
    if !skipped.is_empty() {
        events.push(format!("skipped {skipped:?}"));
        skipped.clear();
    }
}

impl Events for linterpd::mewtocol::ClientCodec {
    fn skipped(event: &Self::Item) -> Option<&[u8]> {
        match event {
            linterpd::mewtocol::ClientEvent::Skipped(bytes) => Some(bytes),
            _ => None,
        }
    }

    /// Every decoded response re-encodes to text that parses back to it.
    fn check(event: &Self::Item) {
        use linterpd::mewtocol::{ClientEvent, encode_response, parse_response};
        if let ClientEvent::Response(response) = event {
            let body = encode_response(&response.message);
            assert_eq!(parse_response(&body).as_ref(), Ok(&response.message), "{body:?}");
        }
    }
}

impl Events for linterpd::mewtocol::ServerCodec {
    fn skipped(event: &Self::Item) -> Option<&[u8]> {
        match event {
            linterpd::mewtocol::ServerEvent::Skipped(bytes) => Some(bytes),
            _ => None,
        }
    }

    /// Every decoded command re-encodes under its own header to text that parses back to it,
    /// and into a frame that fits that header.
    fn check(event: &Self::Item) {
        use linterpd::mewtocol::{Command, Request, ServerEvent};
        if let ServerEvent::Request(request) = event
            && let Request::Command(command) = &request.message
        {
            let body = command.encode_body(request.header).expect("a decoded command re-encodes");
            assert_eq!(Command::parse(&body).as_ref(), Ok(command), "{body:?}");
            let frame = command.to_frame(request.header, request.station).expect("fits its frame");
            let mut wire = BytesMut::new();
            frame.encode(&mut wire).expect("frame fits its header");
        }
    }
}
