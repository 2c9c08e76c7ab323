//! Taught positions: named poses per robot, each with the joint counts it was taught at, kept
//! across restarts in the state directory's `positions.json` (written atomically: a temporary
//! file, fsync, rename).
//!
//! ```json
//! {"linterpd_positions": 1,
//!  "robots": {"press-loader": {"pick": {"pose": [0.0, 520.0, 20.0, 0.0],
//!                                       "joint_counts": [0, 800, 1538, 0],
//!                                       "saved_unix_s": 1767225600}}}}
//! ```
//!
//! A file that cannot be parsed, is of another version or holds a bad name or a number that is
//! not finite is corrupt: it is refused with an error naming the file and the problem, moved
//! aside (`positions.json.corrupt-<unix seconds>`), and the daemon starts with no positions and
//! says so in its log and in the API's answers about positions. A file that cannot be read (or
//! set aside) is left alone and changes are refused, so it is never overwritten blindly.

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::state_file::{Kept, Trouble, WriteFailed};
use crate::contract::machine::Blocker;

/// The file's name in the state directory.
pub const POSITIONS_FILE: &str = "positions.json";
/// The format version this daemon reads and writes.
const VERSION: u32 = 1;
pub use crate::robot::POSITION_NAME_RULE as NAME_RULE;

pub use crate::robot::Position;

/// Every robot's positions, by robot name and position name.
type Book = BTreeMap<String, BTreeMap<String, Position>>;

/// The file as written.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PositionsFile {
    linterpd_positions: u32,
    robots: Book,
}

/// Why a position request failed.
#[derive(Debug, Error)]
pub enum PositionError {
    /// A name that breaks the rule.
    #[error("position name {name:?}: {NAME_RULE}")]
    BadName {
        /// The name as given.
        name: String,
    },
    /// No such position for the robot.
    #[error("no position {name:?} for robot {robot}; {}", known_text(known))]
    NotFound {
        /// The robot.
        robot: String,
        /// The name asked for.
        name: String,
        /// The robot's positions.
        known: Vec<String>,
    },
    /// The robot's pose cannot be taken now (link down, not homed...).
    #[error("cannot take the robot's pose: {blocker}")]
    NotNow {
        /// Why.
        blocker: Blocker,
    },
    /// The frame to keep the position in cannot be used.
    #[error(transparent)]
    Frame {
        /// Why.
        source: Box<crate::pallet::PalletError>,
    },
    /// The robot moves (or a move waits): its pose is not one to teach.
    #[error(
        "cannot take the robot's pose while it moves or moves wait (move {current} current, {queued} \
         queued): save a position when the robot stands still"
    )]
    Busy {
        /// The move running (`-` when none).
        current: String,
        /// Moves waiting.
        queued: usize,
    },
    /// The positions file could not be written; nothing was changed.
    #[error("cannot write the positions file {}: {source}; nothing was changed", file.display())]
    Write {
        /// The file.
        file: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// The positions file could not be read at start: changes are refused so it is not
    /// overwritten.
    #[error("positions cannot be changed: {why}")]
    ReadOnly {
        /// What went wrong with the file.
        why: String,
    },
}

fn known_text(known: &[String]) -> String {
    if known.is_empty() {
        "it has none".to_owned()
    } else {
        format!("positions: {}", known.join(", "))
    }
}

/// Checks `name` against [`NAME_RULE`].
pub fn check_name(name: &str) -> Result<(), PositionError> {
    if crate::robot::is_position_name(name) {
        Ok(())
    } else {
        Err(PositionError::BadName {
            name: name.to_owned(),
        })
    }
}

/// What went wrong with the positions file at start, logged: the warning shown, and why
/// changes are refused (if they are).
fn noted(trouble: Trouble) -> (Option<String>, Option<String>) {
    let (warning, read_only) = match trouble {
        Trouble::SetAside { why, aside } => {
            let shown = aside.display();
            let what = format!(
                "{why}; it was kept aside as {shown}, and the daemon started with no positions"
            );
            (what, None)
        }
        Trouble::Stuck(why) => {
            let what = format!("{why}, so positions cannot be changed");
            (what.clone(), Some(what))
        }
        Trouble::Unreadable(why) => {
            tracing::error!("{why}; starting with no positions and refusing changes");
            return (
                Some(format!("{why}; no positions are available")),
                Some(why),
            );
        }
    };
    tracing::error!("{warning}");
    (Some(warning), read_only)
}

/// Seconds since 1970, now.
#[must_use]
pub fn unix_now_s() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// The taught positions of every robot of one daemon.
#[derive(Debug, Default)]
pub struct TaughtPositions {
    /// The positions, and where they are kept.
    kept: Kept<Book>,
    /// What became of the file at start, when something went wrong with it.
    warning: Option<String>,
}

