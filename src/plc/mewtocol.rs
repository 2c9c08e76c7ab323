//! IO. The MEWTOCOL-COM client: [`Plc`] over any byte stream, through the sans-IO
//! [`crate::mewtocol`] codec.
//!
//! ```text
//!  read_words / write_words        chunked to one frame each: % RD <= 27 words, WD <= 24;
//!      |                           < RD <= 509 words, WD <= 507, fewer on a slow serial line
//!      |                           (at most 250 ms of wire time an exchange); under % a read
//!      |                           takes up to 509 words in one RD answered in several frames
//!      |                           (multi-frame reads), or one frame each after the first
//!      |                           such read goes unanswered
//!  exchange  -- retries (timeout, garbled reply, ! 40 BCC, ! 41 format) up to `retries` times;
//!      |        write_words_once never retries (a start command is not safe to repeat)
//!  attempt   -- drains late bytes first if the last attempt failed, then one timeout around
//!      |        send, any "next frame please" (**&) round trips, and the whole reply: the
//!      |        wire time of both frames at the line's baud, two PLC scans and the margin
//!  Framed<T, ClientCodec>
//! ```
//! A `!` reply other than 40 / 41 is the PLC's answer and goes up unchanged as
//! [`PlcError::Refused`]; it is never retried. Header `auto` probes `<` once with a 1-word read and
//! falls back to `%` on no reply or an error (whether FP-X accepts `<` is \[unverified\], PLC.md §1).

use std::fmt;
use std::io;
use std::sync::Arc;
use std::time::Duration;

use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncRead, AsyncWrite};
use tokio_util::codec::Framed;

use super::link::drain;
use super::settings::{HeaderChoice, LinkSettings, Timing};
use super::{ExchangeCounts, ExchangeSizes, Plc, PlcError, PlcMode, Refusal};
use crate::gateway::Area;
use crate::mewtocol::{
    Addressed, ClientCodec, ClientEvent, CodecError, Command, Contact, ContactArea, ContactWords,
    DtRange, Header, PlcErrorCode, Reply, Request, Response, Station, max_read_reply_words,
    max_write_words, reply_wire,
};

/// Station number that means `EE` (answered by any PLC \[practice\]) in the config.
pub const STATION_ANY: u8 = 0xEE;

/// Wire time one exchange is kept within on a slow line (the frame sizes are cut to fit), so a
/// stop never waits long behind an upload; a frame never gets smaller than `%` allows.
pub const EXCHANGE_BUDGET: Duration = Duration::from_millis(250);

/// Most words one multi-frame read asks for: what one `<` frame carries, a size a PLC's
/// communication buffer is known to hold.
const MULTI_FRAME_READ_WORDS: usize = max_read_reply_words(Header::Angle);

/// How the client talks: station, header, timing and retries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MewtocolOptions {
    /// The PLC's station.
    pub station: Station,
    /// The header, or `Auto` to probe.
    pub header: HeaderChoice,
    /// The margin one exchange may take beyond its wire time and two scans.
    pub timeout: Duration,
    /// One character's time on a serial line (`None`: a network link or a test stream).
    pub char_time: Option<Duration>,
    /// The PLC's longest scan.
    pub scan_time: Duration,
    /// Further attempts after a retryable failure.
    pub retries: u8,
    /// Under `%`, reads longer than one frame as one `RD` with a multi-frame reply.
    pub multi_frame_reads: bool,
}

impl MewtocolOptions {
    /// Options for a network link: a 300 ms margin, a 10 ms scan and 2 retries.
    #[must_use]
    pub fn new(station: Station, header: HeaderChoice) -> Self {
        let timing = Timing::network(Duration::from_millis(300));
        Self {
            station,
            header,
            timeout: timing.margin,
            char_time: timing.char_time,
            scan_time: timing.scan_time,
            retries: 2,
            multi_frame_reads: true,
        }
    }

