//! The API's Unix socket: one daemon per socket, held by a lock file beside it (`api.sock.lock`),
//! so a second `linterpd serve` refuses to start instead of deleting the live daemon's socket.
//! Only the holder of the lock replaces a socket file left behind by a daemon that died.

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

/// Takes the socket's lock for as long as the returned file lives; refuses when another daemon
/// holds it.
pub fn lock(socket: &Path) -> Result<File, ServeError> {
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

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("linterpd-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_second_daemon_on_the_same_socket_is_refused_and_the_first_keeps_its_socket() {
        let dir = temp("lock");
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
    fn a_stale_socket_is_replaced_and_gets_its_mode() {
        let dir = temp("sock");
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
