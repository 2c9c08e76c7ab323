//! The API's Unix socket: one daemon per socket, held by a lock file beside it (`api.sock.lock`),
//! so a second `linterpd serve` refuses to start instead of deleting the live daemon's socket.
//! Only the holder of the lock replaces a socket file left behind by a daemon that died. The
//! socket's directory is made when missing (mode 0750, as the unit's `RuntimeDirectory=` does),
//! so a daemon started by hand needs no root to prepare it.

use std::fs::{File, OpenOptions, TryLockError};
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::{Path, PathBuf};

use tokio::net::UnixListener;

use super::ServeError;

/// The lock file of the socket at `socket`.
#[must_use]
pub fn lock_path(socket: &Path) -> PathBuf {
    let mut name = socket.as_os_str().to_owned();
    name.push(".lock");
    PathBuf::from(name)
}

/// The socket directory's mode when the daemon makes it (the unit's `RuntimeDirectoryMode=`).
const SOCKET_DIR_MODE: u32 = 0o750;

/// Makes the socket's directory (and its parents) when missing; refuses naming `[daemon] socket`
/// and what to do when it cannot.
pub(super) fn ensure_socket_dir(socket: &Path) -> Result<(), ServeError> {
    use std::os::unix::fs::DirBuilderExt;
    let Some(dir) = socket.parent().filter(|d| !d.as_os_str().is_empty()) else {
        return Ok(());
    };
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(SOCKET_DIR_MODE)
        .create(dir)
        .map_err(|source| ServeError::SocketDir {
            dir: dir.to_owned(),
            socket: socket.to_owned(),
            source,
        })
}

/// Takes the socket's lock for as long as the returned file lives, making the socket's
/// directory first when it is missing; refuses when another daemon holds it.
pub fn lock(socket: &Path) -> Result<File, ServeError> {
    ensure_socket_dir(socket)?;
    let path = lock_path(socket);
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(|source| ServeError::Socket {
            operation: "open the lock file",
            target: path.clone(),
            source,
        })?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(TryLockError::WouldBlock) => Err(ServeError::AlreadyRunning {
            socket: socket.to_owned(),
            lock: path,
        }),
        Err(TryLockError::Error(source)) => Err(ServeError::Socket {
            operation: "lock",
            target: path,
            source,
        }),
    }
}

/// Binds the API's Unix socket at `path` with permissions `mode`, replacing a socket file left
/// behind (but no other kind of file). Call it holding the socket's [`lock`].
pub fn bind_unix(path: &Path, mode: u32) -> Result<UnixListener, ServeError> {
    let fail = |operation| {
        move |source| ServeError::Socket {
            operation,
            target: path.to_owned(),
            source,
        }
    };
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_socket()) {
        std::fs::remove_file(path).map_err(fail("remove the stale socket"))?;
    }
    let listener = UnixListener::bind(path).map_err(fail("bind"))?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode))
        .map_err(fail("set the mode of"))?;
    Ok(listener)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::fresh_dir;

    #[test]
    fn a_second_daemon_on_the_same_socket_is_refused_and_the_first_keeps_its_socket() {
        let dir = fresh_dir("lock");
        let socket = dir.join("api.sock");
        let first = lock(&socket).unwrap();
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let _listener = rt.block_on(async { bind_unix(&socket, 0o600).unwrap() });
        let e = lock(&socket).unwrap_err();
        assert!(matches!(e, ServeError::AlreadyRunning { .. }), "{e}");
        assert!(e.to_string().contains("already serves"), "{e}");
        assert!(socket.exists(), "the live socket is still there");
        drop(first);
        assert!(lock(&socket).is_ok(), "free once the first daemon is gone");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_missing_socket_directory_is_made_and_one_that_cannot_be_is_named_with_the_key() {
        use std::os::unix::fs::PermissionsExt;
        let dir = fresh_dir("sockdir");
        let socket = dir.join("run/linterpd/api.sock");
        let held = lock(&socket).unwrap();
        let mode = std::fs::metadata(socket.parent().unwrap())
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & !SOCKET_DIR_MODE & 0o777, 0, "{mode:o}");
        drop(held);
        std::fs::write(dir.join("file"), "").unwrap();
        let e = lock(&dir.join("file/api.sock")).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!(
                "cannot create the socket's directory {}/file ([daemon] socket = \"{}/file/api.sock\")",
                dir.display(),
                dir.display()
            )) && e.contains("set [daemon] socket to a path in a directory you may write"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_stale_socket_is_replaced_and_gets_its_mode() {
        let dir = fresh_dir("sock");
        let path = dir.join("api.sock");
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        rt.block_on(async {
            drop(bind_unix(&path, 0o600).unwrap());
            let _again = bind_unix(&path, 0o640).unwrap();
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o640);
        });
        std::fs::write(dir.join("plain"), "x").unwrap();
        let e = rt.block_on(async { bind_unix(&dir.join("plain"), 0o600).unwrap_err() });
        assert!(e.to_string().starts_with("cannot bind"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
