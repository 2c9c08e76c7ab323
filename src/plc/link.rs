//! IO. Opening a PLC's byte stream (a serial port or a TCP connection), a stream handle the Modbus
//! client can take back from tokio-modbus, draining late bytes off a stream, and a stream whose
//! reads pass through a filter (the Modbus servers' guards) while its writes go straight through.
//!
//! The protocol clients never open anything themselves: they are generic over
//! [`AsyncRead`] + [`AsyncWrite`], so tests run them over `tokio::io::duplex`, a pseudo-terminal or
//! TCP alike.

use std::fmt::Debug;
use std::io;
use std::pin::Pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll};
use std::time::Duration;

use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, ReadBuf};
use tokio::net::TcpStream;
use tokio_serial::SerialPortBuilderExt;

use super::PlcError;
use super::settings::{Parity, SerialSettings, TcpSettings};

/// Bytes at most thrown away by one [`drain`]; a line that keeps talking beyond this is broken.
const DRAIN_LIMIT: usize = 64 * 1024;

/// A byte stream a PLC client can run over.
pub trait ByteStream: AsyncRead + AsyncWrite + Unpin + Send + Debug {}

impl<T: AsyncRead + AsyncWrite + Unpin + Send + Debug> ByteStream for T {}

/// An opened link: a serial port or a TCP stream.
pub type BoxedLink = Box<dyn ByteStream>;

/// How [`open_serial`] names its operation in an error.
const OPEN_SERIAL: &str = "open serial port";
/// How [`open_tcp`] names its operation in an error.
const CONNECT: &str = "connect to";

/// Opens a serial port with the settings' framing.
pub fn open_serial(settings: &SerialSettings) -> Result<BoxedLink, PlcError> {
    let operation = || format!("{OPEN_SERIAL} {}", settings.path);
    let data_bits = match settings.data_bits {
        7 => tokio_serial::DataBits::Seven,
        _ => tokio_serial::DataBits::Eight,
    };
    let stop_bits = match settings.stop_bits {
        2 => tokio_serial::StopBits::Two,
        _ => tokio_serial::StopBits::One,
    };
    let parity = match settings.parity {
        Parity::None => tokio_serial::Parity::None,
        Parity::Odd => tokio_serial::Parity::Odd,
        Parity::Even => tokio_serial::Parity::Even,
    };
    let port = tokio_serial::new(&settings.path, settings.baud)
        .data_bits(data_bits)
        .stop_bits(stop_bits)
        .parity(parity)
        .open_native_async()
        .map_err(|e| PlcError::Link {
            operation: operation(),
            source: io::Error::from(e),
        })?;
    Ok(Box::new(port))
}

/// Connects to a TCP peer within the settings' connect timeout.
pub async fn open_tcp(settings: &TcpSettings) -> Result<BoxedLink, PlcError> {
    let operation = || format!("{CONNECT} {}", settings.address);
    let connect = TcpStream::connect(settings.address.as_str());
    let stream = tokio::time::timeout(settings.connect_timeout, connect)
        .await
        .map_err(|_| PlcError::Timeout {
            operation: operation(),
            timeout_ms: settings.connect_timeout.as_millis() as u64,
        })?
        .map_err(|source| PlcError::Link {
            operation: operation(),
            source,
        })?;
    stream.set_nodelay(true).map_err(|source| PlcError::Link {
        operation: operation(),
        source,
    })?;
    Ok(Box::new(stream))
}