    /// The exchange timing.
    #[must_use]
    pub fn timing(&self) -> Timing {
        Timing {
            char_time: self.char_time,
            scan_time: self.scan_time,
            margin: self.timeout,
        }
    }

    /// Words one exchange carries under `header`: the frame's most, or fewer on a slow line
    /// (`overhead` characters plus 4 a word within [`EXCHANGE_BUDGET`] of wire time).
    fn words_per_exchange(&self, header: Header, most: usize, overhead: usize) -> usize {
        let Some(char_time) = self.char_time.filter(|c| !c.is_zero()) else {
            return most;
        };
        let chars = (EXCHANGE_BUDGET.as_secs_f64() / char_time.as_secs_f64()) as usize;
        let fit = chars.saturating_sub(overhead) / 4;
        let floor = match header {
            Header::Percent => most,
            Header::Angle => max_write_words(Header::Percent),
        };
        fit.clamp(floor.min(most), most)
    }

    /// Words one multi-frame read under `%` asks for: [`MULTI_FRAME_READ_WORDS`], or fewer on
    /// a slow line (its request, reply frames and next-frame requests within
    /// [`EXCHANGE_BUDGET`] of wire time), never fewer than one frame holds.
    fn multi_frame_read_words(&self) -> usize {
        let one_frame = max_read_reply_words(Header::Percent);
        let Some(char_time) = self.char_time.filter(|c| !c.is_zero()) else {
            return MULTI_FRAME_READ_WORDS;
        };
        let chars = (EXCHANGE_BUDGET.as_secs_f64() / char_time.as_secs_f64()) as usize;
        let fits = |words: usize| {
            let command = Command::ReadDt(DtRange::from_len(0, words).expect("a valid range"));
            let request = command
                .to_frame(Header::Percent, self.station)
                .map_or(0, |f| f.encoded_len());
            request + reply_wire(Header::Percent, command.reply_body_len()).chars <= chars
        };
        (one_frame + 1..=MULTI_FRAME_READ_WORDS)
            .take_while(|&words| fits(words))
            .last()
            .unwrap_or(one_frame)
    }

    /// The options a link's settings describe (station 238 is `EE`).
    pub fn from_settings(settings: &LinkSettings) -> Result<Self, PlcError> {
        let station = if settings.station == STATION_ANY {
            Station::ANY
        } else {
            Station::new(settings.station).map_err(|e| PlcError::InvalidRequest {
                operation: "choose the MEWTOCOL station".to_owned(),
                detail: e.to_string(),
            })?
        };
        let timing = settings.timing();
        Ok(Self {
            station,
            header: settings.header,
            timeout: timing.margin,
            char_time: timing.char_time,
            scan_time: timing.scan_time,
            retries: settings.retries,
            multi_frame_reads: settings.multi_frame_reads,
        })
    }
}

/// Why one attempt failed.
#[derive(Debug)]
enum AttemptFailure {
    /// A `!` reply.
    Refused(PlcErrorCode),
    /// A reply that does not decode or does not answer the command.
    Garbled(String),
    /// No whole reply in time.
    Timeout,
    /// The stream failed or closed.
    Link(io::Error),
}

impl AttemptFailure {
    fn is_retryable(&self) -> bool {
        match self {
            Self::Refused(code) => {
                matches!(code, PlcErrorCode::BccError | PlcErrorCode::FormatError)
            }
            Self::Garbled(_) | Self::Timeout => true,
            Self::Link(_) => false,
        }
    }

    fn into_error(self, operation: &str, timeout: Duration) -> PlcError {
        let operation = operation.to_owned();
        match self {
            Self::Refused(code) => PlcError::Refused {
                operation,
                refusal: Refusal::Mewtocol {
                    code: code.number(),
                    meaning: code.meaning(),
                },
            },
            Self::Garbled(detail) => PlcError::BadReply { operation, detail },
            Self::Timeout => PlcError::Timeout {
                operation,
                timeout_ms: timeout.as_millis() as u64,
            },
            Self::Link(source) => PlcError::Link { operation, source },
        }
    }
}

