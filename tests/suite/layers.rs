//! The layering rule of docs/DEVELOPMENT.md ("Layers"), checked on the source text: the pure
//! modules import nothing that does IO, and at every level of the tree the modules side by side
//! import each other one way only (no circle between siblings, the files of a folder counted as
//! one), and inside daemon/ no module imports its parent's siblings back. Test code (`tests.rs`,
//! `*_tests.rs`, a trailing `#[cfg(test)] mod`) is left out: a test may reach anywhere.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The modules that do no IO and read no clock (src/lib.rs, "Layout").
const PURE: [&str; 13] = [
    "console",
    "geometry",
    "kinematics",
    "robot",
    "plan",
    "table",
    "sim",
    "contract",
    "cell",
    "cycle",
    "order",
    "pallet",
    "wire",
];

/// The circles left, each as (folder, its modules in the circle): none (the last, in daemon/,
/// went with issue 45: the handle a thin sender of requests, the cycle's and the cell's state
/// each with an owner of its own). A circle not listed fails the test, and so does one listed
/// that is gone (strike it off).
const KNOWN_CIRCLES: [(&str, &[&str]); 0] = [];

/// The modules that do IO: no pure module imports them.
const IO: [&str; 7] = [
    "daemon",
    "cli",
    "plc",
    "demo",
    "commission",
    "mock",
    "journal",
];

type Module = Vec<String>;

/// Every library file by its module path (`daemon::worker::events`), test files left out.
fn modules(src: &Path) -> BTreeMap<Module, String> {
    let mut out = BTreeMap::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(dir) = dirs.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            if path.is_dir() {
                if name != "tests" {
                    dirs.push(path);
                }
                continue;
            }
            let Some(stem) = name.strip_suffix(".rs") else {
                continue;
            };
            if stem == "tests" || stem.ends_with("_tests") || stem == "testing" || stem == "main" {
                continue;
            }
            let rel = path.strip_prefix(src).unwrap();
            let mut module: Module = rel
                .parent()
                .unwrap()
                .components()
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            if stem != "mod" && stem != "lib" {
                module.push(stem.to_owned());
            }
            out.insert(
                module,
                library_text(&std::fs::read_to_string(&path).unwrap()),
            );
        }
    }
    out
}

/// A file's code without its comments, its string literals and a trailing test module.
fn library_text(text: &str) -> String {
    let text = match text.find("\n#[cfg(test)]\nmod ") {
        Some(at) => &text[..at],
        None => text,
    };
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut in_string = false;
        let mut escaped = false;
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            if in_string {
                if escaped {
                    escaped = false;
                } else if c == '\\' {
                    escaped = true;
                } else if c == '"' {
                    in_string = false;
                    out.push('"');
                }
                continue;
            }
            if c == '/' && chars.peek() == Some(&'/') {
                break;
            }
            if c == '"' {
                in_string = true;
            }
            out.push(c);
        }
        out.push('\n');
    }
    out
}

/// `a::{b, c::{d, e}}` as `a::b`, `a::c::d`, `a::c::e`.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        return vec![tree.to_owned()];
    };
    let (prefix, body) = (&tree[..open], &tree[open + 1..tree.rfind('}').unwrap()]);
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, c) in body.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&body[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&body[start..]);
    parts
        .into_iter()
        .filter(|p| !p.trim().is_empty())
        .flat_map(|p| expand(p).into_iter().map(|e| format!("{prefix}{e}")))
        .collect()
}

/// What each file re-exports: a name it makes public (`pub use a::b::Name;`) and the path it
/// names, as written there.
type Reexports = BTreeMap<Module, BTreeMap<String, String>>;

fn reexports(files: &BTreeMap<Module, String>) -> Reexports {
    files
        .iter()
        .map(|(module, text)| {
            let mut names = BTreeMap::new();
            for statement in text.split(';') {
                let statement = statement.trim();
                let Some(rest) = statement
                    .strip_prefix("pub use ")
                    .or_else(|| statement.strip_prefix("pub(crate) use "))
                    .or_else(|| statement.strip_prefix("pub(super) use "))
                else {
                    continue;
                };
                for path in expand(rest) {
                    let name = path.rsplit("::").next().unwrap_or_default();
                    let name = name.split(" as ").last().unwrap_or(name).trim();
                    let path = if path.starts_with("crate::")
                        || path.starts_with("super::")
                        || path.starts_with("self::")
                    {
                        path.clone()
                    } else {
                        format!("self::{path}")
                    };
                    names.insert(name.to_owned(), path);
                }
            }
            (module.clone(), names)
        })
        .collect()
}

