//! The Modbus face's guard in front of tokio-modbus's server codec. That codec refuses a write
//! whose quantity, byte count and length do not make a request it can decode (above all a
//! Write Multiple Registers of more than 123 registers, whose PDU is over 253 bytes) with an IO
//! error, and its server then closes the connection. The Modbus Application Protocol
//! (v1.1b3, §6.11, §6.12) wants exception 03 (illegal data value) for such a request, and the
//! connection kept. So each request frame is looked at before the codec sees it: a write of
//! coils (15) or registers (16) that is not well formed is handed on as the same write with no
//! values, which the codec decodes and `map::ask` answers with exception 03 like any quantity
//! out of range. Every other frame goes through untouched. No Modbus is decoded here beyond
//! the MBAP header's length and those two functions' quantity and byte count.
//!
//! ```text
//!  MBAP header (Modbus Messaging on TCP/IP Implementation Guide v1.0b §3.1.3), then the PDU
//!  | transaction (2) | protocol 0 (2) | length (2) = 1 + PDU | unit (1) |
//!  15 / 16: | function (1) | address (2) | quantity (2) | byte count (1) | values (byte count) |
//!  a 15 / 16 frame not well formed  ->  | function | address | 0x0000 | 0x00 |  (length 7)
//! ```

use std::borrow::Cow;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, ready};

use bytes::{Buf, BytesMut};
use tokio::io::{AsyncRead, ReadBuf};

use crate::plc::{ReadFilter, ReadFiltered};

use super::map::{MAX_WRITE_COILS, MAX_WRITE_REGISTERS};

/// The MBAP header's size, bytes.
const MBAP_BYTES: usize = 7;
/// The largest PDU (Modbus Application Protocol v1.1b3 §4.1: 256 bytes of serial ADU less
/// address and CRC).
const MAX_PDU_BYTES: usize = 253;
/// The bytes a 15 / 16 request has before its values: function, address, quantity, count.
const WRITE_HEAD_BYTES: usize = 6;
/// Write Multiple Coils.
const WRITE_COILS: u8 = 0x0F;
/// Write Multiple Registers.
const WRITE_REGISTERS: u8 = 0x10;

/// The frame tokio-modbus should see for the request frame `frame` (a whole MBAP frame): itself,
/// or for a 15 / 16 write that is not well formed, the same write with no values.
pub(super) fn screen(frame: &[u8]) -> Cow<'_, [u8]> {
    let Some(pdu) = frame.get(MBAP_BYTES..) else {
        return Cow::Borrowed(frame);
    };
    match pdu.first() {
        Some(&function @ (WRITE_COILS | WRITE_REGISTERS)) if !well_formed(function, pdu) => {
            Cow::Owned(emptied(frame, function, pdu))
        }
        _ => Cow::Borrowed(frame),
    }
}

/// Whether a 15 / 16 PDU has a quantity within its bounds, the byte count it implies and that
/// many bytes of values.
fn well_formed(function: u8, pdu: &[u8]) -> bool {
    if pdu.len() < WRITE_HEAD_BYTES || pdu.len() > MAX_PDU_BYTES {
        return false;
    }
    let quantity = usize::from(u16::from_be_bytes([pdu[3], pdu[4]]));
    let count = usize::from(pdu[5]);
    let (most, bytes) = if function == WRITE_REGISTERS {
        (MAX_WRITE_REGISTERS, quantity * 2)
    } else {
        (MAX_WRITE_COILS, quantity.div_ceil(8))
    };
    (1..=most).contains(&quantity) && count == bytes && pdu.len() == WRITE_HEAD_BYTES + count
}

/// `frame`'s header with the length of a write of no values, and that write.
fn emptied(frame: &[u8], function: u8, pdu: &[u8]) -> Vec<u8> {
    let address = [
        pdu.get(1).copied().unwrap_or(0),
        pdu.get(2).copied().unwrap_or(0),
    ];
    let length = (1 + WRITE_HEAD_BYTES) as u16;
    let mut out = Vec::with_capacity(MBAP_BYTES + WRITE_HEAD_BYTES);
    out.extend_from_slice(&frame[..4]);
    out.extend_from_slice(&length.to_be_bytes());
    out.push(frame[6]);
    out.extend_from_slice(&[function, address[0], address[1], 0, 0, 0]);
    out
}

