//! `check-config`'s look at each robot's cycle programs: every program of its `programs`
//! directory read and checked as `cycle run` would (`crate::cycle`), against the robot, its
//! signals, input words and gateway; and no program number used twice (naming both files).
//! Taught positions live in the daemon's state, not in the config: a position a program names
//! is taken as taught here, and listed.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::config::Config;
use crate::contract::Layout;
use crate::cycle::{Context, Names, ProgramDoc};
use crate::gateway::GatewaySettings;
use crate::order::permit::PermitNames;
use crate::robot::Position;
use crate::robot::Robot;

/// A program that checked.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Checked {
    /// Its name.
    pub name: String,
    /// Its number, if it has one.
    pub number: Option<u8>,
    /// The ops it flattens into.
    pub ops: usize,
}

/// A robot's programs as checked.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(super) struct Programs {
    /// The directory.
    pub dir: PathBuf,
    /// Every program that checked, by name.
    pub checked: Vec<Checked>,
    /// The positions they name (taken as taught).
    pub positions: BTreeSet<String>,
    /// Everything wrong, one line each.
    pub faults: Vec<String>,
}

/// The cycle programs of `robot`, if its cell names a directory.
pub(super) fn check(config: &Config, robot: &Robot) -> Option<Programs> {
    let cell = config.cells.get(&robot.name)?;
    let dir = cell.programs.clone()?;
    let mut out = Programs {
        dir: dir.clone(),
        ..Programs::default()
    };
    let programs = match crate::cycle::load::programs(&dir) {
        Ok(programs) => programs,
        Err(e) => {
            out.faults.push(e.to_string());
            return Some(out);
        }
    };
    for (name, why) in &programs.broken {
        out.faults
            .push(format!("program {name:?} cannot be read: {why}"));
    }
    let docs = programs.docs;
    let shared = duplicate_numbers(&dir, &docs);
    out.faults
        .extend(shared.iter().map(|(_, line)| line.clone()));
    out.positions = positions(&docs);
    // Taken as taught: the taught poses are the daemon's.
    let taught: BTreeMap<String, Position> = out
        .positions
        .iter()
        .map(|name| (name.clone(), placeholder()))
        .collect();
    let gateway = config.gateway(&robot.name).cloned().unwrap_or_default();
    let layout = config
        .link(&robot.name)
        .map_or_else(Layout::default, |l| l.layout);
    let ctx = Context {
        robot,
        taught: &taught,
        names: names(&cell.signals, &layout, &gateway),
        programs: &docs,
        broken: &programs.broken,
        require_wait_timeout: cell.require_wait_timeout,
        // Not the robot's pose at a run, nor its taught poses: those are the daemon's.
        start: None,
        poses_known: false,
        pallets: &BTreeMap::new(),
    };
    check_each(&ctx, &shared, &mut out);
    Some(out)
}

/// Checks every program of `ctx` into `out`, but those that `shared` a number: those are said
/// once, naming both files.
fn check_each(ctx: &Context, shared: &[(Vec<String>, String)], out: &mut Programs) {
    for name in ctx.programs.keys() {
        if shared.iter().any(|(names, _)| names.contains(name)) {
            continue;
        }
        match crate::cycle::check(name, ctx) {
            Ok(checked) => out.checked.push(Checked {
                name: checked.name,
                number: checked.number,
                ops: checked.ops.len(),
            }),
            Err(e) => out.faults.push(e.to_string()),
        }
    }
}

fn names<'a>(
    signals: &'a BTreeMap<String, crate::gateway::Address>,
    layout: &'a Layout,
    gateway: &'a GatewaySettings,
) -> Names<'a> {
    Names {
        permit: PermitNames {
            signals,
            inputs: &layout.inputs,
        },
        access: &gateway.access,
    }
}

/// A position as the check needs it: any pose (only its name is checked here).
fn placeholder() -> Position {
    Position {
        pose: [0.0; 4],
        joint_counts: [0; crate::kinematics::JOINTS],
        saved_unix_s: 0,
        frame: None,
    }
}

/// Every position a move step names.
fn positions(docs: &BTreeMap<String, ProgramDoc>) -> BTreeSet<String> {
    docs.values()
        .flat_map(|doc| &doc.step)
        .filter_map(|step| step.move_.as_ref()?.position.clone())
        .collect()
}

/// A line per number that two programs share, naming both files, with their names.
fn duplicate_numbers(
    dir: &Path,
    docs: &BTreeMap<String, ProgramDoc>,
) -> Vec<(Vec<String>, String)> {
    let mut by_number: BTreeMap<i64, Vec<&str>> = BTreeMap::new();
    for (name, doc) in docs {
        if let Some(n) = doc.number {
            by_number.entry(n).or_default().push(name);
        }
    }
    by_number
        .into_iter()
        .filter(|(_, names)| names.len() > 1)
        .map(|(n, names)| {
            let files: Vec<String> = names
                .iter()
                .map(|name| dir.join(format!("{name}.toml")).display().to_string())
                .collect();
            let line = format!(
                "programs {} have the same number = {n}: a press line selects a program by its \
                 number, so each needs its own (or none)",
                files.join(" and ")
            );
            (names.iter().map(|n| (*n).to_owned()).collect(), line)
        })
        .collect()
}