/// What an operator can do about a link that would not open, for the log line that reports it:
/// a serial port refused to the service user (EACCES), a serial path that is not there (ENOENT; the
/// serial library reports a port another program holds the same way), a TCP peer that refused or
/// did not answer. `None` for anything else.
#[must_use]
pub fn open_hint(e: &PlcError) -> Option<&'static str> {
    match e {
        PlcError::Link { operation, source } if operation.starts_with(OPEN_SERIAL) => {
            match source.kind() {
                io::ErrorKind::PermissionDenied => Some(
                    "add the service user to the `dialout` group (or the group that owns the port)",
                ),
                io::ErrorKind::NotFound => Some(
                    "no such serial port (or another program holds it): check `path` against ls /dev/serial/by-id/",
                ),
                _ => None,
            }
        }
        PlcError::Link { operation, source }
            if operation.starts_with(CONNECT)
                && matches!(
                    source.kind(),
                    io::ErrorKind::ConnectionRefused
                        | io::ErrorKind::TimedOut
                        | io::ErrorKind::HostUnreachable
                        | io::ErrorKind::NetworkUnreachable
                ) =>
        {
            Some("is the PLC (or gateway) reachable and in RUN?")
        }
        PlcError::Timeout { operation, .. } if operation.starts_with(CONNECT) => {
            Some("is the PLC (or gateway) reachable and in RUN?")
        }
        _ => None,
    }
}

/// Reads and throws away whatever arrives until the stream stays quiet for `quiet`: a late reply
/// to a timed-out request must never be taken for the answer to the next one. Returns the bytes
/// dropped.
pub async fn drain<T: AsyncRead + Unpin>(stream: &mut T, quiet: Duration) -> io::Result<usize> {
    let mut buf = [0_u8; 256];
    let mut dropped = 0;
    while dropped < DRAIN_LIMIT {
        match tokio::time::timeout(quiet, stream.read(&mut buf)).await {
            Err(_) | Ok(Ok(0)) => break,
            Ok(Ok(n)) => dropped += n,
            Ok(Err(e)) => return Err(e),
        }
    }
    if dropped > 0 {
        tracing::debug!(bytes = dropped, "drained late bytes off the link");
    }
    Ok(dropped)
}

/// A stream shared between a protocol library that takes ownership of its transport and the
/// client that must get it back (to drain it and attach anew). Clones are handles to one stream;
/// only one of them is used at a time.
#[derive(Debug)]
pub struct SharedStream<T> {
    inner: Arc<Mutex<T>>,
}

impl<T> Clone for SharedStream<T> {
    fn clone(&self) -> Self {
        Self {
            inner: Arc::clone(&self.inner),
        }
    }
}

impl<T> SharedStream<T> {
    /// Wraps `stream`.
    pub fn new(stream: T) -> Self {
        Self {
            inner: Arc::new(Mutex::new(stream)),
        }
    }

    fn lock(&self) -> MutexGuard<'_, T> {
        // A panic while polling leaves the stream as it was: keep using it.
        self.inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl<T: AsyncRead + Unpin> AsyncRead for SharedStream<T> {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut *self.lock()).poll_read(cx, buf)
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for SharedStream<T> {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut *self.lock()).poll_write(cx, buf)
    }

    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut *self.lock()).poll_flush(cx)
    }

    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut *self.lock()).poll_shutdown(cx)
    }
}

/// What a [`ReadFiltered`] stream makes of its reads: bytes from the stream beneath, changed,
/// held back or cut off.
pub trait ReadFilter<S> {
    /// Fills `buf` as [`AsyncRead::poll_read`] does, reading `inner` as it needs.
    fn poll_read(
        &mut self,
        inner: &mut S,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>>;
}

/// A byte stream whose reads pass through a [`ReadFilter`] and whose writes go straight to the
/// stream beneath.
#[derive(Debug)]
pub struct ReadFiltered<S, F> {
    inner: S,
    filter: F,
}

impl<S, F> ReadFiltered<S, F> {
    /// `inner`, its reads through `filter`.
    pub fn new(inner: S, filter: F) -> Self {
        Self { inner, filter }
    }
}

impl<S: AsyncRead + Unpin, F: ReadFilter<S> + Unpin> AsyncRead for ReadFiltered<S, F> {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let this = self.get_mut();
        this.filter.poll_read(&mut this.inner, cx, buf)
    }
}

