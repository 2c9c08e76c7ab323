//! MEWTOCOL-COM: which headers the PLC answers, then the largest read and write with each one
//! that answered; the client to go on with.

use tokio::time::Instant;

use super::sizes::{Search, probe_timeout, sizes};
use super::{MULTI_FRAME_CHECKS, check};
use crate::commission::report::{CheckReport, HeaderProbe};
use crate::commission::{Check, Halt, Session};
use crate::mewtocol::{
    Command, Header, Reply, Station, max_read_reply_words, max_write_words, response_frames,
};
use crate::plc::{
    AnyPlc, BoxedLink, EXCHANGE_BUDGET, HeaderChoice, LinkSettings, MewtocolClient,
    MewtocolOptions, Plc, PlcError, drain,
};

/// What one probe got.
#[derive(Debug)]
enum Probe {
    Answered(f64),
    NotAnswered(String),
    LinkFailed(String),
}

fn probe_outcome<T>(result: &Result<T, PlcError>, took_s: f64) -> Probe {
    match result {
        Ok(_) => Probe::Answered(took_s),
        Err(e @ (PlcError::Link { .. } | PlcError::InvalidRequest { .. })) => {
            Probe::LinkFailed(format!("{e:#}"))
        }
        Err(PlcError::Refused { refusal, .. }) => Probe::NotAnswered(refusal.to_string()),
        Err(PlcError::Timeout { timeout_ms, .. }) => {
            Probe::NotAnswered(format!("no reply within {timeout_ms} ms"))
        }
        Err(PlcError::BadReply { detail, .. }) => {
            Probe::NotAnswered(format!("bad reply: {detail}"))
        }
    }
}

fn mewtocol_options(settings: &LinkSettings, header: Header) -> Result<MewtocolOptions, PlcError> {
    let mut options = MewtocolOptions::from_settings(settings)?;
    options.header = match header {
        Header::Percent => HeaderChoice::Percent,
        Header::Angle => HeaderChoice::Angle,
    };
    Ok(options)
}

fn header_name(header: Header) -> &'static str {
    match header {
        Header::Percent => "%",
        Header::Angle => "<",
    }
}

/// A 1-word read of the status block's first word with `header`; the stream comes back drained
/// when the read failed.
async fn probe_header(
    link: BoxedLink,
    settings: &LinkSettings,
    header: Header,
) -> Result<(BoxedLink, Probe), PlcError> {
    let mut client = MewtocolClient::new(link, mewtocol_options(settings, header)?);
    let began = Instant::now();
    let result = client.read_words(settings.layout.status_base, 1).await;
    let outcome = probe_outcome(&result, began.elapsed().as_secs_f64());
    let mut link = client.into_inner();
    if result.is_err() {
        let _ = drain(&mut link, settings.timeout).await;
    }
    Ok((link, outcome))
}

fn tries(settings: &LinkSettings) -> String {
    match settings.retries {
        0 => String::new(),
        n => format!(", tried {} times", u32::from(n) + 1),
    }
}

impl Probe {
    /// What the probe got, in words.
    fn words(&self, settings: &LinkSettings) -> String {
        match self {
            Probe::Answered(took_s) => format!("answered in {:.1} ms", took_s * 1e3),
            Probe::NotAnswered(why) => format!("{why}{}", tries(settings)),
            Probe::LinkFailed(why) => format!("link failed: {why}"),
        }
    }
}

/// MEWTOCOL-COM: headers, then request sizes with each header that answered.
pub(super) async fn step(
    s: &mut Session<'_>,
    link: BoxedLink,
    settings: &LinkSettings,
) -> Result<AnyPlc, Halt> {
    let c = check(
        "headers %, <",
        &format!(
            "which MEWTOCOL-COM headers the PLC answers: a 1-word read of DT{} with % and with <",
            settings.layout.status_base
        ),
    );
    let (link, works, saw) = probe_headers(s, &c, link, settings).await?;
    let header = settle_header(s, c, saw, &works, settings.header)?;
    let (link, header) = mewtocol_sizes(s, link, settings, &works, header).await?;
    let link = multi_frame_read(s, link, settings, header).await?;
    s.findings.header_used = Some(header_name(header).to_owned());
    let mut options = mewtocol_options(settings, header).map_err(|_| Halt)?;
    // The config's choice, unless the check just saw this PLC leave a multi-frame read
    // unanswered: the rest of the commission does not spend a timeout finding that out again.
    options.multi_frame_reads &= s.findings.multi_frame_reads != Some(false);
    Ok(AnyPlc::Mewtocol(MewtocolClient::new(link, options)))
}

