//! `linterpd log`: the cell's journal, read from the daemon (`GET /v1/journal`, docs/API.md):
//! the last entries, or those since a time, one line each (`--json`: the journal's own JSON
//! lines, the export format); `--follow` keeps printing new ones (polling with the last
//! number as the cursor) until Ctrl-C; `--counts` gives production counts per shift instead.
//!
//! ```text
//! linterpd log --since 10m
//! 2026-11-29T08:48:01.123Z #41 press-loader fault: code 3, stopped from outside (e-stop input)
//! linterpd log --counts --since 24h --shift 8h --shift-start 06:00
//! shift (UTC)                              cycles  stopped  parts  pallets  faults
//! 2026-11-29T06:00:00.000Z .. 14:00:00         412        1    412        4       2
//! ```

use std::fmt::Write as _;
use std::time::Duration;

use clap::Args;
use hyper::Method;

use super::client::{Client, Received};
use super::{DaemonArgs, Failure, bad_input};
use crate::daemon::api::JournalPage;
use crate::wire::journal::{Entry, ShiftCounts, parse_rfc3339, parse_span_ms, per_shift};

/// How often `--follow` asks for new entries.
const POLL: Duration = Duration::from_millis(500);
/// Entries asked for in one request.
const PAGE: usize = 1000;

/// Arguments of `linterpd log`.
#[derive(Debug, Args)]
pub struct LogArgs {
    /// Entries from this time on: RFC 3339 (2026-11-29T06:00:00Z) or a span back from now
    /// (30s, 10m, 8h, 2d). Without it, the last `--lines` entries (`--counts`: the last 24 h).
    #[arg(long)]
    pub since: Option<String>,
    /// Without --since, how many of the last entries.
    #[arg(long, short = 'n', default_value_t = 50)]
    pub lines: usize,
    /// Keep printing new entries as they come, until Ctrl-C.
    #[arg(long, short)]
    pub follow: bool,
    /// One robot's entries (and the daemon's own).
    #[arg(long, global = true)]
    pub robot: Option<String>,
    /// Production counts per shift (cycles, parts placed, pallets, faults) instead of entries.
    #[arg(long)]
    pub counts: bool,
    /// With --counts, a shift's length (e.g. 8h, 12h).
    #[arg(long, default_value = "8h")]
    pub shift: String,
    /// With --counts, when a day's first shift begins, HH:MM in UTC.
    #[arg(long, default_value = "06:00")]
    pub shift_start: String,
    /// The daemon and output options.
    #[command(flatten)]
    pub daemon: DaemonArgs,
}

/// Runs `linterpd log`.
pub fn run(args: &LogArgs, out: &mut dyn std::io::Write) -> Result<(), Failure> {
    if let Some(since) = &args.since {
        check_since(since)?;
    }
    let daemon = &args.daemon;
    daemon.block_on(async {
        let client = Client::new(&daemon.socket);
        if args.counts {
            return counts(args, &client, out).await;
        }
        let cursor = match &args.since {
            Some(since) => print_all(args, &client, &[("since", since)], out).await?,
            None => {
                let lines = args
                    .lines
                    .clamp(1, crate::daemon::api::MAX_ENTRIES)
                    .to_string();
                let page = fetch(args, &client, &[("limit", &lines), ("newest", "true")]).await?;
                print_entries(&page.entries, daemon.json, out)?;
                page.last_seq
            }
        };
        if args.follow {
            follow(args, &client, cursor, out).await?;
        }
        Ok(())
    })
}

/// Whether `since` is a time or a span, before asking the daemon.
fn check_since(since: &str) -> Result<(), Failure> {
    if parse_span_ms(since).is_ok() {
        return Ok(());
    }
    parse_rfc3339(since).map(|_| ()).map_err(|e| {
        bad_input(anyhow::anyhow!(
            "--since: {e}, or a span back from now (10m, 8h)"
        ))
    })
}

/// One page of the journal.
async fn fetch(
    args: &LogArgs,
    client: &Client,
    params: &[(&str, &str)],
) -> Result<JournalPage, Failure> {
    let mut query: Vec<(&str, &str)> = params.to_vec();
    if let Some(robot) = &args.robot {
        query.push(("robot", robot));
    }
    let path = format!("/v1/journal?{}", encode(&query));
    let answer = client.expect(Method::GET, &path, None).await?;
    Received::read(answer, "the journal")
        .map(|r| r.value)
        .map_err(Failure::Runtime)
}

/// Every entry `params` take, page after page; returns the last number.
async fn print_all(
    args: &LogArgs,
    client: &Client,
    params: &[(&str, &str)],
    out: &mut dyn std::io::Write,
) -> Result<Option<u64>, Failure> {
    let mut cursor: Option<u64> = None;
    loop {
        let after = cursor.map(|c| c.to_string());
        let limit = PAGE.to_string();
        let mut query = params.to_vec();
        query.push(("limit", &limit));
        if let Some(after) = &after {
            query.push(("after", after));
        }
        let page = fetch(args, client, &query).await?;
        print_entries(&page.entries, args.daemon.json, out)?;
        cursor = page.last_seq.or(cursor);
        if page.entries.len() < PAGE {
            return Ok(cursor);
        }
    }
}