/// The deepest library file a path names, seen from `from` (`None`: not a crate path), through
/// re-exports: `crate::daemon::RobotHandle` is the file that defines the handle, not
/// daemon/mod.rs that re-exports it.
fn resolve(
    files: &BTreeMap<Module, String>,
    reexported: &Reexports,
    from: &Module,
    path: &str,
    depth: usize,
) -> Option<Module> {
    let mut segments = path
        .split("::")
        .map(|s| s.split(" as ").next().unwrap().trim())
        .peekable();
    let mut base = match *segments.peek()? {
        "crate" => Vec::new(),
        "super" | "self" => from.clone(),
        _ => return None,
    };
    while let Some(&s) = segments.peek() {
        match s {
            "crate" | "self" => {}
            "super" => {
                base.pop();
            }
            _ => break,
        }
        segments.next();
    }
    let mut best = base.clone();
    for s in segments {
        base.push(s.to_owned());
        if files.contains_key(&base) {
            best.clone_from(&base);
            continue;
        }
        // An item of `best`: where `best` re-exports it from, if it does.
        if depth < 8
            && let Some(target) = reexported.get(&best).and_then(|names| names.get(s))
            && let Some(found) = resolve(files, reexported, &best, target, depth + 1)
        {
            return Some(found);
        }
        break;
    }
    Some(best)
}

/// Which files each file imports (by `use` or by a path written out).
fn imports(files: &BTreeMap<Module, String>) -> BTreeMap<Module, BTreeSet<Module>> {
    let reexported = reexports(files);
    files
        .iter()
        .map(|(module, text)| {
            let mut paths = Vec::new();
            for statement in text.split(';') {
                if let Some(at) = statement.find("use ") {
                    let before = &statement[..at];
                    if before.is_empty() || before.ends_with(char::is_whitespace) {
                        paths.extend(expand(&statement[at + 4..]));
                    }
                }
            }
            for (at, _) in text.match_indices("::") {
                let start = text[..at]
                    .rfind(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                    .map_or(0, |i| i + 1);
                let end = text[at..]
                    .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                    .map_or(text.len(), |i| at + i);
                paths.push(text[start..end].trim_end_matches(':').to_owned());
            }
            let targets = paths
                .iter()
                .filter_map(|p| resolve(files, &reexported, module, p, 0))
                .filter(|t| t != module)
                .collect();
            (module.clone(), targets)
        })
        .collect()
}

/// The circles between the children of `parent` (a child's files counted as one).
fn sibling_circles(
    parent: &[String],
    edges: &BTreeMap<Module, BTreeSet<Module>>,
) -> Vec<Vec<String>> {
    let n = parent.len();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (from, targets) in edges {
        if from.len() <= n || from[..n] != *parent {
            continue;
        }
        let child = from[n].clone();
        let entry = graph.entry(child.clone()).or_default();
        for to in targets {
            if to.len() > n && to[..n] == *parent && to[n] != child {
                entry.insert(to[n].clone());
            }
        }
    }
    // A child is in a circle when it reaches itself.
    let reach = |from: &String| {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<&String> = graph[from].iter().collect();
        while let Some(next) = todo.pop() {
            if seen.insert(next.clone()) {
                todo.extend(graph.get(next).into_iter().flatten());
            }
        }
        seen
    };
    let mut circles: Vec<Vec<String>> = Vec::new();
    for child in graph.keys() {
        let from_child = reach(child);
        if from_child.contains(child) && !circles.iter().any(|c| c.contains(child)) {
            let circle = graph
                .keys()
                .filter(|other| from_child.contains(*other) && reach(other).contains(child))
                .cloned()
                .collect();
            circles.push(circle);
        }
    }
    circles
}

#[test]
fn pure_modules_import_nothing_that_does_io_and_no_two_modules_import_each_other() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = modules(&src);
    assert!(files.len() > 100, "the library's files were not found");
    let edges = imports(&files);
    // The rule can fail: the daemon's worker imports its setup.
    assert!(
        edges[&vec!["daemon".to_owned(), "worker".to_owned()]]
            .contains(&vec!["daemon".to_owned(), "setup".to_owned()])
    );

    let mut wrong = Vec::new();
    for (from, targets) in &edges {
        if !from.first().is_some_and(|top| PURE.contains(&top.as_str())) {
            continue;
        }
        for to in targets {
            if to.first().is_some_and(|t| IO.contains(&t.as_str())) {
                wrong.push(format!("{} imports {}", from.join("::"), to.join("::")));
            }
        }
    }
    let parents: BTreeSet<Module> = files
        .keys()
        .filter(|m| !m.is_empty())
        .map(|m| m[..m.len() - 1].to_vec())
        .collect();
    let mut known: Vec<(String, Vec<String>)> = KNOWN_CIRCLES
        .iter()
        .map(|(within, circle)| {
            let circle = circle.iter().map(|m| (*m).to_owned()).collect();
            ((*within).to_owned(), circle)
        })
        .collect();
    for parent in &parents {
        for circle in sibling_circles(parent, &edges) {
            let within = if parent.is_empty() {
                "crate".to_owned()
            } else {
                parent.join("::")
            };
            let found = (within, circle);
            if let Some(at) = known.iter().position(|k| *k == found) {
                known.remove(at);
            } else {
                wrong.push(format!(
                    "a circle in {}: {}",
                    found.0,
                    found.1.join(" <-> ")
                ));
            }
        }
    }
    for (within, circle) in known {
        wrong.push(format!(
            "the circle in {within} ({}) is gone: strike it off KNOWN_CIRCLES",
            circle.join(" <-> ")
        ));
    }
    assert!(
        wrong.is_empty(),
        "the layering rule is broken:\n{}",
        wrong.join("\n")
    );
}

