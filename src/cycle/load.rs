//! Reading a robot's cycle programs: every `*.toml` in its programs directory (at most
//! [`MAX_PROGRAMS`], each a regular file of at most 1 MiB, as path files are), named by its file
//! name without `.toml`, with each `path = { file = ... }` read (relative to the directory) and
//! put in as the path's document. Nothing is checked here but the files: [`super::check`] does.

use std::collections::BTreeMap;
use std::path::Path;

use crate::cli::path_file;
use crate::config::PathDoc;

use super::program::ProgramDoc;

/// The most programs a directory may hold.
pub const MAX_PROGRAMS: usize = 255;

/// Every program in `dir`, by name.
///
/// # Errors
/// The file at fault and why: unreadable, not TOML, an unknown key, a path file that cannot be
/// read or is not a path document.
pub fn programs(dir: &Path) -> Result<BTreeMap<String, ProgramDoc>, String> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| format!("reading the programs directory {}: {e}", dir.display()))?;
    let mut out = BTreeMap::new();
    for entry in entries {
        let path = entry
            .map_err(|e| format!("reading the programs directory {}: {e}", dir.display()))?
            .path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let Some(name) = path.file_stem().and_then(|s| s.to_str()).map(str::to_owned) else {
            continue;
        };
        if out.len() == MAX_PROGRAMS {
            return Err(format!(
                "{} holds more than {MAX_PROGRAMS} programs",
                dir.display()
            ));
        }
        let text = path_file::read(&path).map_err(|e| format!("{e:#}"))?;
        let mut doc = ProgramDoc::from_toml(&text)
            .map_err(|e| format!("program {name:?} ({}): {e}", path.display()))?;
        read_path_files(&mut doc, dir).map_err(|e| format!("program {name:?}: {e}"))?;
        out.insert(name, doc);
    }
    Ok(out)
}

/// Puts each path step's file in as its document.
fn read_path_files(doc: &mut ProgramDoc, dir: &Path) -> Result<(), String> {
    for (i, step) in doc.step.iter_mut().enumerate() {
        let Some(path) = &mut step.path else { continue };
        let Some(file) = path.file.take() else {
            continue;
        };
        if path.path.is_some() {
            return Err(format!(
                "step {}: a path step has `file` or `path`, not both",
                i + 1
            ));
        }
        let at = dir.join(&file);
        let text = path_file::read(&at).map_err(|e| format!("step {}: {e:#}", i + 1))?;
        PathDoc::from_toml(&text).map_err(|e| format!("step {}: {file}: {e}", i + 1))?;
        let value: serde_json::Value =
            toml::from_str(&text).map_err(|e| format!("step {}: {file}: {e}", i + 1))?;
        path.path = Some(value);
    }
    Ok(())
}