/// The size of the whole frame at the start of `raw`, once its header's length is there; `Some(0)`
/// for a length of 0, which no frame has (the rest is handed on for the codec to refuse).
fn frame_bytes(raw: &[u8]) -> Option<usize> {
    let length = usize::from(u16::from_be_bytes([*raw.get(4)?, *raw.get(5)?]));
    Some(if length == 0 { 0 } else { 6 + length })
}

/// A connection's stream with every request frame [`screen`]ed on its way in; writes go
/// straight through.
pub(super) type Screened<S> = ReadFiltered<S, Screen>;

/// `inner` with every request frame [`screen`]ed on its way in.
pub(super) fn screened<S>(inner: S) -> Screened<S> {
    ReadFiltered::new(inner, Screen::default())
}

/// The screening of a connection's reads.
#[derive(Debug, Default)]
pub(super) struct Screen {
    /// Bytes read, not yet a whole frame.
    raw: BytesMut,
    /// Screened bytes for the codec.
    ready: BytesMut,
    /// A frame header was not one: everything from there goes through as read.
    unframed: bool,
    eof: bool,
}

impl Screen {
    /// Moves every whole frame of `raw` to `ready`, screened.
    fn take_frames(&mut self) {
        while !self.raw.is_empty() {
            if self.unframed {
                self.ready.extend_from_slice(&self.raw.split());
                return;
            }
            match frame_bytes(&self.raw) {
                Some(0) => self.unframed = true,
                Some(n) if self.raw.len() >= n => {
                    let frame = self.raw.split_to(n);
                    self.ready.extend_from_slice(&screen(&frame));
                }
                _ => return,
            }
        }
    }
}

