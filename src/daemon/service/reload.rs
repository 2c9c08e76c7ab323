//! SIGHUP (`systemctl reload linterpd`): the config file read again, checked whole, and compared
//! key by key with the config the daemon runs, every section of it. What can change under a
//! running robot is applied at once; the rest is named, section and key, as needing a restart.
//! A config that does not load is refused with its error, and the daemon goes on with the one it
//! runs: a mistake in the file never stops it, and never half-applies.
//!
//! ```text
//!  applied live:   [robots.NAME.gateway]  read, write          (the next register request)
//!                  [robots.NAME.cell]     signals, programs,   (the next order, cycle, check;
//!                                         require_wait_timeout  a cycle under way keeps its own)
//!  needs restart:  [robots.NAME.gateway.modbus], [robots.NAME.cell.face] (bound at start),
//!                  [robots.NAME.plc], the robot itself (kinematics, motion, joints, area_words),
//!                  a robot added or removed, [daemon]
//! ```
//! A robot whose `[robots.NAME.plc]` changed takes none of its changes live: its gateway lists
//! were checked against the new contract layout, and wait for the restart that brings it.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use thiserror::Error;
use toml::{Table, Value};

use crate::config::{Config, ConfigError};
use crate::daemon::RobotHandle;

/// The config file as the daemon runs it: what a reload compares the file with.
#[derive(Debug, Clone, Default)]
pub struct Running {
    table: Table,
}

/// A section whose keys changed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Change {
    /// The section, as the file writes its header: `[robots.press-loader.gateway]`.
    pub section: String,
    /// The keys that changed in it (dotted below the section: `signals.press_go`,
    /// `joints[2].max_freq_hz`), or what happened to it (`robot added`).
    pub keys: Vec<String>,
}

impl fmt::Display for Change {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.section, self.keys.join(", "))
    }
}

/// What a reload found: the changes it applied, and those that need a restart.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Reloaded {
    /// Applied: in effect from the next request on.
    pub applied: Vec<Change>,
    /// Not applied: the daemon runs as before until it is restarted.
    pub restart: Vec<Change>,
}

impl Reloaded {
    /// Whether the file is the config the daemon runs.
    #[must_use]
    pub fn unchanged(&self) -> bool {
        self.applied.is_empty() && self.restart.is_empty()
    }
}

/// Why a reload was refused (the daemon runs on with its config).
#[derive(Debug, Error)]
pub enum ReloadError {
    /// The file cannot be read, parsed or checked.
    #[error(transparent)]
    Config(#[from] ConfigError),
}

impl Running {
    /// The config the daemon starts with, as the file at `path` writes it now.
    pub fn read(path: &Path) -> Result<Self, ReloadError> {
        let (_, table) = load(path)?;
        Ok(Self { table })
    }

    /// Reads `path` again and compares it with what runs: the changes the robots' `handles`
    /// can take live are given to them; the rest are named as needing a restart.
    ///
    /// # Errors
    /// [`ReloadError`] when the file does not load: nothing changes.
    pub fn reload(
        &mut self,
        path: &Path,
        handles: &BTreeMap<String, RobotHandle>,
    ) -> Result<Reloaded, ReloadError> {
        let (config, table) = load(path)?;
        let mut leaves = Vec::new();
        let (old, new) = (
            Value::Table(self.table.clone()),
            Value::Table(table.clone()),
        );
        changed_leaves(&mut Vec::new(), Some(&old), Some(&new), &mut leaves);
        let mut found = group(&leaves, &self.table, &table);
        hold_for_plc(&mut found);
        for change in &found.applied {
            self.apply(change, &config, &table, handles);
        }
        Ok(found)
    }

    /// Gives `change`, a live one, to its robot's handle, and takes it as running.
    fn apply(
        &mut self,
        change: &Change,
        config: &Config,
        new: &Table,
        handles: &BTreeMap<String, RobotHandle>,
    ) {
        let Some((robot, table)) = live_section(&change.section) else {
            return;
        };
        if let Some(handle) = handles.get(robot) {
            if table == "gateway" {
                let access = config.gateway(robot).map(|g| g.access.clone());
                handle.reload_access(access.unwrap_or_default());
            } else {
                let cell = config.cells.get(robot).cloned();
                handle.reload_cell(cell.unwrap_or_default());
            }
        }
        let kept = if table == "gateway" { "modbus" } else { "face" };
        graft(&mut self.table, new, robot, table, kept);
    }
}

/// The config at `path`, checked, and its text as a TOML table.
fn load(path: &Path) -> Result<(Config, Table), ReloadError> {
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
        path: path.to_owned(),
        source,
    })?;
    let config = Config::from_file_text(path, &text)?;
    // It parsed as a config: it is a TOML table.
    let table = text.parse::<Table>().unwrap_or_default();
    Ok((config, table))
}

