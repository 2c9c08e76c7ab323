//! A state file the daemon reads once at start (the taught positions, the pallets' counters):
//! no file yet is nothing kept; a corrupt one is moved aside (`NAME.corrupt-UNIX_S`, `-N`
//! added when that is taken) so a restart does not trip on it again; one that cannot be read is
//! left alone. What the owner makes of each is its own. What it holds is kept in memory
//! ([`Kept`]) and written whole, atomically, before a change of it is kept.

use std::fmt::Display;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};
use std::time::{SystemTime, UNIX_EPOCH};

use super::ids::write_atomically;

/// What a state file holds (`B`: its book), kept in memory behind a lock; a change is kept only
/// once the file is written with it.
#[derive(Debug, Default)]
pub(crate) struct Kept<B> {
    book: Mutex<B>,
    /// Where it is kept (`None`: in memory only).
    file: Option<PathBuf>,
    /// Why changes are refused, when they are.
    read_only: Option<String>,
}

/// The state file could not be written: nothing changed.
#[derive(Debug)]
pub(crate) struct WriteFailed {
    /// The file.
    pub file: PathBuf,
    /// Why.
    pub source: io::Error,
}

impl<B: Default> Kept<B> {
    /// What `file`, the daemon's `what` file, holds, read with `parse` ([`open`]), and what
    /// went wrong with it.
    pub(crate) fn open<E: Display>(
        file: PathBuf,
        what: &str,
        parse: impl FnOnce(&[u8]) -> Result<B, E>,
    ) -> (Self, Option<Trouble>) {
        let (book, trouble) = open(&file, what, parse);
        let kept = Self {
            book: Mutex::new(book),
            file: Some(file),
            read_only: None,
        };
        (kept, trouble)
    }

    /// Changes are refused from now on, `why`.
    pub(crate) fn refuse_changes(&mut self, why: String) {
        self.read_only = Some(why);
    }

    /// Why changes are refused, when they are.
    pub(crate) fn read_only(&self) -> Option<&str> {
        self.read_only.as_deref()
    }

    /// The book, locked.
    pub(crate) fn lock(&self) -> MutexGuard<'_, B> {
        self.book.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Keeps `next` as the book locked in `book`, once the file is written with it (its text
    /// from `render`); the write that failed (nothing changed) otherwise.
    pub(crate) fn keep(
        &self,
        book: &mut MutexGuard<'_, B>,
        next: B,
        render: impl FnOnce(&B) -> String,
    ) -> Result<(), WriteFailed> {
        if let Some(file) = &self.file {
            write_atomically(file, &render(&next)).map_err(|source| WriteFailed {
                file: file.clone(),
                source,
            })?;
        }
        **book = next;
        Ok(())
    }
}

/// What went wrong with a state file at start.
#[derive(Debug)]
pub(crate) enum Trouble {
    /// Corrupt (`why`: the file and the problem), kept aside as `aside`.
    SetAside {
        /// "the NAME file F is corrupt: PROBLEM".
        why: String,
        /// Where it is now.
        aside: PathBuf,
    },
    /// Corrupt, and it could not be moved aside (`why` says both).
    Stuck(String),
    /// It could not be read (`why` names the file and the error).
    Unreadable(String),
}

/// Reads `file`, the daemon's `what` file (`"positions"`), with `parse`: what it holds (the
/// default when there is no file yet, or it is set aside or unread), and what went wrong.
pub(crate) fn open<B: Default, E: Display>(
    file: &Path,
    what: &str,
    parse: impl FnOnce(&[u8]) -> Result<B, E>,
) -> (B, Option<Trouble>) {
    let bytes = match std::fs::read(file) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return (B::default(), None),
        Err(e) => {
            let why = format!("cannot read the {what} file {}: {e}", file.display());
            return (B::default(), Some(Trouble::Unreadable(why)));
        }
    };
    let problem = match parse(&bytes) {
        Ok(book) => return (book, None),
        Err(problem) => problem,
    };
    let why = format!("the {what} file {} is corrupt: {problem}", file.display());
    let aside = aside_name(file);
    let trouble = match std::fs::rename(file, &aside) {
        Ok(()) => Trouble::SetAside { why, aside },
        Err(e) => Trouble::Stuck(format!("{why}; it could not be moved aside ({e})")),
    };
    (B::default(), Some(trouble))
}

/// A name beside `file` for it set aside, not yet taken.
fn aside_name(file: &Path) -> PathBuf {
    let name = file.file_name().unwrap_or_default().to_string_lossy();
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut aside = file.with_file_name(format!("{name}.corrupt-{now}"));
    for n in 1.. {
        if !aside.exists() {
            break;
        }
        aside = file.with_file_name(format!("{name}.corrupt-{now}-{n}"));
    }
    aside
}