impl<S: AsyncRead + Unpin> ReadFilter<S> for Screen {
    fn poll_read(
        &mut self,
        inner: &mut S,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        loop {
            if !self.ready.is_empty() {
                let n = self.ready.len().min(buf.remaining());
                buf.put_slice(&self.ready[..n]);
                self.ready.advance(n);
                return Poll::Ready(Ok(()));
            }
            if self.eof {
                // A partial frame at the end goes on as it is: the codec says what it makes of it.
                self.ready = self.raw.split();
                if self.ready.is_empty() {
                    return Poll::Ready(Ok(()));
                }
                continue;
            }
            let mut chunk = [0; 1_024];
            let mut read = ReadBuf::new(&mut chunk);
            ready!(Pin::new(&mut *inner).poll_read(cx, &mut read))?;
            if read.filled().is_empty() {
                self.eof = true;
            } else {
                self.raw.extend_from_slice(read.filled());
                self.take_frames();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    /// A Write Multiple Registers frame of `n` words at DT100, transaction 0x0102, unit 1.
    fn write_registers(n: u16) -> Vec<u8> {
        let count = (n * 2) as u8; // wraps past 127 words, as a client's might
        let values = usize::from(n) * 2;
        let mut frame = vec![0x01, 0x02, 0, 0];
        frame.extend_from_slice(&((1 + WRITE_HEAD_BYTES + values) as u16).to_be_bytes());
        frame.push(1); // unit
        frame.extend_from_slice(&[0x10, 0, 100]); // function, address DT100
        frame.extend_from_slice(&n.to_be_bytes()); // quantity
        frame.push(count);
        frame.extend(std::iter::repeat_n(0xAB, values));
        frame
    }

    /// A Write Multiple Coils frame of `n` coils at 0.
    fn write_coils(n: u16) -> Vec<u8> {
        let count = usize::from(n).div_ceil(8);
        let mut frame = vec![0, 9, 0, 0];
        frame.extend_from_slice(&((1 + WRITE_HEAD_BYTES + count) as u16).to_be_bytes());
        frame.extend_from_slice(&[1, 0x0F, 0, 0]);
        frame.extend_from_slice(&n.to_be_bytes());
        frame.push(count as u8);
        frame.extend(std::iter::repeat_n(0xFF, count));
        frame
    }

    /// The write of no values `screen` hands on for `frame`.
    fn emptied_write(frame: &[u8]) -> Vec<u8> {
        let mut out = frame[..4].to_vec();
        out.extend_from_slice(&[0, 7, frame[6], frame[7], frame[8], frame[9], 0, 0, 0]);
        out
    }

    #[test]
    fn a_write_of_124_registers_is_handed_on_as_a_write_of_none() {
        let over = write_registers(124);
        assert_eq!(over.len(), MBAP_BYTES + 254, "a PDU over 253 bytes");
        assert_eq!(screen(&over).as_ref(), emptied_write(&over).as_slice());
        let most = write_registers(123);
        assert_eq!(screen(&most).as_ref(), most.as_slice(), "123 goes through");
        let wrapped = write_registers(200);
        assert_eq!(
            screen(&wrapped).as_ref(),
            emptied_write(&wrapped).as_slice()
        );
    }

    #[test]
    fn a_write_of_more_than_1968_coils_is_handed_on_as_a_write_of_none() {
        for n in [1_969, 1_976, 2_000] {
            let over = write_coils(n);
            assert_eq!(
                screen(&over).as_ref(),
                emptied_write(&over).as_slice(),
                "{n}"
            );
        }
        let most = write_coils(1_968);
        assert_eq!(screen(&most).as_ref(), most.as_slice());
    }

    #[test]
    fn a_byte_count_that_does_not_match_its_quantity_is_emptied() {
        let mut frame = write_registers(2);
        frame[12] = 3; // byte count 3 for 2 registers
        assert_eq!(screen(&frame).as_ref(), emptied_write(&frame).as_slice());
        let mut short = write_registers(2);
        short.truncate(short.len() - 1);
        short[5] -= 1; // one value byte fewer than the count says
        assert_eq!(screen(&short).as_ref(), emptied_write(&short).as_slice());
    }

    #[test]
    fn other_functions_go_through_untouched() {
        // Read Holding Registers, 126 of them: the codec decodes it, map::ask answers 03.
        let read = [0, 1, 0, 0, 0, 6, 1, 0x03, 0, 0, 0, 126];
        assert_eq!(screen(&read).as_ref(), read.as_slice());
        let header_only = [0, 1, 0, 0, 0, 1, 1];
        assert_eq!(screen(&header_only).as_ref(), header_only.as_slice());
    }

    #[tokio::test]
    async fn frames_split_and_joined_across_reads_are_screened_in_order() {
        let over = write_registers(124);
        let read = [0, 1, 0, 0, 0, 6, 1, 0x03, 0, 0, 0, 1];
        let mut sent = over.clone();
        sent.extend_from_slice(&read);
        let (mut client, server) = tokio::io::duplex(64);
        let writer = tokio::spawn(async move {
            // One byte, then the rest in pieces the 64-byte pipe cuts.
            client.write_all(&sent[..1]).await.unwrap();
            client.write_all(&sent[1..]).await.unwrap();
        });
        let mut screened = screened(server);
        let mut got = Vec::new();
        screened.read_to_end(&mut got).await.unwrap();
        writer.await.unwrap();
        let mut expected = emptied_write(&over);
        expected.extend_from_slice(&read);
        assert_eq!(got, expected);
    }

    #[tokio::test]
    async fn a_partial_frame_at_the_end_goes_through_as_read() {
        let (mut client, server) = tokio::io::duplex(64);
        client
            .write_all(&[0, 1, 0, 0, 0, 6, 1, 0x03])
            .await
            .unwrap();
        drop(client);
        let mut got = Vec::new();
        screened(server).read_to_end(&mut got).await.unwrap();
        assert_eq!(got, [0, 1, 0, 0, 0, 6, 1, 0x03]);
    }
}