impl fmt::Display for AttemptFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Refused(code) => write!(f, "refused with {code}"),
            Self::Garbled(detail) => write!(f, "garbled reply: {detail}"),
            Self::Timeout => write!(f, "no reply in time"),
            Self::Link(e) => write!(f, "link failed: {e}"),
        }
    }
}

/// Where a client stands with multi-frame reads (`%` only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MultiFrame {
    /// None made yet: the first one that goes unanswered turns them off.
    Untried,
    /// The PLC answered one: a later failure is the line's, and only that read is made again
    /// one frame at a time.
    Answered,
    /// The first went unanswered: one frame a read.
    Unanswered,
    /// Configured off: one frame a read.
    Off,
}

/// A MEWTOCOL-COM host over the stream `T`.
#[derive(Debug)]
pub struct MewtocolClient<T> {
    framed: Framed<T, ClientCodec>,
    options: MewtocolOptions,
    header: Option<Header>,
    /// Whether reads longer than one frame are made as multi-frame reads.
    multi_frame: MultiFrame,
    /// Words one multi-frame read asks for ([`MewtocolOptions::multi_frame_read_words`]).
    multi_frame_words: usize,
    stale: bool,
    counts: Arc<ExchangeCounts>,
}

impl<T: AsyncRead + AsyncWrite + Unpin + Send> MewtocolClient<T> {
    /// A client over `stream`; with header `Auto` the first request probes `<`.
    pub fn new(stream: T, options: MewtocolOptions) -> Self {
        let header = match options.header {
            HeaderChoice::Auto => None,
            HeaderChoice::Percent => Some(Header::Percent),
            HeaderChoice::Angle => Some(Header::Angle),
        };
        Self {
            framed: Framed::new(stream, ClientCodec::new()),
            options,
            header,
            multi_frame: if options.multi_frame_reads {
                MultiFrame::Untried
            } else {
                MultiFrame::Off
            },
            multi_frame_words: options.multi_frame_read_words(),
            stale: false,
            counts: Arc::default(),
        }
    }

    /// Counts this client's retries and timeouts into `counts` (shared with the link's owner).
    pub fn set_exchange_counts(&mut self, counts: Arc<ExchangeCounts>) {
        self.counts = counts;
    }

    /// The header in use, once chosen (`None` before an `Auto` probe).
    #[must_use]
    pub fn header(&self) -> Option<Header> {
        self.header
    }

    /// Whether the PLC answered a multi-frame read on this client (`Some(true)`), or left the
    /// first one unanswered (`Some(false)`: one frame a read since); `None` before any was
    /// made, or with `multi_frame_reads` off.
    #[must_use]
    pub fn multi_frame_reads_answered(&self) -> Option<bool> {
        match self.multi_frame {
            MultiFrame::Answered => Some(true),
            MultiFrame::Unanswered => Some(false),
            MultiFrame::Untried | MultiFrame::Off => None,
        }
    }

    fn multi_frame_in_use(&self) -> bool {
        matches!(self.multi_frame, MultiFrame::Untried | MultiFrame::Answered)
    }

    /// Gives the stream back.
    pub fn into_inner(self) -> T {
        self.framed.into_inner()
    }

    async fn resolve_header(&mut self) -> Result<Header, PlcError> {
        if let Some(header) = self.header {
            return Ok(header);
        }
        let header = self.probe().await?;
        self.header = Some(header);
        Ok(header)
    }

    /// One 1-word `<` read: an answer means `<` works, anything else but a dead link means `%`.
    async fn probe(&mut self) -> Result<Header, PlcError> {
        let command = Command::ReadDt(dt_range(0, 1, "probe the < header")?);
        match self.attempt(Header::Angle, &command).await {
            Ok(_) => Ok(Header::Angle),
            Err(AttemptFailure::Link(source)) => Err(PlcError::Link {
                operation: "probe the < header".to_owned(),
                source,
            }),
            Err(failure) => {
                tracing::info!(%failure, "the PLC does not take the < header; using %");
                Ok(Header::Percent)
            }
        }
    }

