//! IO. The mock PLC's MEWTOCOL-COM server: one task per connection over any byte stream,
//! commands decoded by the shared [`ServerCodec`], answered from a [`SharedMock`].
//!
//! ```text
//!  bytes -> ServerCodec -> Skipped            logged, dropped
//!                       -> frame error        bad BCC: ! 40, other: ! 41 (if the station is ours)
//!                       -> Invalid            ! 42 / 41 / 61 / 66 (MessageError::plc_code)
//!                       -> Request(Command)   route by station, [wait for the scan's end],
//!                                             on_command() faults, execute, reply frames
//!                       -> Request(NextFrame) [wait for the scan's end], the next frame of a
//!                                             multi-frame reply (%01**&)
//! ```
//! Link faults per command: drop (no reply), corrupt (one byte of the first frame), delay, close
//! (the connection ends), error NN (`! NN`); a Modbus exception in the script answers `! 60`.
//! A command that arrives during a multi-frame reply abandons the rest of it. The
//! `angle-refused` variant neither executes nor answers anything that comes with a `<` header;
//! the `one-frame-replies` variant executes a command whose reply needs several frames but
//! answers nothing.

use std::collections::VecDeque;
use std::io;
use std::time::Duration;

use bytes::BytesMut;
use thiserror::Error;
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::TcpListener;
use tokio_util::codec::Decoder;

use super::LinkFault;
use super::answer::{Route, StationFilter, execute};
use super::shared::SharedMock;
use super::wire::WireStream;
use crate::mewtocol::{
    Addressed, CodecError, Command, Frame, FrameError, Header, PlcError, PlcErrorCode, Request,
    Response, ServerCodec, ServerEvent, Station, response_frames,
};

/// How a MEWTOCOL-COM server behaves on its links.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MewtocolServerOptions {
    /// Which stations it answers.
    pub station: StationFilter,
    /// Emulated serial line speed: bytes take 11 bits each in both directions and replies leave
    /// at the end of the scan in which their command arrived. `None`: as fast as the stream.
    pub baud: Option<u32>,
}

impl Default for MewtocolServerOptions {
    fn default() -> Self {
        Self {
            station: StationFilter::Any,
            baud: None,
        }
    }
}

/// Why a connection ended other than by its peer closing it.
#[derive(Debug, Error)]
pub enum ServerError {
    /// The stream failed.
    #[error("link to the mock failed")]
    Io(#[from] io::Error),
    /// A reply could not be encoded (a bug).
    #[error("reply could not be encoded")]
    Encode(#[source] FrameError),
}

/// A MEWTOCOL-COM server on a shared mock.
#[derive(Debug, Clone)]
pub struct MewtocolServer {
    mock: SharedMock,
    options: MewtocolServerOptions,
}

/// What one event asks the connection to do.
enum Step {
    Continue,
    Close,
}

/// The state of one connection.
struct Connection<'a, T> {
    server: &'a MewtocolServer,
    stream: T,
    /// Frames of a multi-frame reply still to send.
    pending: VecDeque<Frame>,
}

impl MewtocolServer {
    /// A server on `mock`.
    #[must_use]
    pub fn new(mock: SharedMock, options: MewtocolServerOptions) -> Self {
        Self { mock, options }
    }

    /// The shared mock.
    #[must_use]
    pub fn mock(&self) -> &SharedMock {
        &self.mock
    }

    /// Serves one connection until the peer closes it or a scripted `close` fires.
    pub async fn serve<T: AsyncRead + AsyncWrite + Unpin + Send>(
        &self,
        stream: T,
    ) -> Result<(), ServerError> {
        match self.options.baud {
            Some(baud) => self.serve_raw(WireStream::new(stream, baud)).await,
            None => self.serve_raw(stream).await,
        }
    }

    async fn serve_raw<T: AsyncRead + AsyncWrite + Unpin + Send>(
        &self,
        stream: T,
    ) -> Result<(), ServerError> {
        let mut connection = Connection {
            server: self,
            stream,
            pending: VecDeque::new(),
        };
        connection.run().await
    }

