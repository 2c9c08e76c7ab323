//! IO. Serial line emulation: a stream wrapper that delivers bytes no faster than a serial line
//! at `baud` would, in both directions, on tokio time (so it works under paused time).
//!
//! ```text
//!  one character = start + 8 data + parity + stop = 11 bits   (PLC.md §1, "Serial settings")
//!  char_time = 11 / baud                  9600 baud: 1.146 ms a character
//!  read:  byte i of what the peer sent is released at  line_free + (i + 1) * char_time
//!  write: n bytes are handed on after n * char_time  (the line is busy meanwhile)
//! ```
//! Wrap the mock's end of a link ([`tokio::io::duplex`], a TCP connection, a pty) and the peer
//! sees a wire's timing without any real port.

use std::collections::VecDeque;
use std::future::Future;
use std::io;
use std::pin::Pin;
use std::task::{Context, Poll, ready};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::time::{Instant, Sleep};

/// Bits per character on the wire: start, 8 data, parity, stop.
pub const BITS_PER_CHAR: u32 = 11;

/// How long `bytes` characters take on a line at `baud`.
#[must_use]
pub fn wire_time(bytes: usize, baud: u32) -> Duration {
    Duration::from_secs_f64(bytes as f64 * f64::from(BITS_PER_CHAR) / f64::from(baud.max(1)))
}

/// A stream whose bytes take a serial line's time to pass, in both directions.
#[derive(Debug)]
pub struct WireStream<S> {
    inner: S,
    char_time: Duration,
    /// Received bytes not yet handed to the reader.
    rx: VecDeque<u8>,
    /// When the first byte of `rx` started on the line.
    rx_start: Instant,
    /// Bytes of the current `rx` batch already handed out.
    rx_taken: usize,
    /// When the receive line is free again (end of the last batch).
    rx_line_free: Instant,
    rx_sleep: Pin<Box<Sleep>>,
    /// A write in progress: its length and whether its wire time has passed.
    tx_pending: Option<usize>,
    tx_sleep: Pin<Box<Sleep>>,
}

impl<S> WireStream<S> {
    /// Wraps `inner` as a line at `baud` (11-bit characters).
    pub fn new(inner: S, baud: u32) -> Self {
        let now = Instant::now();
        Self {
            inner,
            char_time: wire_time(1, baud),
            rx: VecDeque::new(),
            rx_start: now,
            rx_taken: 0,
            rx_line_free: now,
            rx_sleep: Box::pin(tokio::time::sleep_until(now)),
            tx_pending: None,
            tx_sleep: Box::pin(tokio::time::sleep_until(now)),
        }
    }

    /// The wrapped stream.
    pub fn into_inner(self) -> S {
        self.inner
    }

    /// When byte number `i` (from 0) of the current batch has fully arrived.
    fn rx_due(&self, i: usize) -> Instant {
        self.rx_start + self.char_time * (i as u32 + 1)
    }

    /// Bytes of the batch that have arrived by now and are not handed out yet.
    fn rx_released(&self, now: Instant) -> usize {
        let elapsed = now.saturating_duration_since(self.rx_start);
        let arrived = (elapsed.as_nanos() / self.char_time.as_nanos().max(1)) as usize;
        arrived.saturating_sub(self.rx_taken).min(self.rx.len())
    }
}

impl<S: AsyncRead + Unpin> WireStream<S> {
    /// Fills `rx` from the inner stream; `Ok(false)` at its end.
    fn poll_fill(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<bool>> {
        let mut chunk = [0_u8; 512];
        let mut buf = ReadBuf::new(&mut chunk);
        ready!(Pin::new(&mut self.inner).poll_read(cx, &mut buf))?;
        if buf.filled().is_empty() {
            return Poll::Ready(Ok(false));
        }
        self.rx.extend(buf.filled());
        self.rx_start = Instant::now().max(self.rx_line_free);
        self.rx_taken = 0;
        self.rx_line_free = self.rx_due(self.rx.len() - 1);
        Poll::Ready(Ok(true))
    }
}

impl<S: AsyncRead + Unpin> AsyncRead for WireStream<S> {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        if this.rx.is_empty() && !ready!(this.poll_fill(cx))? {
            return Poll::Ready(Ok(()));
        }
        loop {
            let n = this.rx_released(Instant::now()).min(buf.remaining());
            if n > 0 {
                let bytes: Vec<u8> = this.rx.drain(..n).collect();
                this.rx_taken += n;
                buf.put_slice(&bytes);
                return Poll::Ready(Ok(()));
            }
            let due = this.rx_due(this.rx_taken);
            this.rx_sleep.as_mut().reset(due);
            ready!(this.rx_sleep.as_mut().poll(cx));
        }
    }
}

impl<S: AsyncWrite + Unpin> AsyncWrite for WireStream<S> {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let this = self.get_mut();
        if buf.is_empty() {
            return Poll::Ready(Ok(0));
        }
        let len = if let Some(len) = this.tx_pending {
            len.min(buf.len())
        } else {
            let len = buf.len();
            this.tx_pending = Some(len);
            let due = Instant::now() + this.char_time * len as u32;
            this.tx_sleep.as_mut().reset(due);
            len
        };
        ready!(this.tx_sleep.as_mut().poll(cx));
        let written = ready!(Pin::new(&mut this.inner).poll_write(cx, &buf[..len]));
        this.tx_pending = None;
        Poll::Ready(written)
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_shutdown(cx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    #[test]
    fn one_character_at_9600_baud_takes_11_bits() {
        let t = wire_time(1, 9600).as_secs_f64();
        assert!((t - 11.0 / 9600.0).abs() < 1e-9, "{t}");
    }

    #[tokio::test(start_paused = true)]
    async fn reads_arrive_at_line_speed() {
        let (mut peer, ours) = tokio::io::duplex(1024);
        let mut wire = WireStream::new(ours, 9600);
        let started = Instant::now();
        peer.write_all(&[0x55; 96]).await.unwrap();
        let mut got = [0_u8; 96];
        wire.read_exact(&mut got).await.unwrap();
        assert!(started.elapsed() >= wire_time(96, 9600));
        assert!(started.elapsed() < wire_time(97, 9600));
    }

    #[tokio::test(start_paused = true)]
    async fn writes_leave_at_line_speed() {
        let (mut peer, ours) = tokio::io::duplex(1024);
        let mut wire = WireStream::new(ours, 19_200);
        let started = Instant::now();
        wire.write_all(&[0xAA; 192]).await.unwrap();
        assert!(started.elapsed() >= wire_time(192, 19_200));
        let mut got = [0_u8; 192];
        peer.read_exact(&mut got).await.unwrap();
        assert_eq!(got, [0xAA; 192]);
    }
}
