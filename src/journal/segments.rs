//! The journal's files: segments named by the first entry's number
//! (`00000000000000000001.jsonl`), one JSON line an entry, the newest the one appended to.
//! Opening finds where the journal stands (the next number; a torn last line cut off), reading
//! takes entries by number, time and robot.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Read as _, Seek as _, SeekFrom, Write as _};
use std::path::{Path, PathBuf};

use super::JournalError;
use crate::wire::journal::Entry;

/// A segment's file name suffix.
const SUFFIX: &str = ".jsonl";

/// A segment: its file and the number of its first entry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Segment {
    /// Its first entry's number.
    pub first: u64,
    /// Its file.
    pub path: PathBuf,
}

/// The file of the segment starting at `first`.
pub(super) fn segment_path(dir: &Path, first: u64) -> PathBuf {
    dir.join(format!("{first:020}{SUFFIX}"))
}

/// The segments in `dir`, oldest first (other files are left alone).
pub(super) fn segments(dir: &Path) -> Result<Vec<Segment>, JournalError> {
    let read = |source| JournalError::Read {
        path: dir.to_owned(),
        source,
    };
    let mut out = Vec::new();
    for entry in fs::read_dir(dir).map_err(read)? {
        let path = entry.map_err(read)?.path();
        let first = path
            .file_name()
            .and_then(|n| n.to_str())
            .and_then(|n| n.strip_suffix(SUFFIX))
            .filter(|n| n.len() == 20)
            .and_then(|n| n.parse::<u64>().ok());
        if let Some(first) = first {
            out.push(Segment { first, path });
        }
    }
    out.sort_by_key(|s| s.first);
    Ok(out)
}

/// Where the newest segment stands once opened: the next number, and a torn end cut off.
#[derive(Debug)]
pub(super) struct Tail {
    /// The number the next entry takes.
    pub next_seq: u64,
    /// Its length now, bytes.
    pub bytes: u64,
    /// Bytes cut off its end (a torn line, or a power cut's zeros), if any.
    pub torn: Option<u64>,
}

/// Opens `segment` for appending: the last whole entry gives the next number; anything after it
/// (a line a power cut tore, zeros) is cut off, so the next entry starts a line of its own.
pub(super) fn open_tail(segment: &Segment) -> Result<(File, Tail), JournalError> {
    let fail = |source| JournalError::Read {
        path: segment.path.clone(),
        source,
    };
    let mut file = OpenOptions::new()
        .read(true)
        .append(true)
        .open(&segment.path)
        .map_err(fail)?;
    let mut text = Vec::new();
    file.read_to_end(&mut text).map_err(fail)?;
    let (keep, last) = last_entry(&text);
    let torn = (keep < text.len()).then(|| (text.len() - keep) as u64);
    if torn.is_some() {
        file.set_len(keep as u64).map_err(fail)?;
        file.sync_all().map_err(fail)?;
        file.seek(SeekFrom::End(0)).map_err(fail)?;
    }
    let mut bytes = keep as u64;
    if keep > 0 && text[keep - 1] != b'\n' {
        file.write_all(b"\n").map_err(fail)?;
        bytes += 1;
    }
    let next_seq = last.map_or(segment.first, |e| e.seq + 1);
    Ok((
        file,
        Tail {
            next_seq,
            bytes,
            torn,
        },
    ))
}

/// The length of `text` up to the end of its last whole entry (its line break included), and
/// that entry.
fn last_entry(text: &[u8]) -> (usize, Option<Entry>) {
    let mut end = text.len();
    loop {
        let body = &text[..end];
        let start = body.iter().rposition(|b| *b == b'\n').map_or(0, |i| i + 1);
        let line = &body[start..];
        if let Some(entry) = std::str::from_utf8(line)
            .ok()
            .and_then(|l| Entry::from_line(l).ok())
        {
            // A whole entry missing only its line break is kept (the opener adds the break).
            let keep = if text.get(end) == Some(&b'\n') {
                end + 1
            } else {
                end
            };
            return (keep, Some(entry));
        }
        if start == 0 {
            return (0, None);
        }
        end = start - 1;
    }
}

/// What to read.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Query {
    /// Entries after this number only.
    pub after: Option<u64>,
    /// Entries at or after this time only, ms since the epoch.
    pub since_ms: Option<u64>,
    /// One robot's entries only (and the daemon's own, which name no robot).
    pub robot: Option<String>,
    /// At most this many.
    pub limit: usize,
    /// The newest `limit` rather than the oldest.
    pub newest: bool,
}

impl Query {
    fn takes(&self, e: &Entry) -> bool {
        self.after.is_none_or(|a| e.seq > a)
            && self.since_ms.is_none_or(|s| e.at_ms >= s)
            && self
                .robot
                .as_ref()
                .is_none_or(|r| e.robot.as_ref().is_none_or(|er| er == r))
    }
}

/// The entries of `dir` that `query` takes, oldest first.
pub(super) fn read(dir: &Path, query: &Query) -> Result<Vec<Entry>, JournalError> {
    let all = segments(dir)?;
    // A segment holds the numbers from its first to the next one's first, less one.
    let wanted: Vec<&Segment> = all
        .iter()
        .enumerate()
        .filter(|(i, _)| {
            let next = all.get(i + 1).map(|s| s.first);
            query.after.is_none_or(|a| next.is_none_or(|n| n > a + 1))
        })
        .map(|(_, s)| s)
        .collect();
    let mut out = Vec::new();
    if query.newest {
        for segment in wanted.iter().rev() {
            let mut entries = entries_of(segment, query)?;
            entries.append(&mut out);
            out = entries;
            if out.len() >= query.limit {
                break;
            }
        }
        let extra = out.len().saturating_sub(query.limit);
        out.drain(..extra);
    } else {
        for segment in wanted {
            out.extend(entries_of(segment, query)?);
            if out.len() >= query.limit {
                break;
            }
        }
        out.truncate(query.limit);
    }
    Ok(out)
}

/// A segment's entries that `query` takes (lines that are not entries skipped; a file removed
/// since it was listed has none).
fn entries_of(segment: &Segment, query: &Query) -> Result<Vec<Entry>, JournalError> {
    let text = match fs::read_to_string(&segment.path) {
        Ok(t) => t,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(source) => {
            return Err(JournalError::Read {
                path: segment.path.clone(),
                source,
            });
        }
    };
    Ok(text
        .lines()
        .filter_map(|l| Entry::from_line(l).ok())
        .filter(|e| query.takes(e))
        .collect())
}