    /// Accepts TCP connections forever, one task each.
    pub async fn serve_tcp(self, listener: TcpListener) -> io::Result<()> {
        loop {
            let (stream, peer) = listener.accept().await?;
            let _ = stream.set_nodelay(true);
            tracing::info!(%peer, "MEWTOCOL-COM client connected");
            let server = self.clone();
            tokio::spawn(async move {
                match server.serve(stream).await {
                    Ok(()) => tracing::info!(%peer, "MEWTOCOL-COM connection closed"),
                    Err(e) => tracing::warn!(%peer, error = %e, "MEWTOCOL-COM connection failed"),
                }
            });
        }
    }
}

/// Header and station at the front of `buf`, if it starts like a frame.
fn envelope(buf: &[u8]) -> Option<(Header, Station)> {
    let header = Header::from_byte(*buf.first()?)?;
    let station = Station::from_ascii([*buf.get(1)?, *buf.get(2)?]).ok()?;
    Some((header, station))
}

fn refusal(code: PlcErrorCode) -> Response {
    Err(PlcError { code })
}

impl<T: AsyncRead + AsyncWrite + Unpin + Send> Connection<'_, T> {
    async fn run(&mut self) -> Result<(), ServerError> {
        let mut codec = ServerCodec::new();
        let mut buf = BytesMut::with_capacity(4096);
        loop {
            loop {
                let front = envelope(&buf);
                let event = match codec.decode(&mut buf) {
                    Ok(None) => break,
                    Ok(Some(event)) => Ok(event),
                    Err(e) => Err((front, e)),
                };
                if let Step::Close = self.on_decoded(event).await? {
                    return Ok(());
                }
            }
            if self.stream.read_buf(&mut buf).await? == 0 {
                return Ok(());
            }
        }
    }

    async fn on_decoded(
        &mut self,
        event: Result<ServerEvent, (Option<(Header, Station)>, CodecError)>,
    ) -> Result<Step, ServerError> {
        match event {
            Ok(ServerEvent::Skipped(bytes)) => {
                tracing::warn!(bytes = ?String::from_utf8_lossy(&bytes), "skipped bytes before a header");
                Ok(Step::Continue)
            }
            Ok(ServerEvent::Invalid {
                header,
                station,
                error,
            }) => {
                tracing::warn!(%error, "refused an invalid command");
                self.refuse(header, station, error.plc_code()).await
            }
            Ok(ServerEvent::Request(request)) => self.on_request(request).await,
            Err((front, error)) => self.on_bad_frame(front, &error).await,
        }
    }

    async fn on_bad_frame(
        &mut self,
        front: Option<(Header, Station)>,
        error: &CodecError,
    ) -> Result<Step, ServerError> {
        tracing::warn!(%error, "bad command frame");
        let Some((header, station)) = front else {
            return Ok(Step::Continue);
        };
        let code = match error {
            CodecError::Frame(FrameError::BadBcc { .. }) => PlcErrorCode::BccError,
            _ => PlcErrorCode::FormatError,
        };
        self.refuse(header, station, code).await
    }

    /// Whether the mock ignores frames with `header` (the `angle-refused` variant and `<`).
    fn deaf_to(&self, header: Header) -> bool {
        header == Header::Angle
            && !self
                .server
                .mock
                .with(|m| m.config().variant.answers_angle())
    }

    async fn refuse(
        &mut self,
        header: Header,
        station: Station,
        code: PlcErrorCode,
    ) -> Result<Step, ServerError> {
        self.pending.clear();
        if self.deaf_to(header) {
            return Ok(Step::Continue);
        }
        match self.server.options.station.route(station) {
            Route::Answer(from) => {
                self.send(&Frame::new(header, from, encode(&refusal(code))), &[])
                    .await?;
                Ok(Step::Continue)
            }
            Route::Silent | Route::Ignore => Ok(Step::Continue),
        }
    }

