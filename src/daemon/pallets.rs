//! Pallet counters: each robot's pallets' [`Counter`]s, kept across restarts in the state
//! directory's `pallets.json`, written atomically (a temporary file, fsync, rename, fsync of the
//! directory) at every change and before the change is kept: the cycle's next step starts only
//! once its pallet's counter is on disk.
//!
//! ```json
//! {"linterpd_pallets": 1,
//!  "robots": {"palletiser": {"out": {"index": 7, "in_progress": {"slot": 7, "phase": "at-slot"},
//!                                    "full": false, "parts": 31, "pallets": 1}}}}
//! ```
//!
//! At start every slot in progress becomes unsure ([`Counter::restored`]): the cycle refuses to
//! place on that pallet until the operator chooses redo or go on. A file that cannot be parsed is
//! moved aside (`pallets.json.corrupt-<unix seconds>`) and every pallet it held is unknown: the
//! cycle refuses to place on a pallet until the operator sets it (`linterpd pallet set`). A file
//! that cannot be read is left alone and every change is refused.

use std::collections::BTreeMap;
use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::state_file::{Kept, Trouble, WriteFailed};
use crate::pallet::counter::Phase;
use crate::pallet::{Counter, CounterError, PalletError, Pattern, RobotPallets};
use crate::robot::{Position, Robot};

/// The robots' pallets: each robot's frames and pallet tables (from the config, laid out
/// against its taught positions at every cycle check) and every pallet's counter.
#[derive(Debug)]
pub struct Pallets {
    /// Each robot's frames and pallets, by robot (a robot with none is not listed).
    pub sets: BTreeMap<String, RobotPallets>,
    /// Every pallet's counter.
    pub counters: PalletCounters,
}

impl Default for Pallets {
    /// No pallets, counters in memory.
    fn default() -> Self {
        Self {
            sets: BTreeMap::new(),
            counters: PalletCounters::in_memory(),
        }
    }
}

impl Pallets {
    /// Robot `robot`'s pallets laid out with its taught positions `taught`, checked against its
    /// reach (none: an empty map).
    ///
    /// # Errors
    /// The first pallet that cannot be laid out or reached, naming the pallet and the slot.
    pub fn patterns(
        &self,
        robot: &Robot,
        taught: &BTreeMap<String, Position>,
    ) -> Result<BTreeMap<String, Pattern>, PalletError> {
        match self.sets.get(&robot.name) {
            Some(set) => set.patterns(robot, taught),
            None => Ok(BTreeMap::new()),
        }
    }
}

/// The file's name in the state directory.
pub const PALLETS_FILE: &str = "pallets.json";
/// The format version this daemon reads and writes.
const VERSION: u32 = 1;

/// Every robot's pallets' counters, by robot and pallet.
type Book = BTreeMap<String, BTreeMap<String, Counter>>;

/// The file as written.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PalletsFile {
    linterpd_pallets: u32,
    robots: Book,
}

/// Why a pallet's counter was not changed.
#[derive(Debug, Error)]
pub enum PalletStoreError {
    /// The counter refused the change.
    #[error(transparent)]
    Counter(#[from] CounterError),
    /// The pallet's count was lost with a corrupt file: the operator sets it first.
    #[error(
        "pallet {pallet:?}: its count was lost ({why}); set it (`linterpd pallet set`) before the \
         cycle places on it"
    )]
    Unknown {
        /// The pallet.
        pallet: String,
        /// What happened to the file.
        why: String,
    },
    /// The file could not be written: nothing changed.
    #[error("writing the pallets file {}: {source}", file.display())]
    Write {
        /// The file.
        file: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// Changes are refused (the file could not be read at start).
    #[error("pallet counters cannot be changed: {why}")]
    ReadOnly {
        /// Why.
        why: String,
    },
}

/// The pallet counters of every robot of one daemon.
#[derive(Debug, Default)]
pub struct PalletCounters {
    /// The counters, and where they are kept.
    kept: Kept<Book>,
    /// Why the counts of pallets not in the book are unknown (a corrupt file set aside).
    lost: Option<String>,
}

impl PalletCounters {
    /// Counters in memory only (tests, the demo): every pallet at slot 0.
    #[must_use]
    pub fn in_memory() -> Self {
        Self::default()
    }

    /// The counters kept in `dir`'s `pallets.json`, as a restart finds them (a slot in progress
    /// is unsure).
    #[must_use]
    pub fn in_state_dir(dir: &Path) -> Self {
        let (kept, trouble) = Kept::open(dir.join(PALLETS_FILE), "pallets", parse);
        let mut store = Self { kept, lost: None };
        match trouble {
            None => {}
            Some(Trouble::SetAside { why, aside }) => {
                let why = format!("{why}; it was kept aside as {}", aside.display());
                tracing::error!("{why}; every pallet must be set before the cycle places on it");
                store.lost = Some(why);
            }
            Some(Trouble::Stuck(why) | Trouble::Unreadable(why)) => {
                tracing::error!("{why}; pallet counters cannot be changed");
                store.kept.refuse_changes(why);
            }
        }
        store
    }

