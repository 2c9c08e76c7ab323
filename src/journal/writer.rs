//! The journal's writer thread: takes entries from the daemon's tasks over a bounded channel,
//! numbers them, appends them to the newest segment (a new one when it would pass the size
//! cap, the oldest removed past the number kept), and makes them durable: at once after a
//! durable kind ([`Kind::durable`]) or a flush, else within [`SYNC_EVERY`].
//!
//! ```text
//!  tasks --try_send (never blocks; full: dropped, counted)--> channel (queue)
//!    --> writer: batch of up to BATCH -> [dropped n] -> lines -> write -> fdatasync if durable
//! ```

use std::fs::File;
use std::io::Write as _;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use super::segments::{Segment, segment_path, segments};
use super::{Counters, JournalError, Message, Pending};
use crate::config::JournalSettings;
use crate::wire::journal::{Entry, Kind};

/// Longest an entry that is not durable waits for its fsync.
pub(super) const SYNC_EVERY: Duration = Duration::from_secs(1);
/// Most messages taken in one batch.
const BATCH: usize = 1024;
/// How long the writer sleeps with nothing to write and nothing to sync.
const IDLE: Duration = Duration::from_secs(3600);

/// What a batch left on the disk.
enum Written {
    /// Written and synced (or only synced: a flush).
    Synced,
    /// Written, its fsync still due.
    Unsynced,
    /// Nothing.
    Nothing,
}

/// The newest segment, appended to.
pub(super) struct Writer {
    dir: PathBuf,
    settings: JournalSettings,
    file: File,
    bytes: u64,
    next_seq: u64,
    counters: Arc<Counters>,
    /// Drops already journaled.
    dropped_told: u64,
}

impl Writer {
    /// The writer of `dir`, its newest segment opened (a first one made in an empty journal),
    /// and the bytes a torn end had (cut off), with the segment's name.
    pub(super) fn open(
        dir: PathBuf,
        settings: JournalSettings,
        counters: Arc<Counters>,
    ) -> Result<(Self, Option<(String, u64)>), JournalError> {
        let newest = match segments(&dir)?.pop() {
            Some(s) => s,
            None => Segment {
                first: 1,
                path: create(&dir, 1)?,
            },
        };
        let (file, tail) = super::segments::open_tail(&newest)?;
        let torn = tail.torn.map(|bytes| {
            let name = newest
                .path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            (name, bytes)
        });
        let writer = Self {
            dir,
            settings,
            file,
            bytes: tail.bytes,
            next_seq: tail.next_seq,
            counters,
            dropped_told: 0,
        };
        Ok((writer, torn))
    }

    /// The number the next entry takes.
    pub(super) fn next_seq(&self) -> u64 {
        self.next_seq
    }