impl<S: AsyncWrite + Unpin, F: Unpin> AsyncWrite for ReadFiltered<S, F> {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.get_mut().inner).poll_write(cx, buf)
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
    use tokio::io::AsyncWriteExt;

    fn link_error(operation: &str, kind: io::ErrorKind) -> PlcError {
        PlcError::Link {
            operation: operation.to_owned(),
            source: kind.into(),
        }
    }

    #[test]
    fn open_hints_name_the_fix_for_each_open_failure() {
        let serial = "open serial port /dev/ttyUSB0";
        let dialout = open_hint(&link_error(serial, io::ErrorKind::PermissionDenied));
        assert!(dialout.unwrap().contains("`dialout` group"));
        let missing = open_hint(&link_error(serial, io::ErrorKind::NotFound));
        assert!(missing.unwrap().starts_with("no such serial port"));
        let tcp = "connect to 10.0.0.5:9094";
        for kind in [io::ErrorKind::ConnectionRefused, io::ErrorKind::TimedOut] {
            let hint = open_hint(&link_error(tcp, kind));
            assert_eq!(hint, Some("is the PLC (or gateway) reachable and in RUN?"));
        }
        let timeout = PlcError::Timeout {
            operation: tcp.to_owned(),
            timeout_ms: 3000,
        };
        assert!(open_hint(&timeout).is_some());
        // Failures after the link opened get no open hint.
        assert_eq!(
            open_hint(&link_error("read DT1000", io::ErrorKind::PermissionDenied)),
            None
        );
        assert_eq!(
            open_hint(&link_error(serial, io::ErrorKind::InvalidInput)),
            None
        );
    }

    #[test]
    fn a_serial_path_that_is_not_there_gets_the_no_such_port_hint() {
        let settings = SerialSettings {
            path: "/dev/linterpd-no-such-tty".into(),
            baud: 19200,
            data_bits: 8,
            parity: Parity::Odd,
            stop_bits: 1,
        };
        let e = open_serial(&settings).expect_err("no such device");
        assert!(
            open_hint(&e).unwrap().starts_with("no such serial port"),
            "{e}"
        );
    }

    #[tokio::test]
    async fn a_refused_tcp_connection_gets_the_reachable_hint() {
        // A port that was just free: nothing listens there any more.
        let address = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .to_string();
        let settings = TcpSettings {
            address,
            connect_timeout: Duration::from_secs(2),
        };
        let e = open_tcp(&settings).await.expect_err("refused");
        assert_eq!(
            open_hint(&e),
            Some("is the PLC (or gateway) reachable and in RUN?"),
            "{e}"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn drain_drops_bytes_until_the_line_is_quiet() {
        let (mut a, mut b) = tokio::io::duplex(64);
        b.write_all(b"late reply\r").await.unwrap();
        let dropped = drain(&mut a, Duration::from_millis(50)).await.unwrap();
        assert_eq!(dropped, 11);
        assert_eq!(drain(&mut a, Duration::from_millis(50)).await.unwrap(), 0);
    }

    #[tokio::test]
    async fn shared_stream_handles_reach_one_stream() {
        let (a, mut b) = tokio::io::duplex(64);
        let shared = SharedStream::new(a);
        let mut handle = shared.clone();
        handle.write_all(b"x").await.unwrap();
        drop(handle);
        let mut byte = [0_u8];
        b.read_exact(&mut byte).await.unwrap();
        b.write_all(b"y").await.unwrap();
        shared.clone().read_exact(&mut byte).await.unwrap();
        assert_eq!(&byte, b"y");
    }

    #[tokio::test]
    async fn tcp_connect_to_a_closed_port_is_a_link_error() {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let address = listener.local_addr().unwrap().to_string();
        drop(listener);
        let settings = TcpSettings {
            address,
            connect_timeout: Duration::from_secs(5),
        };
        assert!(matches!(
            open_tcp(&settings).await,
            Err(PlcError::Link { .. })
        ));
    }
}