    /// Sends `command` and returns its reply, retrying what is safe to retry.
    async fn exchange(
        &mut self,
        header: Header,
        command: &Command,
        operation: &str,
    ) -> Result<Reply, PlcError> {
        self.exchange_tries(header, command, operation, self.options.retries)
            .await
    }

    /// Sends `command` and returns its reply, trying again up to `retries` times.
    async fn exchange_tries(
        &mut self,
        header: Header,
        command: &Command,
        operation: &str,
        retries: u8,
    ) -> Result<Reply, PlcError> {
        let mut attempt = 0;
        loop {
            let failure = match self.attempt(header, command).await {
                Ok(reply) => return Ok(reply),
                Err(failure) => failure,
            };
            if !failure.is_retryable() || attempt >= retries {
                let timeout = self.exchange_timeout(header, command);
                return Err(failure.into_error(operation, timeout));
            }
            attempt += 1;
            self.counts.retried();
            tracing::warn!(operation, attempt, %failure, "retrying a MEWTOCOL exchange");
        }
    }

    /// The longest `command` may take: its frame and its reply on the wire (every frame of a
    /// multi-frame reply and the requests for them), two scans and one more for every frame
    /// after the first, the margin.
    fn exchange_timeout(&self, header: Header, command: &Command) -> Duration {
        let request = command
            .to_frame(header, self.options.station)
            .map_or(0, |f| f.encoded_len());
        let reply = reply_wire(header, command.reply_body_len());
        let asks = u32::try_from(reply.frames - 1).unwrap_or(u32::MAX);
        self.options.timing().exchange(request, reply.chars) + self.options.scan_time * asks
    }

    /// Words one read exchange asks for under `header`: a multi-frame read's under `%` while
    /// those are in use, else what one frame holds.
    fn read_words_per_exchange(&self, header: Header) -> usize {
        if header == Header::Percent && self.multi_frame_in_use() {
            self.multi_frame_words
        } else {
            self.one_frame_read_words(header)
        }
    }

    fn one_frame_read_words(&self, header: Header) -> usize {
        self.options
            .words_per_exchange(header, max_read_reply_words(header), 9)
    }

    /// `len` words from `start`: one multi-frame read when it takes more than one frame and
    /// those are in use, else one read a frame. A multi-frame read gets one try; not answered
    /// (no reply in time, a garbled or `!` reply), its words are read one frame at a time with
    /// the usual retries, and if the PLC never answered one, multi-frame reads end for this
    /// client. A failed link is an error.
    async fn read_span(
        &mut self,
        header: Header,
        start: u32,
        len: usize,
    ) -> Result<Vec<u16>, PlcError> {
        let one_frame = self.one_frame_read_words(header);
        if len > one_frame && header == Header::Percent && self.multi_frame_in_use() {
            match self.read_chunk(header, start, len, 0).await {
                Ok(words) => {
                    self.multi_frame = MultiFrame::Answered;
                    return Ok(words);
                }
                Err(e @ PlcError::Link { .. }) => return Err(e),
                Err(e) if self.multi_frame == MultiFrame::Answered => {
                    self.counts.retried();
                    tracing::warn!(error = %e, "reading those words again one frame at a time");
                }
                Err(e) => {
                    tracing::warn!(
                        error = %e,
                        "the PLC did not answer a multi-frame read: reading one frame at a time \
                         from now on (multi_frame_reads = false skips this try)"
                    );
                    self.multi_frame = MultiFrame::Unanswered;
                }
            }
        }
        let mut words = Vec::with_capacity(len);
        for (from, n) in chunks(start, len, one_frame) {
            words.extend(
                self.read_chunk(header, from, n, self.options.retries)
                    .await?,
            );
        }
        Ok(words)
    }

