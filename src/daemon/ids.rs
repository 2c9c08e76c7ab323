//! Move ids unique across daemon restarts. With a state directory the ids are counted on from
//! where the last run left them, reserved a block at a time in `move-ids` (written atomically:
//! write, fsync, rename), so a crash loses at most the rest of a block. Without one (or when it
//! cannot be written) they start from the clock: milliseconds since 1970 times 1000.

use std::io::{self, Write as _};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{SystemTime, UNIX_EPOCH};

/// Ids reserved by one write of the state file.
const BLOCK: u64 = 1_000;
/// The state file's name in the state directory.
const FILE: &str = "move-ids";

/// Where move ids come from.
#[derive(Debug)]
pub struct MoveIds {
    inner: Mutex<Inner>,
}

#[derive(Debug)]
struct Inner {
    next: u64,
    /// Ids below this are reserved in the file (when there is one).
    reserved: u64,
    file: Option<PathBuf>,
}

impl MoveIds {
    /// Ids from `first` on, remembered nowhere (tests, the demo).
    #[must_use]
    pub fn counting_from(first: u64) -> Self {
        Self {
            inner: Mutex::new(Inner {
                next: first.max(1),
                reserved: u64::MAX,
                file: None,
            }),
        }
    }

    /// Ids from the clock: unique across restarts unless a run makes more than 1000 moves a
    /// millisecond.
    #[must_use]
    pub fn from_clock() -> Self {
        let ms = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        Self::counting_from(ms.saturating_mul(1_000).saturating_add(1))
    }

    /// Ids counted on from the state directory's `move-ids` (1 when there is none yet); the
    /// first block is reserved at once, so an unwritable directory is an error here.
    pub fn in_state_dir(dir: &Path) -> io::Result<Self> {
        let file = dir.join(FILE);
        let next = match std::fs::read_to_string(&file) {
            Ok(text) => text.trim().parse::<u64>().map_err(|e| {
                io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!("{}: {text:?} is not a move id: {e}", file.display()),
                )
            })?,
            Err(e) if e.kind() == io::ErrorKind::NotFound => 1,
            Err(e) => return Err(e),
        };
        let ids = Self {
            inner: Mutex::new(Inner {
                next: next.max(1),
                reserved: 0,
                file: Some(file),
            }),
        };
        ids.reserve()?;
        Ok(ids)
    }

    fn reserve(&self) -> io::Result<()> {
        let mut inner = self
            .inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let Some(file) = inner.file.clone() else {
            return Ok(());
        };
        let reserved = inner.next + BLOCK;
        write_atomically(&file, &format!("{reserved}\n"))?;
        inner.reserved = reserved;
        Ok(())
    }

    /// The next id. When its block is used up the next is reserved; if that write fails the ids
    /// go on from the clock (never repeating one), and the failure is logged.
    ///
    /// # Panics
    /// Never: a poisoned lock is taken over.
    pub fn next(&self) -> u64 {
        let mut inner = self
            .inner
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if inner.next >= inner.reserved {
            drop(inner);
            if let Err(e) = self.reserve() {
                tracing::warn!(error = %e, "cannot reserve move ids; counting on from the clock");
                let clock = Self::from_clock().next();
                let mut inner = self
                    .inner
                    .lock()
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
                inner.file = None;
                inner.reserved = u64::MAX;
                inner.next = inner.next.max(clock);
            }
            inner = self
                .inner
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
        }
        let id = inner.next;
        inner.next += 1;
        id
    }
}

/// Writes `text` to `path` so that a crash leaves the old file or the new one: a temporary file
/// beside it, fsync, rename, fsync of the directory.
pub fn write_atomically(path: &Path, text: &str) -> io::Result<()> {
    let dir = path.parent().unwrap_or_else(|| Path::new("."));
    let name = path
        .file_name()
        .map_or_else(|| "state".into(), |n| n.to_string_lossy().into_owned());
    let tmp = dir.join(format!(".{name}.tmp"));
    {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(text.as_bytes())?;
        f.sync_all()?;
    }
    std::fs::rename(&tmp, path)?;
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::fresh_dir;

    #[test]
    fn ids_go_on_after_a_restart_and_never_repeat() {
        let dir = fresh_dir("ids-restart");
        let first = MoveIds::in_state_dir(&dir).unwrap();
        let a: Vec<u64> = (0..3).map(|_| first.next()).collect();
        assert_eq!(a, [1, 2, 3]);
        drop(first);
        // A restart (or a crash) goes on past the whole reserved block.
        let second = MoveIds::in_state_dir(&dir).unwrap();
        let b = second.next();
        assert!(b > 3, "{b}");
        assert_eq!(b, 1 + BLOCK);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_block_used_up_reserves_the_next() {
        let dir = fresh_dir("ids-block");
        let ids = MoveIds::in_state_dir(&dir).unwrap();
        for _ in 0..BLOCK {
            ids.next();
        }
        assert_eq!(ids.next(), 1 + BLOCK);
        let on_disk: u64 = std::fs::read_to_string(dir.join(FILE))
            .unwrap()
            .trim()
            .parse()
            .unwrap();
        assert_eq!(on_disk, 1 + 2 * BLOCK);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_corrupt_file_is_an_error_naming_it() {
        let dir = fresh_dir("ids-corrupt");
        std::fs::write(dir.join(FILE), "twelve").unwrap();
        let e = MoveIds::in_state_dir(&dir).unwrap_err().to_string();
        assert!(e.contains("move-ids") && e.contains("twelve"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn clock_ids_are_past_any_counted_ones() {
        assert!(MoveIds::from_clock().next() > 1_000_000_000_000_000);
    }
}