/// A 1-word read with `%`, then with `<`: the stream back, the headers the PLC answered and
/// what each probe got, in words.
async fn probe_headers(
    s: &mut Session<'_>,
    c: &Check,
    mut link: BoxedLink,
    settings: &LinkSettings,
) -> Result<(BoxedLink, Vec<Header>, String), Halt> {
    let mut works = Vec::new();
    let mut said = Vec::new();
    for header in [Header::Percent, Header::Angle] {
        let (back, outcome) = match probe_header(link, settings, header).await {
            Ok(done) => done,
            Err(e) => {
                let hint = "check the station number in the config";
                s.record(c.clone().fail(format!("{e:#}"), hint))?;
                return Err(Halt);
            }
        };
        link = back;
        let name = header_name(header);
        let text = outcome.words(settings);
        said.push(format!("{name} {text}"));
        s.findings.headers.push(HeaderProbe {
            header: name.to_owned(),
            answered: matches!(outcome, Probe::Answered(_)),
            outcome: text,
        });
        match outcome {
            Probe::Answered(_) => works.push(header),
            Probe::NotAnswered(_) => {}
            Probe::LinkFailed(_) => {
                s.record(c.clone().fail(
                    said.join("; "),
                    "the link itself failed: check the cable, port and its settings",
                ))?;
                return Err(Halt);
            }
        }
    }
    Ok((link, works, said.join("; ")))
}

/// The header to go on with: the one the config asks for when the PLC answered it, else the
/// first that answered (a config change).
fn settle_header(
    s: &mut Session<'_>,
    c: Check,
    saw: String,
    works: &[Header],
    configured: HeaderChoice,
) -> Result<Header, Halt> {
    let wanted = match configured {
        HeaderChoice::Angle => Header::Angle,
        HeaderChoice::Auto if works.contains(&Header::Angle) => Header::Angle,
        HeaderChoice::Percent | HeaderChoice::Auto => Header::Percent,
    };
    let Some(&fallback) = works.first() else {
        s.record(c.fail(
            saw,
            "the PLC answers no MEWTOCOL-COM frame: check that its port is in computer link mode, \
             the station number, baud rate, parity and the cable (deploy/plc/README.md, \"The COM port\")",
        ))?;
        return Err(Halt);
    };
    if !works.contains(&wanted) {
        s.record(c.config(
            saw,
            format!(
                "the config asks for {} frames, which this PLC does not answer: set header = \"{}\"",
                header_name(wanted),
                header_config(fallback)
            ),
        ))?;
        return Ok(fallback);
    }
    let report = match configured {
        HeaderChoice::Auto => c.pass_noting(
            saw,
            format!("header = \"auto\" settles on {} here", header_name(wanted)),
        ),
        _ => c.pass(saw),
    };
    s.record(report)?;
    Ok(wanted)
}

fn header_config(header: Header) -> &'static str {
    match header {
        Header::Percent => "percent",
        Header::Angle => "angle",
    }
}

/// The longest frame of a read of `read` words and a write of `write` words under `header`.
fn largest_frame(header: Header, station: Station, read: usize, write: usize) -> Option<usize> {
    let write_chars = Command::write_dt(0, vec![0; write.max(1)])
        .ok()?
        .to_frame(header, station)
        .ok()?
        .to_bytes()
        .ok()?
        .len();
    let reply = Ok(Reply::ReadDt(vec![0; read.max(1)]));
    let read_chars = response_frames(header, station, &reply)
        .first()?
        .to_bytes()
        .ok()?
        .len();
    Some(write_chars.max(read_chars))
}

/// Request sizes with every header that answered; the header to go on with (`<` only if it
/// carries linterpd's frames, else `%`).
async fn mewtocol_sizes(
    s: &mut Session<'_>,
    mut link: BoxedLink,
    settings: &LinkSettings,
    works: &[Header],
    wanted: Header,
) -> Result<(BoxedLink, Header), Halt> {
    let c = check(
        "largest frame/read/write",
        "the largest read and write one MEWTOCOL-COM frame may hold, with each header that \
         answered (reads and writes back of bank 1's channel 0 table area; the maximum first, \
         then halving)",
    );
    let station = mewtocol_options(settings, Header::Percent)
        .map(|o| o.station)
        .map_err(|_| Halt)?;
    let mut fits = Vec::new();
    let mut said = Vec::new();
    for &header in works {
        let (back, probed) = sizes_with(link, settings, header).await?;
        link = back;
        let (read, write) = match probed {
            Ok(found) => found,
            Err(e) => {
                let hint = "the link failed while probing request sizes";
                s.record(c.fail(format!("{e:#}"), hint))?;
                return Err(Halt);
            }
        };
        let frame = largest_frame(
            header,
            station,
            read.bisect.largest(),
            write.bisect.largest(),
        );
        said.push(sizes_said(header, (&read, &write), frame));
        let (max_read, max_write) = (max_read_reply_words(header), max_write_words(header));
        if read.carries(max_read, settings.timeout) && write.carries(max_write, settings.timeout) {
            fits.push(header);
        }
        s.findings
            .sizes
            .push(read.sizes(&write, header_name(header), frame));
    }
    settle_sizes(s, c, said.join("; "), &fits, wanted).map(|header| (link, header))
}