/// New entries as they come, until Ctrl-C.
async fn follow(
    args: &LogArgs,
    client: &Client,
    mut cursor: Option<u64>,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    loop {
        tokio::select! {
            _ = tokio::signal::ctrl_c() => return Ok(()),
            () = tokio::time::sleep(POLL) => {}
        }
        let after = cursor.unwrap_or(0).to_string();
        let limit = PAGE.to_string();
        let page = fetch(args, client, &[("after", &after), ("limit", &limit)]).await?;
        print_entries(&page.entries, args.daemon.json, out)?;
        cursor = page.last_seq.or(cursor);
    }
}

fn print_entries(
    entries: &[Entry],
    json: bool,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    for entry in entries {
        let line = if json {
            entry.to_line()
        } else {
            entry.to_string()
        };
        writeln!(out, "{line}").map_err(|e| Failure::Runtime(e.into()))?;
    }
    out.flush().map_err(|e| Failure::Runtime(e.into()))
}

/// `--counts`: every entry since (24 h without --since), counted per shift.
async fn counts(
    args: &LogArgs,
    client: &Client,
    out: &mut dyn std::io::Write,
) -> Result<(), Failure> {
    let shift_ms =
        parse_span_ms(&args.shift).map_err(|e| bad_input(anyhow::anyhow!("--shift: {e}")))?;
    let offset_ms = shift_start_ms(&args.shift_start)?;
    let since = args.since.clone().unwrap_or_else(|| "24h".to_owned());
    let mut entries = Vec::new();
    let mut cursor: Option<u64> = None;
    loop {
        let (after, limit) = (cursor.map(|c| c.to_string()), PAGE.to_string());
        let mut query = vec![("since", since.as_str()), ("limit", limit.as_str())];
        if let Some(after) = &after {
            query.push(("after", after));
        }
        let page = fetch(args, client, &query).await?;
        let full = page.entries.len() == PAGE;
        cursor = page.last_seq.or(cursor);
        entries.extend(page.entries);
        if !full {
            break;
        }
    }
    let shifts = per_shift(&entries, shift_ms, offset_ms);
    let text = if args.daemon.json {
        shifts
            .iter()
            .map(|s| serde_json::to_string(s).unwrap_or_default() + "\n")
            .collect()
    } else {
        counts_table(&shifts)
    };
    write!(out, "{text}").map_err(|e| Failure::Runtime(e.into()))
}

/// `HH:MM` as ms after midnight.
fn shift_start_ms(text: &str) -> Result<u64, Failure> {
    let bad = || {
        bad_input(anyhow::anyhow!(
            "--shift-start {text:?}: must be HH:MM (UTC), e.g. 06:00"
        ))
    };
    let (h, m) = text.split_once(':').ok_or_else(bad)?;
    let (h, m): (u64, u64) = (h.parse().map_err(|_| bad())?, m.parse().map_err(|_| bad())?);
    if h > 23 || m > 59 {
        return Err(bad());
    }
    Ok((h * 60 + m) * 60_000)
}

/// The counts as a table, a shift a line.
fn counts_table(shifts: &[ShiftCounts]) -> String {
    let mut text = format!(
        "{:<40} {:>7} {:>8} {:>6} {:>8} {:>7}\n",
        "shift (UTC)", "cycles", "stopped", "parts", "pallets", "faults"
    );
    for s in shifts {
        let span = format!("{} .. {}", s.from, s.to.get(11..19).unwrap_or(&s.to));
        let _ = writeln!(
            text,
            "{span:<40} {:>7} {:>8} {:>6} {:>8} {:>7}",
            s.cycles, s.stopped, s.parts, s.pallets, s.faults
        );
    }
    if shifts.is_empty() {
        text.push_str("(nothing journaled in that time)\n");
    }
    text
}

/// A query string, each value percent-encoded but for RFC 3986's unreserved characters.
fn encode(pairs: &[(&str, &str)]) -> String {
    let escape = |s: &str| {
        s.bytes()
            .map(|b| match b {
                b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' => {
                    (b as char).to_string()
                }
                _ => format!("%{b:02X}"),
            })
            .collect::<String>()
    };
    pairs
        .iter()
        .map(|(k, v)| format!("{k}={}", escape(v)))
        .collect::<Vec<_>>()
        .join("&")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_time_with_an_offset_is_sent_percent_encoded() {
        assert_eq!(
            encode(&[
                ("since", "2026-11-29T09:00:00+01:00"),
                ("robot", "press-loader")
            ]),
            "since=2026-11-29T09%3A00%3A00%2B01%3A00&robot=press-loader"
        );
    }

    #[test]
    fn since_and_shift_start_are_checked_before_the_daemon_is_asked() {
        assert!(check_since("10m").is_ok());
        assert!(check_since("2026-11-29T06:00:00Z").is_ok());
        let e = check_since("yesterday").unwrap_err();
        assert!(matches!(e, Failure::BadInput(_)));
        assert_eq!(shift_start_ms("06:30").ok(), Some(23_400_000));
        assert!(shift_start_ms("25:00").is_err());
        assert!(shift_start_ms("6").is_err());
    }
}
