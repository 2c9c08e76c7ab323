//! A state file the daemon reads once at start (the taught positions, the pallets' counters):
//! no file yet is nothing kept; a corrupt one is moved aside (`NAME.corrupt-UNIX_S`, `-N`
//! added when that is taken) so a restart does not trip on it again; one that cannot be read is
//! left alone. What the owner makes of each is its own.

use std::fmt::Display;
use std::io;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

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