    /// Runs until every sender is gone: batches in, lines out, fsync where it matters (and
    /// within [`SYNC_EVERY`] of the first write not yet synced, however busy the queue).
    pub(super) fn run(mut self, rx: &Receiver<Message>) {
        let mut dirty_since: Option<Instant> = None;
        loop {
            let wait = dirty_since.map_or(IDLE, |t| SYNC_EVERY.saturating_sub(t.elapsed()));
            match rx.recv_timeout(wait) {
                Ok(first) => {
                    let mut batch = vec![first];
                    batch.extend(rx.try_iter().take(BATCH - 1));
                    match self.take(batch) {
                        Written::Synced => dirty_since = None,
                        Written::Unsynced => {
                            dirty_since.get_or_insert_with(Instant::now);
                        }
                        Written::Nothing => {}
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if dirty_since.is_some_and(|t| t.elapsed() >= SYNC_EVERY) && self.sync() {
                dirty_since = None;
            }
        }
        if dirty_since.is_some() {
            self.sync();
        }
    }

    /// Writes a batch, and syncs it when it holds a durable entry or a flush.
    fn take(&mut self, batch: Vec<Message>) -> Written {
        let mut entries = Vec::with_capacity(batch.len() + 1);
        let mut flushes = Vec::new();
        let dropped = self.counters.dropped.load(Ordering::Relaxed);
        if dropped > self.dropped_told {
            entries.push(Pending {
                at_ms: super::now_ms(),
                robot: None,
                kind: Kind::Dropped {
                    entries: dropped - self.dropped_told,
                },
            });
            self.dropped_told = dropped;
        }
        for message in batch {
            match message {
                Message::Entry(p) => entries.push(p),
                Message::Flush(done) => flushes.push(done),
            }
        }
        let durable = !flushes.is_empty() || entries.iter().any(|p| p.kind.durable());
        let written = self.append(entries);
        let synced = durable && self.sync();
        for done in flushes {
            let _ = done.send(());
        }
        match (synced, written) {
            (true, _) => Written::Synced,
            (false, true) => Written::Unsynced,
            (false, false) => Written::Nothing,
        }
    }

    /// Numbers the entries and appends them, a new segment started where one would pass the
    /// cap; returns whether anything was written.
    fn append(&mut self, entries: Vec<Pending>) -> bool {
        let mut buffer = Vec::new();
        let mut written = false;
        for pending in entries {
            let line = Entry {
                seq: self.next_seq,
                at_ms: pending.at_ms,
                robot: pending.robot,
                kind: pending.kind,
            }
            .to_line();
            let size = line.len() as u64 + 1;
            if self.bytes + buffer.len() as u64 + size > self.settings.file_bytes
                && self.bytes + buffer.len() as u64 > 0
            {
                written |= self.write(&mut buffer);
                self.rotate();
            }
            buffer.extend_from_slice(line.as_bytes());
            buffer.push(b'\n');
            self.next_seq += 1;
        }
        written | self.write(&mut buffer)
    }

    /// Writes `buffer` to the newest segment (emptying it).
    fn write(&mut self, buffer: &mut Vec<u8>) -> bool {
        if buffer.is_empty() {
            return false;
        }
        let lines = buffer.iter().filter(|b| **b == b'\n').count() as u64;
        match self.file.write_all(buffer) {
            Ok(()) => {
                self.bytes += buffer.len() as u64;
                self.counters.written.fetch_add(lines, Ordering::Relaxed);
            }
            Err(e) => self.failed(lines, &e),
        }
        buffer.clear();
        true
    }

    /// Starts a segment at the next number; removes the oldest past the number kept.
    fn rotate(&mut self) {
        self.sync();
        match create(&self.dir, self.next_seq).and_then(|path| {
            std::fs::OpenOptions::new()
                .append(true)
                .open(&path)
                .map_err(|source| JournalError::Write { path, source })
        }) {
            Ok(file) => {
                self.file = file;
                self.bytes = 0;
            }
            Err(e) => {
                tracing::warn!(error = %e, "the journal cannot start a new file; it goes on in the old one")
            }
        }
        let Ok(all) = segments(&self.dir) else {
            return;
        };
        let extra = all.len().saturating_sub(self.settings.files as usize);
        for old in &all[..extra] {
            if let Err(e) = std::fs::remove_file(&old.path) {
                tracing::warn!(file = %old.path.display(), error = %e, "cannot remove an old journal file");
            }
        }
    }

    /// fdatasync of the newest segment; whether it held.
    fn sync(&mut self) -> bool {
        match self.file.sync_data() {
            Ok(()) => {
                self.counters.syncs.fetch_add(1, Ordering::Relaxed);
                true
            }
            Err(e) => {
                self.failed(0, &e);
                false
            }
        }
    }

    fn failed(&self, lines: u64, e: &std::io::Error) {
        let before = self
            .counters
            .failed
            .fetch_add(lines.max(1), Ordering::Relaxed);
        if before == 0 || before.is_power_of_two() {
            tracing::warn!(error = %e, failures = before + 1, "the journal cannot write");
        }
    }
}

/// Creates the segment starting at `first` and makes its name durable (the directory synced).
fn create(dir: &std::path::Path, first: u64) -> Result<PathBuf, JournalError> {
    let path = segment_path(dir, first);
    let fail = |source| JournalError::Write {
        path: path.clone(),
        source,
    };
    std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .map_err(fail)?;
    File::open(dir).and_then(|d| d.sync_all()).map_err(fail)?;
    Ok(path)
}