/// The robot and table (`gateway` or `cell`) of a live section's header.
fn live_section(section: &str) -> Option<(&str, &str)> {
    let inner = section.strip_prefix("[robots.")?.strip_suffix(']')?;
    let (robot, table) = inner.rsplit_once('.')?;
    matches!(table, "gateway" | "cell").then_some((robot, table))
}

/// Puts `new`'s `robots.ROBOT.TABLE` into `running` but for its `kept` entry, which stays as
/// it runs.
fn graft(running: &mut Table, new: &Table, robot: &str, table: &str, kept: &str) {
    let sub = |t: &Table| -> Option<Table> {
        t.get("robots")?.get(robot)?.get(table)?.as_table().cloned()
    };
    let mut taken = sub(new).unwrap_or_default();
    taken.remove(kept);
    if let Some(old) = sub(running).and_then(|mut t| t.remove(kept)) {
        taken.insert(kept.to_owned(), old);
    }
    let Some(Value::Table(robot)) = running
        .get_mut("robots")
        .and_then(|r| r.as_table_mut())
        .and_then(|r| r.get_mut(robot))
    else {
        return;
    };
    if taken.is_empty() {
        robot.remove(table);
    } else {
        robot.insert(table.to_owned(), Value::Table(taken));
    }
}

/// Appends to `out` the path of every leaf that differs between `old` and `new` (a value
/// missing on one side differs; a table or an array of tables is compared entry by entry, an
/// array index written onto its key: `joints[2]`).
fn changed_leaves(
    at: &mut Vec<String>,
    old: Option<&Value>,
    new: Option<&Value>,
    out: &mut Vec<Vec<String>>,
) {
    let empty = Table::new();
    match (old, new) {
        (Some(Value::Table(_)), _) | (_, Some(Value::Table(_))) if tables(old, new) => {
            let (o, n) = (old.and_then(Value::as_table), new.and_then(Value::as_table));
            let (o, n) = (o.unwrap_or(&empty), n.unwrap_or(&empty));
            let keys: std::collections::BTreeSet<&String> = o.keys().chain(n.keys()).collect();
            for key in keys {
                at.push(key.clone());
                changed_leaves(at, o.get(key), n.get(key), out);
                at.pop();
            }
        }
        _ if arrays_of_tables(old, new) => {
            let none = Vec::new();
            let (o, n) = (old.and_then(Value::as_array), new.and_then(Value::as_array));
            let (o, n) = (o.unwrap_or(&none), n.unwrap_or(&none));
            let last = at.pop().unwrap_or_default();
            for i in 0..o.len().max(n.len()) {
                at.push(format!("{last}[{i}]"));
                changed_leaves(at, o.get(i), n.get(i), out);
                at.pop();
            }
            at.push(last);
        }
        _ if old != new => out.push(at.clone()),
        _ => {}
    }
}

/// Whether each side is a table or missing.
fn tables(old: Option<&Value>, new: Option<&Value>) -> bool {
    [old, new].iter().all(|v| v.is_none_or(Value::is_table))
}

/// Whether each side is an array of tables (a non-empty one, at least on one side) or missing.
fn arrays_of_tables(old: Option<&Value>, new: Option<&Value>) -> bool {
    let of_tables = |v: Option<&Value>| {
        v.is_none_or(|v| v.as_array().is_some_and(|a| a.iter().all(Value::is_table)))
    };
    let some = |v: Option<&Value>| v.and_then(Value::as_array).is_some_and(|a| !a.is_empty());
    [old, new].into_iter().all(of_tables) && [old, new].into_iter().any(some)
}

/// The changed leaves grouped into sections, each live or needing a restart; a robot on one
/// side only is one change.
fn group(leaves: &[Vec<String>], old: &Table, new: &Table) -> Reloaded {
    let mut out = Reloaded::default();
    let has = |t: &Table, robot: &str| t.get("robots").and_then(|r| r.get(robot)).is_some();
    for leaf in leaves {
        let (section, key, live) = match leaf.as_slice() {
            [robots, robot, ..] if robots == "robots" && has(old, robot) != has(new, robot) => {
                let what = if has(new, robot) {
                    "robot added"
                } else {
                    "robot removed"
                };
                (format!("[robots.{robot}]"), what.to_owned(), false)
            }
            [robots, robot, rest @ ..] if robots == "robots" => robot_key(robot, rest),
            [table, rest @ ..] if !rest.is_empty() => (format!("[{table}]"), rest.join("."), false),
            _ => ("(the top level)".to_owned(), leaf.join("."), false),
        };
        let list = if live {
            &mut out.applied
        } else {
            &mut out.restart
        };
        match list.iter_mut().find(|c| c.section == section) {
            Some(c) if !c.keys.contains(&key) => c.keys.push(key),
            Some(_) => {}
            None => list.push(Change {
                section,
                keys: vec![key],
            }),
        }
    }
    out
}

