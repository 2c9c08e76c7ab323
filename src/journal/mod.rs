//! The cell's journal on disk (issue 48, item 5): what the cell did, appended as JSON lines
//! ([`crate::wire::journal::Entry`]) to a bounded set of files in the state directory, kept
//! across restarts, made durable where it matters, and written without slowing anything: the
//! daemon's tasks hand entries to a writer thread over a bounded channel and never wait on the
//! disk; when the channel is full the entry is dropped and counted, and the count is journaled
//! (`dropped`) and on `/metrics`.
//!
//! ```text
//!  state_dir/journal/00000000000000000001.jsonl   segments named by their first entry's
//!                    00000000000000004712.jsonl   number; the newest is appended to; at most
//!                                                 `files` of at most `file_bytes` each
//!  mod.rs       Journal: the cheap, cloneable handle (record, flush, read, counts)
//!  writer.rs    the writer thread: numbers, appends, rotates, fsyncs
//!  segments.rs  the files: listing, opening the newest (a torn end cut off), reading
//! ```

mod segments;
mod writer;

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{SyncSender, TrySendError, sync_channel};

use thiserror::Error;

use crate::config::JournalSettings;
use crate::wire::journal::{Entry, Kind};

pub use segments::Query;

/// The journal's folder in the state directory.
pub const DIR: &str = "journal";

/// Why the journal cannot be opened or read.
#[derive(Debug, Error)]
pub enum JournalError {
    /// Its folder or a file could not be read.
    #[error("cannot read the journal at {}", path.display())]
    Read {
        /// The folder or file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Its folder or a file could not be made or written.
    #[error("cannot write the journal at {}", path.display())]
    Write {
        /// The folder or file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
}

/// What the journal has done since the daemon started.
#[derive(Debug, Default)]
struct Counters {
    written: AtomicU64,
    dropped: AtomicU64,
    failed: AtomicU64,
    syncs: AtomicU64,
}

/// [`Counters`] read at one moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct JournalCounts {
    /// Entries written.
    pub written: u64,
    /// Entries dropped because the queue was full.
    pub dropped: u64,
    /// Entries (or fsyncs) that failed on the disk.
    pub failed: u64,
    /// fsyncs done.
    pub syncs: u64,
}

/// An entry on its way to the writer: numbered there.
#[derive(Debug)]
struct Pending {
    at_ms: u64,
    robot: Option<String>,
    kind: Kind,
}

/// What the writer thread is sent.
#[derive(Debug)]
enum Message {
    Entry(Pending),
    /// Write and fsync everything before it, then answer.
    Flush(tokio::sync::oneshot::Sender<()>),
}

#[derive(Debug)]
struct Inner {
    dir: PathBuf,
    tx: SyncSender<Message>,
    counters: Arc<Counters>,
}

/// The journal: cheap to clone, shared by every task that records into it. [`Journal::off`]
/// records nothing (the daemon in tests, and a library user without a state directory).
#[derive(Debug, Clone, Default)]
pub struct Journal(Option<Arc<Inner>>);

impl Journal {
    /// A journal that records nothing.
    #[must_use]
    pub fn off() -> Self {
        Self(None)
    }

    /// Opens (or makes) the journal in `dir` and starts its writer thread. A torn line at the
    /// end (a power cut during a write) is cut off with a warning and journaled (`torn-line`).
    pub fn open(dir: &Path, settings: &JournalSettings) -> Result<Self, JournalError> {
        std::fs::create_dir_all(dir).map_err(|source| JournalError::Write {
            path: dir.to_owned(),
            source,
        })?;
        let counters = Arc::new(Counters::default());
        let (writer, torn) =
            writer::Writer::open(dir.to_owned(), *settings, Arc::clone(&counters))?;
        let (tx, rx) = sync_channel(settings.queue.max(1));
        let next = writer.next_seq();
        std::thread::Builder::new()
            .name("journal".into())
            .spawn(move || writer.run(&rx))
            .map_err(|source| JournalError::Write {
                path: dir.to_owned(),
                source,
            })?;
        let journal = Self(Some(Arc::new(Inner {
            dir: dir.to_owned(),
            tx,
            counters,
        })));
        tracing::info!(dir = %dir.display(), next_seq = next, "journal open");
        if let Some((file, bytes)) = torn {
            tracing::warn!(
                file,
                bytes,
                "the journal's last line was torn (a power cut?): cut off"
            );
            journal.record(None, Kind::TornLine { file, bytes });
        }
        Ok(journal)
    }

    /// Whether it records anything.
    #[must_use]
    pub fn is_on(&self) -> bool {
        self.0.is_some()
    }

    /// Records `kind` (about `robot`) at the time now; never waits: when the writer's queue is
    /// full the entry is dropped and counted.
    pub fn record(&self, robot: Option<&str>, kind: Kind) {
        let Some(inner) = &self.0 else {
            return;
        };
        let pending = Pending {
            at_ms: now_ms(),
            robot: robot.map(str::to_owned),
            kind,
        };
        match inner.tx.try_send(Message::Entry(pending)) {
            Ok(()) => {}
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                inner.counters.dropped.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// A part placed on `pallet`'s `slot` (in `layer`), both from 1: for the cycle's place step.
    pub fn pallet_placed(&self, robot: &str, pallet: &str, slot: u32, layer: u32) {
        self.record(
            Some(robot),
            Kind::PalletPlaced {
                pallet: pallet.to_owned(),
                slot,
                layer,
            },
        );
    }

    /// `pallet` full with `parts` on it.
    pub fn pallet_full(&self, robot: &str, pallet: &str, parts: u32) {
        self.record(
            Some(robot),
            Kind::PalletFull {
                pallet: pallet.to_owned(),
                parts,
            },
        );
    }

    /// Waits until everything recorded before is written and fsync'd.
    pub async fn flush(&self) {
        let Some(inner) = &self.0 else {
            return;
        };
        let (done, wait) = tokio::sync::oneshot::channel();
        let mut message = Message::Flush(done);
        loop {
            match inner.tx.try_send(message) {
                Ok(()) => break,
                Err(TrySendError::Full(m)) => {
                    message = m;
                    tokio::time::sleep(std::time::Duration::from_millis(1)).await;
                }
                Err(TrySendError::Disconnected(_)) => return,
            }
        }
        let _ = wait.await;
    }

    /// The entries `query` takes, oldest first (blocking file reads: call it off the runtime's
    /// threads, `spawn_blocking`).
    pub fn read(&self, query: &Query) -> Result<Vec<Entry>, JournalError> {
        match &self.0 {
            Some(inner) => segments::read(&inner.dir, query),
            None => Ok(Vec::new()),
        }
    }

    /// What it has done since it was opened.
    #[must_use]
    pub fn counts(&self) -> JournalCounts {
        let Some(inner) = &self.0 else {
            return JournalCounts::default();
        };
        let c = &inner.counters;
        JournalCounts {
            written: c.written.load(Ordering::Relaxed),
            dropped: c.dropped.load(Ordering::Relaxed),
            failed: c.failed.load(Ordering::Relaxed),
            syncs: c.syncs.load(Ordering::Relaxed),
        }
    }
}

/// The wall time now, ms since the Unix epoch.
pub fn now_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

#[cfg(test)]
mod tests;