    /// What went wrong with the file at start, if anything did.
    #[must_use]
    pub fn warning(&self) -> Option<&str> {
        self.kept.read_only().or(self.lost.as_deref())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Book> {
        self.kept.lock()
    }

    /// A robot's pallets' counters, by pallet (those never changed are not listed).
    #[must_use]
    pub fn of(&self, robot: &str) -> BTreeMap<String, Counter> {
        self.lock().get(robot).cloned().unwrap_or_default()
    }

    /// One pallet's counter (slot 0 when never changed).
    #[must_use]
    pub fn get(&self, robot: &str, pallet: &str) -> Counter {
        self.lock()
            .get(robot)
            .and_then(|p| p.get(pallet))
            .copied()
            .unwrap_or_default()
    }

    /// Applies `f` to a copy of the pallet's counter, writes the book with it, and only then
    /// keeps it; returns what `f` returned. A pallet whose count was lost takes only
    /// [`Self::set_by_operator`].
    ///
    /// # Errors
    /// The counter's refusal, a lost count, or the write that failed (nothing changed).
    pub fn change<T>(
        &self,
        robot: &str,
        pallet: &str,
        f: impl FnOnce(&mut Counter) -> Result<T, CounterError>,
    ) -> Result<T, PalletStoreError> {
        self.apply(robot, pallet, false, f)
    }

    /// An operator's change (set, reset, redo, go on): taken even for a pallet whose count was
    /// lost, which it makes known again.
    ///
    /// # Errors
    /// As [`Self::change`].
    pub fn set_by_operator<T>(
        &self,
        robot: &str,
        pallet: &str,
        f: impl FnOnce(&mut Counter) -> Result<T, CounterError>,
    ) -> Result<T, PalletStoreError> {
        self.apply(robot, pallet, true, f)
    }

    /// The PLC under `robot` restarted (its outputs went off: a gripper let go wherever the
    /// robot was): every slot of its pallets in progress, whatever its phase, becomes unsure, as
    /// a restart of the daemon makes it ([`Counter::restored`]). Returns the pallets and slots
    /// made unsure.
    ///
    /// # Errors
    /// The write that failed (nothing changed).
    pub fn interrupted(&self, robot: &str) -> Result<Vec<(String, usize)>, PalletStoreError> {
        let mut unsure = Vec::new();
        for (pallet, counter) in self.of(robot) {
            if let Some(p) = counter.in_progress.filter(|p| p.phase != Phase::Unsure) {
                self.change(robot, &pallet, |c| {
                    *c = c.restored();
                    Ok(())
                })?;
                unsure.push((pallet, p.slot));
            }
        }
        Ok(unsure)
    }

    fn apply<T>(
        &self,
        robot: &str,
        pallet: &str,
        operator: bool,
        f: impl FnOnce(&mut Counter) -> Result<T, CounterError>,
    ) -> Result<T, PalletStoreError> {
        if let Some(why) = self.kept.read_only() {
            return Err(PalletStoreError::ReadOnly {
                why: why.to_owned(),
            });
        }
        let mut book = self.lock();
        let known = book.get(robot).and_then(|p| p.get(pallet)).copied();
        let mut counter = match (known, &self.lost) {
            (Some(c), _) => c,
            (None, Some(why)) if !operator => {
                return Err(PalletStoreError::Unknown {
                    pallet: pallet.to_owned(),
                    why: why.clone(),
                });
            }
            (None, _) => Counter::default(),
        };
        // A refusal can still change the counter (a slot found unsure): that is kept too.
        let out = f(&mut counter);
        if known != Some(counter) {
            let mut next = book.clone();
            next.entry(robot.to_owned())
                .or_default()
                .insert(pallet.to_owned(), counter);
            let kept = self.kept.keep(&mut book, next, render);
            kept.map_err(|WriteFailed { file, source }| PalletStoreError::Write { file, source })?;
        }
        Ok(out?)
    }
}

fn render(book: &Book) -> String {
    let file = PalletsFile {
        linterpd_pallets: VERSION,
        robots: book.clone(),
    };
    let mut text = serde_json::to_string_pretty(&file).expect("counters are plain data");
    text.push('\n');
    text
}

/// The file's book, every slot in progress made unsure.
fn parse(bytes: &[u8]) -> Result<Book, PalletsFileError> {
    let file: PalletsFile = serde_json::from_slice(bytes)?;
    if file.linterpd_pallets != VERSION {
        return Err(PalletsFileError::Version(file.linterpd_pallets));
    }
    Ok(file
        .robots
        .into_iter()
        .map(|(robot, pallets)| {
            let pallets = pallets.into_iter().map(|(n, c)| (n, c.restored()));
            (robot, pallets.collect())
        })
        .collect())
}

/// Why the file's text is not a pallets file.
#[derive(Debug, Error)]
enum PalletsFileError {
    /// Not its JSON.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// Another version.
    #[error("linterpd_pallets = {0}; this daemon reads version {VERSION}")]
    Version(u32),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pallet::Choice;
    use crate::pallet::counter::Phase;
    use crate::testing::fresh_dir;