/// A robot's changed key (its path below `robots.ROBOT`) as a section, a key, and whether it
/// applies live.
fn robot_key(robot: &str, rest: &[String]) -> (String, String, bool) {
    let section = |tables: &[String]| format!("[robots.{robot}.{}]", tables.join("."));
    match rest {
        [t, bound, keys @ ..]
            if (t == "gateway" && bound == "modbus") || (t == "cell" && bound == "face") =>
        {
            let key = if keys.is_empty() {
                bound.clone()
            } else {
                keys.join(".")
            };
            (section(&rest[..2]), key, false)
        }
        [t, keys @ ..] if matches!(t.as_str(), "gateway" | "cell") && !keys.is_empty() => {
            (section(&rest[..1]), keys.join("."), true)
        }
        [t, keys @ ..] if !keys.is_empty() && !t.contains('[') => {
            (section(&rest[..1]), keys.join("."), false)
        }
        _ => (format!("[robots.{robot}]"), rest.join("."), false),
    }
}

/// Moves a robot's live changes to those needing a restart when its `[robots.NAME.plc]`
/// changed too (see the module's docs).
fn hold_for_plc(found: &mut Reloaded) {
    let plc_changed = |robot: &str| {
        let plc = format!("[robots.{robot}.plc]");
        found.restart.iter().any(|c| c.section == plc)
    };
    let (held, live): (Vec<Change>, Vec<Change>) = found
        .applied
        .drain(..)
        .partition(|c| live_section(&c.section).is_some_and(|(robot, _)| plc_changed(robot)));
    found.applied = live;
    found.restart.extend(held);
}

/// Logs what a reload of `path` found: every change, applied or needing a restart, or that the
/// file is the config that runs; a refused file with its error.
/// A reload as the journal keeps it: what was applied and what waits for a restart, or why the
/// config was refused.
pub(super) fn journaled(reloaded: &Result<Reloaded, ReloadError>) -> crate::wire::journal::Kind {
    use crate::wire::journal::Kind;
    match reloaded {
        Ok(r) => Kind::ConfigReloaded {
            applied: r.applied.iter().map(ToString::to_string).collect(),
            needs_restart: r.restart.iter().map(ToString::to_string).collect(),
        },
        Err(e) => Kind::ConfigRefused {
            error: e.to_string(),
        },
    }
}