    /// One try: settle the link, then one timeout around the whole round trip.
    async fn attempt(
        &mut self,
        header: Header,
        command: &Command,
    ) -> Result<Reply, AttemptFailure> {
        self.settle().await?;
        let timeout = self.exchange_timeout(header, command);
        let result = tokio::time::timeout(timeout, self.round_trip(header, command))
            .await
            .unwrap_or(Err(AttemptFailure::Timeout));
        if matches!(result, Err(AttemptFailure::Timeout)) {
            self.counts.timed_out();
        }
        if matches!(
            result,
            Err(AttemptFailure::Timeout | AttemptFailure::Garbled(_))
        ) {
            self.stale = true;
        }
        result
    }

    /// After a failed attempt: forget half-read replies and drain late bytes.
    async fn settle(&mut self) -> Result<(), AttemptFailure> {
        if !std::mem::take(&mut self.stale) {
            return Ok(());
        }
        self.framed.codec_mut().reset();
        self.framed.read_buffer_mut().clear();
        drain(self.framed.get_mut(), self.options.timing().quiet())
            .await
            .map(|_| ())
            .map_err(AttemptFailure::Link)
    }

    async fn send(
        &mut self,
        header: Header,
        station: Station,
        message: Request,
    ) -> Result<(), AttemptFailure> {
        let addressed = Addressed {
            header,
            station,
            message,
        };
        self.framed.send(addressed).await.map_err(|e| match e {
            CodecError::Io(e) => AttemptFailure::Link(e),
            other => AttemptFailure::Garbled(other.to_string()),
        })
    }

    async fn round_trip(
        &mut self,
        header: Header,
        command: &Command,
    ) -> Result<Reply, AttemptFailure> {
        let request = Request::Command(command.clone());
        self.send(header, self.options.station, request).await?;
        loop {
            match self.framed.next().await {
                None => return Err(AttemptFailure::Link(io::ErrorKind::UnexpectedEof.into())),
                Some(Err(CodecError::Io(e))) => return Err(AttemptFailure::Link(e)),
                Some(Err(e)) => {
                    // Framed yields `None` once after a decoder error: take it now.
                    let _ = self.framed.next().await;
                    return Err(AttemptFailure::Garbled(e.to_string()));
                }
                Some(Ok(ClientEvent::Skipped(bytes))) => {
                    tracing::warn!(
                        bytes = %String::from_utf8_lossy(&bytes).escape_debug(),
                        "skipped bytes that start no MEWTOCOL frame"
                    );
                }
                Some(Ok(ClientEvent::MoreFollows { header, station })) => {
                    self.send(header, station, Request::NextFrame).await?;
                }
                Some(Ok(ClientEvent::Response(reply))) => {
                    return self.accept(reply, header, command);
                }
            }
        }
    }

    /// The reply's data if it answers `command` from our station under our header.
    fn accept(
        &self,
        reply: Addressed<Response>,
        header: Header,
        command: &Command,
    ) -> Result<Reply, AttemptFailure> {
        let station = self.options.station;
        if reply.header != header || (station != Station::ANY && reply.station != station) {
            return Err(AttemptFailure::Garbled(format!(
                "reply from {:?} station {:?}, expected {header:?} station {station:?}",
                reply.header, reply.station
            )));
        }
        match reply.message {
            Err(refusal) => Err(AttemptFailure::Refused(refusal.code)),
            Ok(data) if data.answers(command) => Ok(data),
            Ok(data) => Err(AttemptFailure::Garbled(format!(
                "{data:?} does not answer {command:?}"
            ))),
        }
    }

    async fn read_chunk(
        &mut self,
        header: Header,
        start: u32,
        len: usize,
        retries: u8,
    ) -> Result<Vec<u16>, PlcError> {
        let operation = dt_operation("read", start, len);
        let command = Command::ReadDt(dt_range(start, len, &operation)?);
        match self
            .exchange_tries(header, &command, &operation, retries)
            .await?
        {
            Reply::ReadDt(words) => Ok(words),
            other => Err(unexpected(&operation, &other)),
        }
    }