    fn place(store: &PalletCounters, len: usize) -> usize {
        store.change("r", "out", |c| c.begin("out", len)).unwrap();
        store.change("r", "out", |c| c.arrived("out")).unwrap();
        store.change("r", "out", |c| Ok(c.advance(len))).unwrap()
    }

    #[test]
    fn counters_survive_a_restart_and_a_slot_in_progress_comes_back_unsure() {
        let dir = fresh_dir("pallets-restart");
        let store = PalletCounters::in_state_dir(&dir);
        assert_eq!(place(&store, 24), 0);
        assert_eq!(place(&store, 24), 1);
        store.change("r", "out", |c| c.begin("out", 24)).unwrap();
        // Killed here: the file is what a restart reads.
        drop(store);
        let store = PalletCounters::in_state_dir(&dir);
        let c = store.get("r", "out");
        assert_eq!((c.index, c.parts, c.needs_choice()), (2, 2, Some(2)));
        let e = store
            .change("r", "out", |c| c.begin("out", 24))
            .unwrap_err();
        assert!(e.to_string().contains("choose redo"), "{e}");
        store
            .set_by_operator("r", "out", |c| c.choose("out", Choice::Redo, 24))
            .unwrap();
        assert_eq!(place(&store, 24), 2);
        drop(store);
        let c = PalletCounters::in_state_dir(&dir).get("r", "out");
        assert_eq!((c.index, c.parts, c.in_progress), (3, 3, None));
    }

    #[test]
    fn a_corrupt_file_is_set_aside_and_its_pallets_wait_for_the_operator() {
        let dir = fresh_dir("pallets-corrupt");
        std::fs::write(dir.join(PALLETS_FILE), "{\"linterpd_pallets\": 1, \"rob").unwrap();
        let store = PalletCounters::in_state_dir(&dir);
        assert!(store.warning().unwrap().contains("corrupt"));
        let e = store
            .change("r", "out", |c| c.begin("out", 24))
            .unwrap_err();
        assert!(matches!(e, PalletStoreError::Unknown { .. }), "{e}");
        store
            .set_by_operator("r", "out", |c| c.set("out", 9, 24))
            .unwrap();
        assert_eq!(store.change("r", "out", |c| c.begin("out", 24)).unwrap(), 9);
        let aside = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(Result::ok)
            .any(|e| e.file_name().to_string_lossy().contains(".corrupt-"));
        assert!(aside);
    }

    #[test]
    fn a_failed_write_changes_nothing() {
        let dir = fresh_dir("pallets-write");
        let store = PalletCounters::in_state_dir(&dir);
        place(&store, 3);
        std::fs::remove_dir_all(&dir).unwrap();
        let e = store.change("r", "out", |c| c.begin("out", 3)).unwrap_err();
        assert!(matches!(e, PalletStoreError::Write { .. }), "{e}");
        let c = store.get("r", "out");
        assert_eq!((c.index, c.in_progress), (1, None));
    }

    #[test]
    fn the_phase_is_on_disk_before_the_change_returns() {
        let dir = fresh_dir("pallets-phase");
        let store = PalletCounters::in_state_dir(&dir);
        store.change("r", "out", |c| c.begin("out", 3)).unwrap();
        store.change("r", "out", |c| c.arrived("out")).unwrap();
        let text = std::fs::read_to_string(dir.join(PALLETS_FILE)).unwrap();
        let file: PalletsFile = serde_json::from_str(&text).unwrap();
        let c = file.robots["r"]["out"];
        assert_eq!(c.in_progress.map(|p| p.phase), Some(Phase::AtSlot));
    }

    #[test]
    fn a_plc_restart_makes_every_slot_in_progress_unsure_on_disk() {
        let dir = fresh_dir("pallets-plc-restart");
        let store = PalletCounters::in_state_dir(&dir);
        place(&store, 3);
        store.change("r", "out", |c| c.begin("out", 3)).unwrap();
        store.change("r", "in", |c| c.begin("in", 3)).unwrap();
        store.change("r", "in", |c| c.arrived("in")).unwrap();
        store.change("r", "done", |c| Ok(c.advance(3))).unwrap();
        let unsure = store.interrupted("r").unwrap();
        assert_eq!(unsure, [("in".to_owned(), 0), ("out".to_owned(), 1)]);
        assert_eq!(store.get("r", "out").needs_choice(), Some(1));
        assert_eq!(store.get("r", "done").needs_choice(), None);
        let text = std::fs::read_to_string(dir.join(PALLETS_FILE)).unwrap();
        let file: PalletsFile = serde_json::from_str(&text).unwrap();
        assert_eq!(file.robots["r"]["in"].needs_choice(), Some(0));
        // Once unsure, nothing more to mark.
        assert!(store.interrupted("r").unwrap().is_empty());
    }
}