pub(super) fn log(path: &Path, reloaded: &Result<Reloaded, ReloadError>) {
    let config = path.display();
    match reloaded {
        Err(e) => tracing::error!(
            %config,
            error = %e,
            "SIGHUP: the config is refused; the daemon goes on with the config it runs"
        ),
        Ok(r) if r.unchanged() => {
            tracing::info!(%config, "SIGHUP: the config is unchanged");
        }
        Ok(r) => {
            for change in &r.applied {
                tracing::info!(%config, "SIGHUP: applied {change}");
            }
            for change in &r.restart {
                tracing::warn!(
                    %config,
                    "SIGHUP: {change} changed: needs a restart to apply (systemctl restart \
                     linterpd); until then the daemon runs as it was started"
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TRY: &str = include_str!("../../../config/try.toml");

    /// A config file holding `text` in a fresh directory, and what runs from it.
    fn started(name: &str, text: &str) -> (std::path::PathBuf, Running) {
        let path = crate::testing::fresh_dir(name).join("linterpd.toml");
        std::fs::write(&path, text).unwrap();
        let running = Running::read(&path).unwrap();
        (path, running)
    }

    fn edited(from: &str, to: &str) -> String {
        assert!(TRY.contains(from), "{from}");
        TRY.replace(from, to)
    }

    fn change(section: &str, keys: &[&str]) -> Change {
        Change {
            section: section.to_owned(),
            keys: keys.iter().map(|k| (*k).to_owned()).collect(),
        }
    }

    #[test]
    fn an_unchanged_file_is_unchanged() {
        let (path, mut running) = started("reload-same", TRY);
        let found = running.reload(&path, &BTreeMap::new()).unwrap();
        assert!(found.unchanged(), "{found:?}");
    }

    #[test]
    fn gateway_lists_and_cell_signals_apply_live_and_say_which_keys() {
        // Issue 47: a changed cell or gateway was "unchanged" (only robots, links, [daemon]).
        let (path, mut running) = started("reload-live", TRY);
        let text = edited("write = [\"Y0-Y7\"]", "write = [\"Y0-Y7\", \"R0-R1F\"]")
            .replace("gripper = \"Y1\"", "gripper = \"Y2\"")
            .replace(
                "require_wait_timeout = true",
                "require_wait_timeout = false",
            );
        std::fs::write(&path, text).unwrap();
        let found = running.reload(&path, &BTreeMap::new()).unwrap();
        assert_eq!(
            found.applied,
            [
                change(
                    "[robots.press-loader.cell]",
                    &["require_wait_timeout", "signals.gripper"]
                ),
                change("[robots.press-loader.gateway]", &["write"]),
            ]
        );
        assert!(found.restart.is_empty(), "{found:?}");
        // Applied: the same file again is the config that runs.
        assert!(running.reload(&path, &BTreeMap::new()).unwrap().unchanged());
    }

    #[test]
    fn a_face_a_modbus_face_a_link_and_the_daemon_need_a_restart_naming_section_and_key() {
        let (path, mut running) = started("reload-restart", TRY);
        let text = edited("station = 1", "station = 2")
            .replace(
                "write = [\"Y0-Y7\"]",
                "write = [\"Y0-Y7\"]\nmodbus = { listen = \"127.0.0.1:0\" }",
            )
            .replace(
                "require_wait_timeout = true",
                "require_wait_timeout = true\n[robots.press-loader.cell.face]\nregisters = 50000",
            )
            .replace("speed_mm_s = 240.0", "speed_mm_s = 200.0")
            .replace(
                "state_dir = \"../target/try\"",
                "state_dir = \"../target/try2\"",
            );
        std::fs::write(&path, &text).unwrap();
        let found = running.reload(&path, &BTreeMap::new()).unwrap();
        assert!(found.applied.is_empty(), "{found:?}");
        let shown: Vec<String> = found.restart.iter().map(ToString::to_string).collect();
        for expected in [
            "[daemon] state_dir",
            "[robots.press-loader.cell.face] registers",
            "[robots.press-loader.gateway.modbus] listen",
            "[robots.press-loader.motion] speed_mm_s",
            "[robots.press-loader.plc] station",
        ] {
            assert!(shown.iter().any(|s| s == expected), "{expected}: {shown:?}");
        }
        // Not applied: said again at the next reload, until the restart.
        assert_eq!(running.reload(&path, &BTreeMap::new()).unwrap(), found);
    }

    #[test]
    fn a_joint_changed_is_named_by_its_index_and_a_robot_added_once() {
        let (path, mut running) = started("reload-joint", TRY);
        let text = TRY.replacen("max_freq_hz = 100000", "max_freq_hz = 90000", 1);
        std::fs::write(&path, &text).unwrap();
        let found = running.reload(&path, &BTreeMap::new()).unwrap();
        assert_eq!(
            found.restart,
            [change("[robots.press-loader]", &["joints[0].max_freq_hz"])]
        );
        let other = TRY.split("[robots.press-loader.plc]").next().unwrap();
        let twin = other.replace("robots.press-loader", "robots.twin");
        std::fs::write(&path, format!("{TRY}\n{twin}")).unwrap();
        let (_, mut running) = started("reload-joint-2", TRY);
        let found = running.reload(&path, &BTreeMap::new()).unwrap();
        assert_eq!(found.restart, [change("[robots.twin]", &["robot added"])]);
    }

    #[test]
    fn a_link_changed_holds_the_robots_live_changes_for_the_restart() {
        let (path, mut running) = started("reload-held", TRY);
        let text =
            edited("station = 1", "station = 2").replace("gripper = \"Y1\"", "gripper = \"Y2\"");
        std::fs::write(&path, text).unwrap();
        let found = running.reload(&path, &BTreeMap::new()).unwrap();
        assert!(found.applied.is_empty(), "{found:?}");
        assert_eq!(
            found.restart,
            [
                change("[robots.press-loader.plc]", &["station"]),
                change("[robots.press-loader.cell]", &["signals.gripper"]),
            ]
        );
    }

    #[test]
    fn a_config_that_does_not_load_is_refused_with_its_error_and_the_running_one_kept() {
        let (path, mut running) = started("reload-bad", TRY);
        std::fs::write(&path, edited("station = 1", "statoin = 1")).unwrap();
        let e = running
            .reload(&path, &BTreeMap::new())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&path.display().to_string()) && e.contains("statoin"),
            "{e}"
        );
        // What runs is what ran: the file put back is unchanged.
        std::fs::write(&path, TRY).unwrap();
        assert!(running.reload(&path, &BTreeMap::new()).unwrap().unchanged());
    }
}