    /// Contact words `first..=last` of `area` (RCC), in as few exchanges as the frames allow.
    async fn read_contact_words(
        &mut self,
        header: Header,
        area: ContactArea,
        (first, last): (u32, u32),
        operation: &str,
    ) -> Result<Vec<u16>, PlcError> {
        let per = self
            .options
            .words_per_exchange(header, max_read_reply_words(header), 9);
        let mut words = Vec::new();
        let mut word = first;
        while word <= last {
            let end = last.min(word + per as u32 - 1);
            let range = ContactWords::new(area, word as u16, end as u16)
                .map_err(|e| invalid(operation, &e))?;
            match self
                .exchange(header, &Command::ReadContactWords(range), operation)
                .await?
            {
                Reply::ReadContactWords(w) => words.extend(w),
                other => return Err(unexpected(operation, &other)),
            }
            word = end + 1;
        }
        Ok(words)
    }

    async fn write_chunk(
        &mut self,
        header: Header,
        start: u32,
        words: &[u16],
        retries: u8,
    ) -> Result<(), PlcError> {
        let operation = dt_operation("write", start, words.len());
        let command =
            Command::write_dt(start, words.to_vec()).map_err(|e| invalid(&operation, &e))?;
        self.exchange_tries(header, &command, &operation, retries)
            .await
            .map(|_| ())
    }
}

impl<T: AsyncRead + AsyncWrite + Unpin + Send> Plc for MewtocolClient<T> {
    async fn read_words(&mut self, start: u16, count: u16) -> Result<Vec<u16>, PlcError> {
        let header = self.resolve_header().await?;
        let mut words = Vec::with_capacity(usize::from(count));
        let size = self.read_words_per_exchange(header);
        for (from, len) in chunks(u32::from(start), usize::from(count), size) {
            words.extend(self.read_span(header, from, len).await?);
        }
        Ok(words)
    }

    async fn write_words(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        let header = self.resolve_header().await?;
        let size = self
            .options
            .words_per_exchange(header, max_write_words(header), 20);
        for (from, chunk) in (u32::from(start)..).step_by(size).zip(words.chunks(size)) {
            self.write_chunk(header, from, chunk, self.options.retries)
                .await?;
        }
        Ok(())
    }

    async fn write_words_once(&mut self, start: u16, words: &[u16]) -> Result<(), PlcError> {
        let header = self.resolve_header().await?;
        if words.len() > max_write_words(header) {
            return Err(invalid(
                &dt_operation("write", u32::from(start), words.len()),
                &format!(
                    "a single write carries at most {} words",
                    max_write_words(header)
                ),
            ));
        }
        self.write_chunk(header, u32::from(start), words, 0).await
    }

    async fn read_bits(
        &mut self,
        area: Area,
        start: u32,
        count: u16,
    ) -> Result<Vec<bool>, PlcError> {
        let operation = bits_operation("read", area, start, count);
        let contact_area = contact_area(area).ok_or_else(|| super::not_bits(operation.clone()))?;
        if count == 0 {
            return Ok(Vec::new());
        }
        let header = self.resolve_header().await?;
        if count == 1 {
            // One contact: RCS, which every FP answers.
            let word =
                u16::try_from(start / 16).map_err(|_| invalid(&operation, &"word too large"))?;
            let contact = Contact::new(contact_area, word, (start % 16) as u8)
                .map_err(|e| invalid(&operation, &e))?;
            return match self
                .exchange(header, &Command::ReadContact(contact), &operation)
                .await?
            {
                Reply::ReadContact(on) => Ok(vec![on]),
                other => Err(unexpected(&operation, &other)),
            };
        }
        let (first, last) = (start / 16, (start + u32::from(count) - 1) / 16);
        let words = self
            .read_contact_words(header, contact_area, (first, last), &operation)
            .await?;
        let offset = start - first * 16;
        Ok((0..u32::from(count))
            .map(|i| {
                let at = offset + i;
                words[(at / 16) as usize] & (1 << (at % 16)) != 0
            })
            .collect())
    }