impl TaughtPositions {
    /// Positions kept in memory only (tests, the demo): none to start with.
    #[must_use]
    pub fn in_memory() -> Self {
        Self::default()
    }

    /// The positions kept in `dir`'s `positions.json` (none when there is no file yet). A
    /// corrupt file is set aside and logged, and the daemon starts with none; one that cannot
    /// be read is left alone, logged, and changes are refused.
    #[must_use]
    pub fn in_state_dir(dir: &Path) -> Self {
        let (mut kept, trouble) = Kept::open(dir.join(POSITIONS_FILE), "positions", parse);
        let (warning, read_only) = trouble.map_or((None, None), noted);
        if let Some(why) = read_only {
            kept.refuse_changes(why);
        }
        Self { kept, warning }
    }

    /// What went wrong with the file at start, if anything did.
    #[must_use]
    pub fn warning(&self) -> Option<&str> {
        self.warning.as_deref()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Book> {
        self.kept.lock()
    }

    /// A robot's positions, by name.
    #[must_use]
    pub fn of(&self, robot: &str) -> BTreeMap<String, Position> {
        self.lock().get(robot).cloned().unwrap_or_default()
    }

    /// One position of a robot.
    pub fn get(&self, robot: &str, name: &str) -> Result<Position, PositionError> {
        check_name(name)?;
        let book = self.lock();
        let positions = book.get(robot);
        positions
            .and_then(|p| p.get(name))
            .cloned()
            .ok_or_else(|| not_found(robot, name, positions))
    }

    /// Saves (or replaces) a robot's position; returns whether one was replaced.
    pub fn save(&self, robot: &str, name: &str, position: Position) -> Result<bool, PositionError> {
        check_name(name)?;
        self.change(|book| {
            Ok(book
                .entry(robot.to_owned())
                .or_default()
                .insert(name.to_owned(), position)
                .is_some())
        })
    }

    /// Deletes a robot's position; returns it.
    pub fn delete(&self, robot: &str, name: &str) -> Result<Position, PositionError> {
        check_name(name)?;
        self.change(|book| {
            let positions = book.get_mut(robot);
            let removed = positions.and_then(|p| p.remove(name));
            let removed = removed.ok_or_else(|| not_found(robot, name, book.get(robot)))?;
            if book.get(robot).is_some_and(BTreeMap::is_empty) {
                book.remove(robot);
            }
            Ok(removed)
        })
    }

    /// Applies `f` to a copy of the book, writes it, and only then keeps it.
    fn change<T>(
        &self,
        f: impl FnOnce(&mut Book) -> Result<T, PositionError>,
    ) -> Result<T, PositionError> {
        if let Some(why) = self.kept.read_only() {
            return Err(PositionError::ReadOnly {
                why: why.to_owned(),
            });
        }
        let mut book = self.lock();
        let mut next = book.clone();
        let out = f(&mut next)?;
        let kept = self.kept.keep(&mut book, next, render);
        kept.map_err(|WriteFailed { file, source }| PositionError::Write { file, source })?;
        Ok(out)
    }
}

fn not_found(
    robot: &str,
    name: &str,
    positions: Option<&BTreeMap<String, Position>>,
) -> PositionError {
    PositionError::NotFound {
        robot: robot.to_owned(),
        name: name.to_owned(),
        known: positions
            .map(|p| p.keys().cloned().collect())
            .unwrap_or_default(),
    }
}

/// The file's text for `book`.
fn render(book: &Book) -> String {
    let file = PositionsFile {
        linterpd_positions: VERSION,
        robots: book.clone(),
    };
    let mut text = serde_json::to_string_pretty(&file).expect("positions always serialize");
    text.push('\n');
    text
}

/// What is wrong with a positions file's bytes (the file is then corrupt).
#[derive(Debug, Error)]
enum CorruptFile {
    /// Not JSON of the file's form.
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// Another format version.
    #[error("linterpd_positions is {found}; this linterpd reads version {VERSION}")]
    Version {
        /// The version the file says.
        found: u32,
    },
    /// A position name that breaks the rule.
    #[error("robot {robot:?}: {source}")]
    Name {
        /// The robot.
        robot: String,
        /// The name's fault.
        #[source]
        source: PositionError,
    },
    /// A pose with a number that is not finite.
    #[error("robot {robot:?}, position {name:?}: pose {pose:?} is not finite")]
    NotFinite {
        /// The robot.
        robot: String,
        /// The position.
        name: String,
        /// Its pose.
        pose: [f64; 4],
    },
}

/// The book in a file's bytes, or what is wrong with them.
fn parse(bytes: &[u8]) -> Result<Book, CorruptFile> {
    let file: PositionsFile = serde_json::from_slice(bytes)?;
    if file.linterpd_positions != VERSION {
        return Err(CorruptFile::Version {
            found: file.linterpd_positions,
        });
    }
    for (robot, positions) in &file.robots {
        for (name, position) in positions {
            check_name(name).map_err(|source| CorruptFile::Name {
                robot: robot.clone(),
                source,
            })?;
            if position.pose.iter().any(|v| !v.is_finite()) {
                return Err(CorruptFile::NotFinite {
                    robot: robot.clone(),
                    name: name.clone(),
                    pose: position.pose,
                });
            }
        }
    }
    Ok(file.robots)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("linterpd-positions-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn pick() -> Position {
        Position {
            pose: [0.0, 520.0, 20.0, 0.0],
            joint_counts: [0, 800, 1_538, 0],
            saved_unix_s: 1_767_225_600,
            frame: None,
        }
    }

    #[test]
    fn names_follow_the_rule() {
        for good in ["pick", "P1", "a_b-c", "_x", &"x".repeat(32)] {
            assert!(check_name(good).is_ok(), "{good}");
        }
        for bad in ["", "-x", "a b", "über", "a/b", "..", &"x".repeat(33)] {
            let e = check_name(bad).unwrap_err().to_string();
            assert!(e.ends_with(NAME_RULE), "{e}");
        }
    }

    #[test]
    fn positions_survive_a_reopening_and_deletes_stick() {
        let dir = temp_dir("reopen");
        let first = TaughtPositions::in_state_dir(&dir);
        assert!(!first.save("r", "pick", pick()).unwrap());
        assert!(first.save("r", "pick", pick()).unwrap(), "replaced");
        first.save("r", "place", pick()).unwrap();
        drop(first);
        let second = TaughtPositions::in_state_dir(&dir);
        assert!(second.warning().is_none());
        assert_eq!(second.get("r", "pick").unwrap(), pick());
        assert_eq!(second.of("r").len(), 2);
        second.delete("r", "place").unwrap();
        let third = TaughtPositions::in_state_dir(&dir);
        assert_eq!(third.of("r").keys().collect::<Vec<_>>(), ["pick"]);
        let e = third.get("r", "place").unwrap_err().to_string();
        assert_eq!(e, "no position \"place\" for robot r; positions: pick");
        assert!(third.of("other").is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_corrupt_file_is_refused_kept_aside_and_replaced_by_none() {
        for (text, problem) in [
            (
                "{\"linterpd_positions\": 1, \"robots\": {\"r\": {\"pick\": ",
                "EOF while parsing",
            ),
            (
                "{\"linterpd_positions\": 2, \"robots\": {}}",
                "this linterpd reads version 1",
            ),
            (
                "{\"linterpd_positions\": 1, \"robots\": {\"r\": {\"a b\": {\"pose\": [0,0,0,0], \"joint_counts\": [0,0,0,0], \"saved_unix_s\": 0}}}}",
                NAME_RULE,
            ),
        ] {
            let dir = temp_dir("corrupt");
            std::fs::write(dir.join(POSITIONS_FILE), text).unwrap();
            let taught = TaughtPositions::in_state_dir(&dir);
            let warning = taught.warning().unwrap().to_owned();
            assert!(
                warning.contains("positions.json is corrupt") && warning.contains(problem),
                "{warning}"
            );
            assert!(warning.contains("kept aside as"), "{warning}");
            assert!(taught.of("r").is_empty());
            let aside: Vec<_> = std::fs::read_dir(&dir)
                .unwrap()
                .map(|e| e.unwrap().file_name().into_string().unwrap())
                .filter(|n| n.starts_with("positions.json.corrupt-"))
                .collect();
            assert_eq!(aside.len(), 1, "{aside:?}");
            assert_eq!(std::fs::read_to_string(dir.join(&aside[0])).unwrap(), text);
            assert!(!dir.join(POSITIONS_FILE).exists());
            // Saving works again, into a fresh file.
            taught.save("r", "pick", pick()).unwrap();
            assert_eq!(
                TaughtPositions::in_state_dir(&dir)
                    .get("r", "pick")
                    .unwrap(),
                pick()
            );
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }

    #[test]
    fn a_failed_write_changes_nothing() {
        let dir = temp_dir("unwritable");
        let taught = TaughtPositions::in_state_dir(&dir.join("missing"));
        let e = taught.save("r", "pick", pick()).unwrap_err().to_string();
        assert!(
            e.starts_with("cannot write the positions file") && e.contains("missing"),
            "{e}"
        );
        assert!(taught.of("r").is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