/// What the size search under `header` found, in words.
fn sizes_said(header: Header, (read, write): (&Search, &Search), frame: Option<usize>) -> String {
    format!(
        "{}: reads up to {} of {} words{}, writes up to {} of {}{}{}",
        header_name(header),
        read.bisect.largest(),
        max_read_reply_words(header),
        read.refused_at(),
        write.bisect.largest(),
        max_write_words(header),
        write.refused_at(),
        frame.map_or(String::new(), |n| format!(", frames up to {n} characters")),
    )
}

/// The size search under `header`, with a client whose timeout allows for the longest frame:
/// the stream back, and what the search found.
async fn sizes_with(
    link: BoxedLink,
    settings: &LinkSettings,
    header: Header,
) -> Result<(BoxedLink, Result<(Search, Search), PlcError>), Halt> {
    let mut options = mewtocol_options(settings, header).map_err(|_| Halt)?;
    options.timeout = probe_timeout(settings, header.max_frame_len());
    let mut client = MewtocolClient::new(link, options);
    let most = (max_read_reply_words(header), max_write_words(header));
    let probed = sizes(&mut client, settings, most).await;
    Ok((client.into_inner(), probed))
}

/// The header whose frames carry linterpd's reads and writes: `wanted` if it does, else `%`
/// (a config change); the procedure stops when neither does.
fn settle_sizes(
    s: &mut Session<'_>,
    c: Check,
    saw: String,
    fits: &[Header],
    wanted: Header,
) -> Result<Header, Halt> {
    if fits.contains(&wanted) {
        s.record(c.pass(saw))?;
        return Ok(wanted);
    }
    if fits.contains(&Header::Percent) {
        s.record(c.config(
            saw,
            "linterpd fills each < frame (509 words a read, 507 a write): more than this PLC \
             takes, or longer on the line than the config's timeout: set header = \"percent\"",
        ))?;
        return Ok(Header::Percent);
    }
    s.record(c.fail(
        saw,
        "linterpd fills each % frame (27 words a read, 24 a write) and this PLC takes fewer: \
         linterpd cannot talk to it over MEWTOCOL-COM as it is (try Modbus RTU)",
    ))?;
    Err(Halt)
}

/// Under `%`: a read of two frames' words of bank 1's channel 0 table area with multi-frame reads
/// on, and whether the PLC answered it in several frames (the client reads the words one frame
/// at a time if not). Skipped under `<`, whose one frame carries 509 words.
async fn multi_frame_read(
    s: &mut Session<'_>,
    link: BoxedLink,
    settings: &LinkSettings,
    header: Header,
) -> Result<BoxedLink, Halt> {
    let c = check("multi-frame read", MULTI_FRAME_CHECKS);
    if header == Header::Angle {
        let most = max_read_reply_words(Header::Angle);
        s.record(c.skip(format!("< frames carry {most} words a read in one frame")))?;
        return Ok(link);
    }
    let mut options = mewtocol_options(settings, header).map_err(|_| Halt)?;
    options.multi_frame_reads = true;
    let words = 2 * max_read_reply_words(Header::Percent);
    let mut client = MewtocolClient::new(link, options);
    let began = Instant::now();
    let result = client
        .read_words(settings.layout.area(1, 0), words as u16)
        .await;
    let took_ms = began.elapsed().as_secs_f64() * 1e3;
    let answered = client.multi_frame_reads_answered();
    let link = client.into_inner();
    if let Err(e) = result {
        s.record(c.fail(
            format!("{e:#}"),
            "the link failed on a read the size probes had just carried one frame at a time",
        ))?;
        return Err(Halt);
    }
    s.findings.multi_frame_reads = answered;
    let report = multi_frame_report(c, answered, settings.multi_frame_reads, (words, took_ms));
    s.record(report)?;
    Ok(link)
}

/// The multi-frame check's report: whether the PLC answered a read of `words` words in several
/// frames (`None`: the line is too slow to try), against the config's `configured` choice.
fn multi_frame_report(
    c: Check,
    answered: Option<bool>,
    configured: bool,
    (words, took_ms): (usize, f64),
) -> CheckReport {
    match (answered, configured) {
        (None, _) => c.skip(format!(
            "the line is too slow for a read past one frame within {} ms of wire time",
            EXCHANGE_BUDGET.as_millis()
        )),
        (Some(true), true) => c.pass(format!(
            "a {words}-word read came back in several frames ({took_ms:.1} ms)"
        )),
        (Some(true), false) => c.pass_noting(
            format!("a {words}-word read came back in several frames ({took_ms:.1} ms)"),
            "multi_frame_reads = true would shorten the read-back of every upload",
        ),
        (Some(false), configured) => {
            let saw = format!(
                "a {words}-word read got no answer; one frame at a time its words came back \
                 ({took_ms:.1} ms in all)"
            );
            if configured {
                c.config(
                    saw,
                    "set multi_frame_reads = false: else every connection spends a timeout on its \
                     first long read before reading one frame at a time",
                )
            } else {
                c.pass_noting(saw, "multi_frame_reads = false fits this PLC")
            }
        }
    }
}
