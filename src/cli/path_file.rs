//! Reading a path file for `linterpd run FILE` and `linterpd plan --path FILE`: only a regular
//! file of at most [`MAX_PATH_FILE_BYTES`] is read, so `/dev/zero`, a FIFO or a runaway log
//! given by mistake is refused at once, naming the file and the limit, instead of read forever.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use anyhow::{Context, bail};

/// The largest path file read, bytes (1 MiB: a path of thousands of elements is a few hundred
/// kB).
pub const MAX_PATH_FILE_BYTES: u64 = 1 << 20;

/// The text of the path file at `file`, if it is a regular file of at most
/// [`MAX_PATH_FILE_BYTES`]; else an error naming the file and the limit.
pub fn read(file: &Path) -> anyhow::Result<String> {
    let shown = file.display();
    let meta = std::fs::metadata(file).with_context(|| format!("reading {shown}"))?;
    if !meta.is_file() {
        bail!(
            "{shown} is not a regular file ({}); a path file must be a regular file of at most \
             {MAX_PATH_FILE_BYTES} bytes (1 MiB)",
            kind(meta.file_type())
        );
    }
    too_long(file, meta.len())?;
    let mut text = String::new();
    File::open(file)
        .and_then(|f| f.take(MAX_PATH_FILE_BYTES + 1).read_to_string(&mut text))
        .with_context(|| format!("reading {shown}"))?;
    // The file may have grown since it was measured.
    too_long(file, text.len() as u64)?;
    Ok(text)
}

fn too_long(file: &Path, bytes: u64) -> anyhow::Result<()> {
    if bytes > MAX_PATH_FILE_BYTES {
        bail!(
            "{} is {bytes} bytes; a path file is at most {MAX_PATH_FILE_BYTES} bytes (1 MiB)",
            file.display()
        );
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

    fn temp(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("linterpd-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn dev_zero_is_refused_before_it_is_read_naming_the_file_and_the_limit() {
        let e = read(Path::new("/dev/zero")).unwrap_err().to_string();
        assert_eq!(
            e,
            "/dev/zero is not a regular file (a character device); a path file must be a \
             regular file of at most 1048576 bytes (1 MiB)"
        );
    }

    #[test]
    fn a_directory_is_not_a_path_file() {
        let dir = temp("path-file-dir");
        let e = read(&dir).unwrap_err().to_string();
        assert!(e.contains("is not a regular file (a directory)"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_file_over_1_mib_is_refused_and_one_at_the_limit_is_read() {
        let dir = temp("path-file-size");
        let big = dir.join("big.toml");
        std::fs::write(&big, vec![b'#'; MAX_PATH_FILE_BYTES as usize + 1]).unwrap();
        let e = read(&big).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{} is 1048577 bytes; a path file is at most 1048576 bytes (1 MiB)",
                big.display()
            )
        );
        let fits = dir.join("fits.toml");
        std::fs::write(&fits, vec![b'#'; MAX_PATH_FILE_BYTES as usize]).unwrap();
        assert_eq!(read(&fits).unwrap().len(), MAX_PATH_FILE_BYTES as usize);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_missing_file_names_it() {
        let e = format!(
            "{:#}",
            read(Path::new("/nonexistent/cycle.toml")).unwrap_err()
        );
        assert!(e.starts_with("reading /nonexistent/cycle.toml: "), "{e}");
    }
}