    async fn write_bit(&mut self, area: Area, bit: u32, on: bool) -> Result<(), PlcError> {
        let operation = format!("write {} = {}", bit_name(area, bit), u8::from(on));
        let contact_area = contact_area(area).ok_or_else(|| super::not_bits(operation.clone()))?;
        let word = u16::try_from(bit / 16).map_err(|_| invalid(&operation, &"word too large"))?;
        let contact = Contact::new(contact_area, word, (bit % 16) as u8)
            .map_err(|e| invalid(&operation, &e))?;
        let command = Command::write_contact(contact, on).map_err(|e| invalid(&operation, &e))?;
        let header = self.resolve_header().await?;
        self.exchange(header, &command, &operation)
            .await
            .map(|_| ())
    }

    fn exchange_sizes(&self) -> ExchangeSizes {
        let header = self.header.unwrap_or(Header::Percent);
        let read = self.one_frame_read_words(header);
        ExchangeSizes {
            read_words: self.read_words_per_exchange(header) as u16,
            write_words: self
                .options
                .words_per_exchange(header, max_write_words(header), 20)
                as u16,
            read_bits: (read * 16).min(usize::from(u16::MAX)) as u16,
        }
    }

    async fn mode(&mut self) -> Result<PlcMode, PlcError> {
        let operation = "read the PLC status (RT)";
        let header = self.resolve_header().await?;
        match self.exchange(header, &Command::Status, operation).await? {
            Reply::Status(status) if status.is_running() => Ok(PlcMode::Run),
            Reply::Status(_) => Ok(PlcMode::Prog),
            other => Err(unexpected(operation, &other)),
        }
    }
}

/// `(start, len)` pieces of `count` words from `start`, at most `size` words each.
fn chunks(start: u32, count: usize, size: usize) -> impl Iterator<Item = (u32, usize)> {
    (0..count)
        .step_by(size)
        .map(move |offset| (start + offset as u32, size.min(count - offset)))
}

fn dt_range(start: u32, len: usize, operation: &str) -> Result<DtRange, PlcError> {
    DtRange::from_len(start, len).map_err(|e| invalid(operation, &e))
}

fn dt_operation(verb: &str, start: u32, len: usize) -> String {
    format!("{verb} DT{start}..=DT{}", start + len as u32 - 1)
}

/// R`relay` as Panasonic writes it: word in decimal, bit in hex (R9020 = word 902, bit 0).
#[must_use]
pub fn relay_name(relay: u16) -> String {
    format!("R{}{:X}", relay / 16, relay % 16)
}

/// MEWTOCOL's contact area of a gateway area (none for DT).
fn contact_area(area: Area) -> Option<ContactArea> {
    match area {
        Area::X => Some(ContactArea::X),
        Area::Y => Some(ContactArea::Y),
        Area::R => Some(ContactArea::R),
        Area::Dt => None,
    }
}

/// A bit as Panasonic writes it (R9020, X1F).
fn bit_name(area: Area, bit: u32) -> String {
    crate::gateway::Address { area, index: bit }.to_string()
}

fn bits_operation(verb: &str, area: Area, start: u32, count: u16) -> String {
    let last = start + u32::from(count.max(1)) - 1;
    format!(
        "{verb} {}..={}",
        bit_name(area, start),
        bit_name(area, last)
    )
}

fn invalid(operation: &str, error: &impl fmt::Display) -> PlcError {
    PlcError::InvalidRequest {
        operation: operation.to_owned(),
        detail: error.to_string(),
    }
}

fn unexpected(operation: &str, reply: &Reply) -> PlcError {
    PlcError::BadReply {
        operation: operation.to_owned(),
        detail: format!("unexpected reply {reply:?}"),
    }
}

#[cfg(test)]
#[path = "mewtocol_tests.rs"]
mod tests;
