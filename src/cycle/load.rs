//! Reading a robot's cycle programs: every `*.toml` in its programs directory (at most
//! [`MAX_PROGRAMS`]), each read as [`crate::config::files`] reads a file inside a directory (a
//! regular file of at most 1 MiB, no link out of the directory), named by its file name without
//! `.toml`, with each `path = { file = ... }` read from inside the directory too and put in as
//! the path's document. Each program is read on its own: one that cannot be read is set aside
//! with the reason ([`Programs::broken`]) and never keeps another from running. Nothing is
//! checked here but the files: [`super::check`] does the rest.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::config::PathDoc;
use crate::config::PathFileError;
use crate::config::files::{FileError, read_inside};

use super::program::ProgramDoc;

/// The most programs a directory may hold.
pub const MAX_PROGRAMS: usize = 255;

/// A robot's programs directory as read.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Programs {
    /// Every program that could be read, by name.
    pub docs: BTreeMap<String, ProgramDoc>,
    /// Every program that could not, by name, with why (its file named).
    pub broken: BTreeMap<String, String>,
}

/// Why a programs directory could not be read at all.
#[derive(Debug, Error)]
pub enum LoadError {
    /// The directory itself.
    #[error("reading the programs directory {dir}: {source}")]
    Directory {
        /// It.
        dir: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// More programs than a robot may have.
    #[error("{dir} holds more than {MAX_PROGRAMS} programs")]
    TooMany {
        /// It.
        dir: PathBuf,
    },
}

/// Why one program file cannot be read: the file, and in it the step whose path file cannot.
#[derive(Debug, Error)]
pub enum ProgramFileError {
    /// The program file itself (it names the file).
    #[error(transparent)]
    File(#[from] FileError),
    /// Its TOML.
    #[error("{file}: {source}")]
    Toml {
        /// The program file.
        file: String,
        /// Where and why.
        #[source]
        source: toml::de::Error,
    },
    /// A path step with a file and a document.
    #[error("{file}: step {step}: a path step has `file` or `path`, not both")]
    BothPaths {
        /// The program file.
        file: String,
        /// The step, from 1.
        step: usize,
    },
    /// A path step's file (it names the file).
    #[error("{file}: step {step}: {source}")]
    PathFile {
        /// The program file.
        file: String,
        /// The step, from 1.
        step: usize,
        /// Why.
        #[source]
        source: FileError,
    },
    /// A path step's file is not a path document.
    #[error("{file}: step {step}: {path}: {source}")]
    PathDoc {
        /// The program file.
        file: String,
        /// The step, from 1.
        step: usize,
        /// The path file.
        path: String,
        /// Why.
        #[source]
        source: PathFileError,
    },
}

/// Every program in `dir`, by name, each read on its own.
///
/// # Errors
/// Only when the directory cannot be listed, or holds too many programs.
pub fn programs(dir: &Path) -> Result<Programs, LoadError> {
    let listing = |source| LoadError::Directory {
        dir: dir.to_owned(),
        source,
    };
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(listing)? {
        let file = entry.map_err(listing)?.file_name();
        let Some(file) = file.to_str() else { continue };
        if let Some(name) = file.strip_suffix(".toml")
            && !name.is_empty()
        {
            names.push((name.to_owned(), file.to_owned()));
        }
    }
    if names.len() > MAX_PROGRAMS {
        return Err(LoadError::TooMany {
            dir: dir.to_owned(),
        });
    }
    names.sort();
    let mut out = Programs::default();
    for (name, file) in names {
        match program(dir, &file) {
            Ok(doc) => {
                out.docs.insert(name, doc);
            }
            Err(why) => {
                out.broken.insert(name, why.to_string());
            }
        }
    }
    Ok(out)
}

/// Program file `file` of `dir`, its path files read in.
fn program(dir: &Path, file: &str) -> Result<ProgramDoc, ProgramFileError> {
    let text = read_inside(dir, file)?;
    let mut doc = ProgramDoc::from_toml(&text).map_err(|source| ProgramFileError::Toml {
        file: file.to_owned(),
        source,
    })?;
    read_path_files(&mut doc, dir, file)?;
    Ok(doc)
}

/// Puts each path step's file in as its document.
fn read_path_files(
    doc: &mut ProgramDoc,
    dir: &Path,
    program: &str,
) -> Result<(), ProgramFileError> {
    for (i, step) in doc.step.iter_mut().enumerate() {
        let Some(path) = &mut step.path else { continue };
        let Some(name) = path.file.take() else {
            continue;
        };
        let (file, at) = (program.to_owned(), i + 1);
        if path.path.is_some() {
            return Err(ProgramFileError::BothPaths { file, step: at });
        }
        let text = match read_inside(dir, &name) {
            Ok(text) => text,
            Err(source) => {
                return Err(ProgramFileError::PathFile {
                    file,
                    step: at,
                    source,
                });
            }
        };
        let value = PathDoc::from_toml(&text)
            .and_then(|_| {
                toml::from_str::<serde_json::Value>(&text)
                    .map_err(|e| PathFileError::Syntax(e.to_string()))
            })
            .map_err(|source| ProgramFileError::PathDoc {
                file,
                step: at,
                path: name,
                source,
            })?;
        path.path = Some(value);
    }
    Ok(())
}

impl Programs {
    /// The name of the program numbered `number`: `Err` with every program that has it when
    /// none or several do.
    ///
    /// # Errors
    /// The names of the programs with that number (empty: none).
    pub fn numbered(&self, number: u8) -> Result<&str, Vec<&str>> {
        let with: Vec<&str> = self
            .docs
            .iter()
            .filter(|(_, d)| d.number == Some(i64::from(number)))
            .map(|(n, _)| n.as_str())
            .collect();
        match with.as_slice() {
            [one] => Ok(one),
            _ => Err(with),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        crate::testing::fresh_dir(&format!("load-{name}"))
    }

    /// Issue 44: one bad file made every good program of the directory refuse, naming it.
    #[test]
    fn a_bad_neighbour_is_set_aside_and_the_good_programs_are_read() {
        let dir = temp("neighbours");
        std::fs::write(dir.join("good.toml"), "[[step]]\ndwell = \"1s\"\n").unwrap();
        std::fs::write(dir.join("garbled.toml"), "[[step]\n").unwrap();
        std::fs::write(dir.join("typo.toml"), "[[step]]\ndwel = \"1s\"\n").unwrap();
        std::os::unix::fs::symlink("/dev/zero", dir.join("zero.toml")).unwrap();
        std::fs::write(
            dir.join("escape.toml"),
            "[[step]]\npath = { file = \"../../x.toml\" }\n",
        )
        .unwrap();
        let p = programs(&dir).unwrap();
        assert_eq!(p.docs.keys().collect::<Vec<_>>(), ["good"]);
        assert_eq!(
            p.broken.keys().collect::<Vec<_>>(),
            ["escape", "garbled", "typo", "zero"]
        );
        assert!(
            p.broken["typo"].starts_with("typo.toml: "),
            "{}",
            p.broken["typo"]
        );
        assert!(p.broken["typo"].contains("dwel"), "{}", p.broken["typo"]);
        assert!(
            p.broken["zero"].contains("leads out"),
            "{}",
            p.broken["zero"]
        );
        assert!(
            p.broken["escape"].contains("step 1: file = \"../../x.toml\" goes up with .."),
            "{}",
            p.broken["escape"]
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_number_names_its_program_or_every_program_that_shares_it() {
        let dir = temp("numbers");
        for (name, n) in [("a", 1), ("b", 2), ("c", 2)] {
            std::fs::write(
                dir.join(format!("{name}.toml")),
                format!("number = {n}\n[[step]]\ndwell = \"1s\"\n"),
            )
            .unwrap();
        }
        let p = programs(&dir).unwrap();
        assert_eq!(p.numbered(1), Ok("a"));
        assert_eq!(p.numbered(2), Err(vec!["b", "c"]));
        assert_eq!(p.numbered(3), Err(vec![]));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
