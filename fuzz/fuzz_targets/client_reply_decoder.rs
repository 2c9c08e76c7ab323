//! Fuzzes the host's reply decoder (`ClientCodec`, over the shared frame decoder).
//!
//! The first input byte picks a chunk size; the rest is decoded twice, all at once and fed in
//! chunks. Checked: no panic; `Ok(None)` consumes nothing, anything else consumes something (no
//! endless loop); both feedings give the same events; every decoded response re-encodes to text
//! that parses back to it.
#![no_main]

use bytes::BytesMut;
use libfuzzer_sys::fuzz_target;
use linterpd::mewtocol::{ClientCodec, ClientEvent, encode_response, parse_response};
use tokio_util::codec::Decoder;

fuzz_target!(|data: &[u8]| {
    let Some((&split, bytes)) = data.split_first() else { return };
    let whole = run(bytes, bytes.len().max(1));
    let chunked = run(bytes, usize::from(split % 17) + 1);
    assert_eq!(whole, chunked);
});

/// Decodes `bytes` fed `chunk` bytes at a time; returns the events, consecutive skips merged.
fn run(bytes: &[u8], chunk: usize) -> Vec<String> {
    let mut codec = ClientCodec::new();
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
                Ok(Some(ClientEvent::Skipped(bytes))) => {
                    assert!(!bytes.is_empty());
                    skipped.extend_from_slice(&bytes);
                    None
                }
                Ok(Some(event)) => {
                    check_round_trip(&event);
                    Some(format!("{event:?}"))
                }
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

fn check_round_trip(event: &ClientEvent) {
    if let ClientEvent::Response(response) = event {
        let body = encode_response(&response.message);
        assert_eq!(parse_response(&body).as_ref(), Ok(&response.message), "{body:?}");
    }
}
