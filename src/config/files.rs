//! Reading the files a config points at (path files, cycle programs): only a regular file of at
//! most [`MAX_FILE_BYTES`] is read, so `/dev/zero`, a FIFO or a runaway log given by mistake is
//! refused at once, naming the file and the limit, instead of read forever; and a file a program
//! names is looked up inside its directory only ([`read_inside`]): an absolute name, `..` or a
//! symbolic link that leads out of it is refused, naming the file.

use std::fs::File;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

use thiserror::Error;

/// The largest file read, bytes (1 MiB: a path of thousands of elements is a few hundred kB).
pub const MAX_FILE_BYTES: u64 = 1 << 20;

/// Why a file was not read.
#[derive(Debug, Error)]
pub enum FileError {
    /// It could not be read (missing, no permission, ...).
    #[error("reading {file}: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// It is not a regular file.
    #[error(
        "{file} is not a regular file ({kind}); a file here must be a regular file of at most \
         {MAX_FILE_BYTES} bytes (1 MiB)"
    )]
    NotRegular {
        /// The file.
        file: PathBuf,
        /// What it is.
        kind: &'static str,
    },
    /// It is too long.
    #[error("{file} is {bytes} bytes; a file here is at most {MAX_FILE_BYTES} bytes (1 MiB)")]
    TooLong {
        /// The file.
        file: PathBuf,
        /// Its length.
        bytes: u64,
    },
    /// A name that leads out of the directory it must be in.
    #[error("file = {name:?} {how}: a file is named relative to {dir} and stays inside it")]
    OutsideDirectory {
        /// The name as given.
        name: String,
        /// The directory.
        dir: PathBuf,
        /// How it leaves (an absolute name, `..`, a link that points out).
        how: &'static str,
    },
}

/// The text of the file at `file`, if it is a regular file of at most [`MAX_FILE_BYTES`].
///
/// # Errors
/// The file and why: unreadable, not a regular file, too long.
pub fn read_regular(file: &Path) -> Result<String, FileError> {
    let io = |source| FileError::Io {
        file: file.to_owned(),
        source,
    };
    let meta = std::fs::metadata(file).map_err(io)?;
    if !meta.is_file() {
        return Err(FileError::NotRegular {
            file: file.to_owned(),
            kind: kind(meta.file_type()),
        });
    }
    too_long(file, meta.len())?;
    let mut text = String::new();
    File::open(file)
        .and_then(|f| f.take(MAX_FILE_BYTES + 1).read_to_string(&mut text))
        .map_err(io)?;
    // The file may have grown since it was measured.
    too_long(file, text.len() as u64)?;
    Ok(text)
}

/// Where `name` (as a program gives it) lies inside `dir`: relative, with no `..`, and, links
/// followed, still inside `dir`.
///
/// # Errors
/// [`FileError::OutsideDirectory`] naming it, or why it cannot be found.
pub fn inside(dir: &Path, name: &str) -> Result<PathBuf, FileError> {
    let outside = |how| FileError::OutsideDirectory {
        name: name.to_owned(),
        dir: dir.to_owned(),
        how,
    };
    let given = Path::new(name);
    if given.is_absolute() || given.has_root() {
        return Err(outside("is an absolute name"));
    }
    if given
        .components()
        .any(|c| !matches!(c, Component::Normal(_) | Component::CurDir))
    {
        return Err(outside("goes up with .."));
    }
    let io = |file: &Path| {
        let file = file.to_owned();
        move |source| FileError::Io { file, source }
    };
    let joined = dir.join(given);
    let home = dir.canonicalize().map_err(io(dir))?;
    let real = joined.canonicalize().map_err(io(&joined))?;
    if !real.starts_with(&home) {
        return Err(outside("is a link that leads out of the directory"));
    }
    Ok(real)
}

/// [`read_regular`] of [`inside`]`(dir, name)`.
///
/// # Errors
/// As either.
pub fn read_inside(dir: &Path, name: &str) -> Result<String, FileError> {
    read_regular(&inside(dir, name)?)
}

fn too_long(file: &Path, bytes: u64) -> Result<(), FileError> {
    if bytes > MAX_FILE_BYTES {
        return Err(FileError::TooLong {
            file: file.to_owned(),
            bytes,
        });
    }
    Ok(())
}

/// What a file that is not a regular file is, in words.
fn kind(t: std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_dir() {
        "a directory"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_fifo() {
        "a FIFO"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::fresh_dir;

    #[test]
    fn dev_zero_is_refused_before_it_is_read_naming_the_file_and_the_limit() {
        let e = read_regular(Path::new("/dev/zero"))
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "/dev/zero is not a regular file (a character device); a file here must be a \
             regular file of at most 1048576 bytes (1 MiB)"
        );
    }

    #[test]
    fn a_directory_is_not_a_file() {
        let dir = fresh_dir("files-dir");
        let e = read_regular(&dir).unwrap_err().to_string();
        assert!(e.contains("is not a regular file (a directory)"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_over_1_mib_is_refused_and_one_at_the_limit_is_read() {
        let dir = fresh_dir("files-size");
        let big = dir.join("big.toml");
        std::fs::write(&big, vec![b'#'; MAX_FILE_BYTES as usize + 1]).unwrap();
        let e = read_regular(&big).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{} is 1048577 bytes; a file here is at most 1048576 bytes (1 MiB)",
                big.display()
            )
        );
        let fits = dir.join("fits.toml");
        std::fs::write(&fits, vec![b'#'; MAX_FILE_BYTES as usize]).unwrap();
        assert_eq!(read_regular(&fits).unwrap().len(), MAX_FILE_BYTES as usize);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_missing_file_names_it() {
        let e = read_regular(Path::new("/nonexistent/cycle.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("reading /nonexistent/cycle.toml: "), "{e}");
    }

    /// Issue 44: `file = "../../x.toml"` ran a path from outside the programs directory, and
    /// `file = "/etc/passwd"` was opened.
    #[test]
    fn a_file_outside_its_directory_is_refused_naming_it() {
        let dir = fresh_dir("files-inside");
        let programs = dir.join("programs");
        std::fs::create_dir_all(programs.join("paths")).unwrap();
        std::fs::write(dir.join("x.toml"), "outside").unwrap();
        std::fs::write(programs.join("paths/in.toml"), "inside").unwrap();
        assert_eq!(read_inside(&programs, "paths/in.toml").unwrap(), "inside");
        assert_eq!(read_inside(&programs, "./paths/in.toml").unwrap(), "inside");
        let refused = |name: &str| read_inside(&programs, name).unwrap_err().to_string();
        let e = refused("../x.toml");
        assert!(
            e.starts_with("file = \"../x.toml\" goes up with ..: a file is named relative to"),
            "{e}"
        );
        let e = refused("/etc/passwd");
        assert!(
            e.starts_with("file = \"/etc/passwd\" is an absolute name"),
            "{e}"
        );
        // Links: one that stays inside is followed; one that leads out is refused, whatever
        // it points at.
        std::os::unix::fs::symlink(programs.join("paths/in.toml"), programs.join("ok.toml"))
            .unwrap();
        assert_eq!(read_inside(&programs, "ok.toml").unwrap(), "inside");
        std::os::unix::fs::symlink(dir.join("x.toml"), programs.join("out.toml")).unwrap();
        assert!(refused("out.toml").contains("is a link that leads out"));
        std::os::unix::fs::symlink("/dev/zero", programs.join("zero.toml")).unwrap();
        assert!(refused("zero.toml").contains("is a link that leads out"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