/// The modules under `folder` (the folder's own files and every one below).
fn under<'a>(
    edges: &'a BTreeMap<Module, BTreeSet<Module>>,
    folder: &'a [String],
) -> impl Iterator<Item = (&'a Module, &'a BTreeSet<Module>)> {
    edges.iter().filter(move |(m, _)| m.starts_with(folder))
}

/// Inside daemon/, a module in a folder (`daemon/cycle/run.rs`, in `daemon/cycle`) may use a
/// sibling of that folder, or of any folder above it up to daemon/ (`daemon/handle`), only when
/// that sibling imports nothing of the folder back: what a folder adds onto a sibling's type
/// (`impl RobotHandle` in `daemon/cycle`) is the folder's, and the sibling never reaches into it.
#[test]
fn inside_the_daemon_no_module_imports_its_parents_siblings_back() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let edges = imports(&modules(&src));
    let daemon = |path: &str| -> Module { path.split("::").map(str::to_owned).collect() };
    // The rule is exercised: the cycle's driver uses the handle, which imports nothing of it.
    assert!(edges[&daemon("daemon::cycle::run")].contains(&daemon("daemon::handle")));

    let mut wrong = Vec::new();
    for (from, targets) in &edges {
        if from.first().map(String::as_str) != Some("daemon") {
            continue;
        }
        // Each folder `from` is in, below daemon/ (daemon/cycle, daemon/worker/dispatch, ...).
        for depth in 2..from.len() {
            let folder = &from[..depth];
            let parent = &folder[..depth - 1];
            for to in targets {
                if to.len() < depth || !to.starts_with(parent) || to.starts_with(folder) {
                    continue;
                }
                let sibling = &to[..depth];
                let back: Vec<String> = under(&edges, sibling)
                    .filter_map(|(m, ts)| {
                        let hit = ts.iter().find(|t| t.starts_with(folder))?;
                        Some(format!("{} imports {}", m.join("::"), hit.join("::")))
                    })
                    .collect();
                if !back.is_empty() {
                    wrong.push(format!(
                        "{} imports {}, its parent's sibling, which imports it back ({})",
                        from.join("::"),
                        to.join("::"),
                        back.join("; ")
                    ));
                }
            }
        }
    }
    wrong.sort();
    wrong.dedup();
    assert!(
        wrong.is_empty(),
        "inside daemon/, modules import their parents' siblings back:\n{}",
        wrong.join("\n")
    );
}