    async fn on_request(&mut self, request: Addressed<Request>) -> Result<Step, ServerError> {
        if self.deaf_to(request.header) {
            tracing::debug!("angle-refused: a < frame goes unanswered");
            return Ok(Step::Continue);
        }
        let route = self.server.options.station.route(request.station);
        match (request.message, route) {
            (_, Route::Ignore) => {
                tracing::debug!(
                    station = %String::from_utf8_lossy(&request.station.to_ascii()),
                    "command for another station"
                );
                Ok(Step::Continue)
            }
            (Request::NextFrame, Route::Silent) => Ok(Step::Continue),
            (Request::NextFrame, Route::Answer(_)) => self.next_frame().await,
            (Request::Command(command), route) => {
                self.on_command(request.header, &command, route).await
            }
        }
    }

    async fn next_frame(&mut self) -> Result<Step, ServerError> {
        if let Some(frame) = self.pending.pop_front() {
            // A PLC answers the request for the next frame at the end of a scan, as a command.
            if self.server.options.baud.is_some() {
                self.server.mock.wait_scan_end().await;
            }
            self.send(&frame, &[]).await?;
        } else {
            tracing::warn!("next-frame request without a multi-frame reply in progress");
        }
        Ok(Step::Continue)
    }

    async fn on_command(
        &mut self,
        header: Header,
        command: &Command,
        route: Route,
    ) -> Result<Step, ServerError> {
        if !self.pending.is_empty() {
            tracing::info!("a new command abandons the rest of a multi-frame reply");
            self.pending.clear();
        }
        let mock = &self.server.mock;
        if self.server.options.baud.is_some() {
            mock.wait_scan_end().await;
        }
        let (faults, response) = mock.with(|m| {
            let faults = m.on_command();
            (faults, execute(m, command))
        });
        let Route::Answer(from) = route else {
            return Ok(Step::Continue);
        };
        self.reply(header, from, response, &faults).await
    }

    async fn reply(
        &mut self,
        header: Header,
        from: Station,
        mut response: Response,
        faults: &[LinkFault],
    ) -> Result<Step, ServerError> {
        for fault in faults {
            tracing::warn!(%fault, "injecting link fault");
            match *fault {
                LinkFault::Drop => return Ok(Step::Continue),
                LinkFault::Close => return Ok(Step::Close),
                LinkFault::Delay { ms } => tokio::time::sleep(Duration::from_millis(ms)).await,
                LinkFault::MewtocolError { code } => {
                    response = refusal(PlcErrorCode::from_number(code));
                }
                LinkFault::ModbusException { .. } => {
                    response = refusal(PlcErrorCode::ParameterError);
                }
                LinkFault::Corrupt { .. } => {}
            }
        }
        let mut frames: VecDeque<Frame> = response_frames(header, from, &response).into();
        if frames.len() > 1
            && !self
                .server
                .mock
                .with(|m| m.config().variant.answers_multi_frame())
        {
            tracing::debug!(
                "one-frame-replies: a reply of {} frames goes unanswered",
                frames.len()
            );
            self.server
                .mock
                .with(super::MockPlc::note_unanswered_multi_frame);
            return Ok(Step::Continue);
        }
        if let Some(first) = frames.pop_front() {
            self.send(&first, faults).await?;
        }
        self.pending = frames;
        Ok(Step::Continue)
    }

    /// Sends one frame, with any `Corrupt` fault applied to its bytes.
    async fn send(&mut self, frame: &Frame, faults: &[LinkFault]) -> Result<(), ServerError> {
        let mut bytes = frame.to_bytes().map_err(ServerError::Encode)?;
        for fault in faults {
            fault.corrupt_in_place(&mut bytes);
        }
        self.stream.write_all(&bytes).await?;
        self.stream.flush().await?;
        Ok(())
    }
}

fn encode(response: &Response) -> bytes::Bytes {
    crate::mewtocol::encode_response(response)
}
