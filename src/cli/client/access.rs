//! Why the daemon's socket could not be reached, in words an operator can act on: nothing
//! listens there ([`NotRunning`]), or this user may not use it ([`NoPermission`], naming the
//! group that may).

use std::io;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// The daemon could not be reached at all.
#[derive(Debug, thiserror::Error)]
#[error(
    "the linterpd daemon is not running (nothing answers at {socket}): start it with \
     `systemctl start linterpd`, or give its socket with --socket or LINTERPD_SOCKET"
)]
pub struct NotRunning {
    /// The socket tried.
    pub socket: PathBuf,
    /// Why connecting failed.
    #[source]
    pub source: io::Error,
}

/// The socket (or its directory) is there but not open to this user.
#[derive(Debug, thiserror::Error)]
#[error(
    "permission denied on the daemon's socket {socket}: it is open to group {group} only; \
     add yourself with `sudo usermod -aG {group} $USER` and log in again (or use sudo)"
)]
pub struct NoPermission {
    /// The socket tried.
    pub socket: PathBuf,
    /// The group that owns the socket, or its directory when the socket cannot be seen.
    pub group: String,
    /// The refusal.
    #[source]
    pub source: io::Error,
}

/// The group the service's sysusers file makes (deploy/linterpd.sysusers), said when the socket
/// and its directory cannot even be looked at.
const SERVICE_GROUP: &str = "linterpd";

/// The error for a failed connection to `socket`.
#[must_use]
pub(super) fn connect_error(socket: &Path, source: io::Error) -> anyhow::Error {
    if source.kind() == io::ErrorKind::PermissionDenied {
        let group = owning_gid(socket).map_or_else(
            || SERVICE_GROUP.to_owned(),
            |gid| {
                let groups = std::fs::read_to_string("/etc/group").unwrap_or_default();
                group_name(gid, &groups)
            },
        );
        return NoPermission {
            socket: socket.to_owned(),
            group,
            source,
        }
        .into();
    }
    NotRunning {
        socket: socket.to_owned(),
        source,
    }
    .into()
}

/// The group id of the socket, or of the nearest directory above it that can be looked at.
fn owning_gid(socket: &Path) -> Option<u32> {
    socket
        .ancestors()
        .take(2)
        .find_map(|p| std::fs::metadata(p).ok())
        .map(|m| m.gid())
}

/// The name of group `gid` in the text of `/etc/group`, else `gid N`.
fn group_name(gid: u32, etc_group: &str) -> String {
    etc_group
        .lines()
        .find_map(|line| {
            let mut fields = line.split(':');
            let name = fields.next()?;
            let id = fields.nth(1)?.parse::<u32>().ok()?;
            (id == gid).then(|| name.to_owned())
        })
        .unwrap_or_else(|| format!("gid {gid}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    const GROUPS: &str = "root:x:0:\ndialout:x:20:\n# a comment\nlinterpd:x:998:ops,anna\n";

    #[test]
    fn group_names_come_from_etc_group_else_the_number() {
        assert_eq!(group_name(998, GROUPS), "linterpd");
        assert_eq!(group_name(20, GROUPS), "dialout");
        assert_eq!(group_name(4242, GROUPS), "gid 4242");
        assert_eq!(group_name(0, "broken line\nroot:x:0:"), "root");
    }

    #[test]
    fn permission_denied_names_the_socket_and_its_group() {
        let dir = std::env::temp_dir();
        let socket = dir.join("linterpd-access-test.sock");
        let e = connect_error(&socket, io::ErrorKind::PermissionDenied.into());
        let text = format!("{e:#}");
        let no = e
            .downcast_ref::<NoPermission>()
            .expect("a permission problem");
        // The socket does not exist: its directory's group is named.
        let dir_gid = std::fs::metadata(&dir).unwrap().gid();
        let groups = std::fs::read_to_string("/etc/group").unwrap_or_default();
        assert_eq!(no.group, group_name(dir_gid, &groups));
        assert!(
            text.contains("permission denied")
                && text.contains(&socket.display().to_string())
                && text.contains(&format!("usermod -aG {}", no.group)),
            "{text}"
        );
    }

    #[test]
    fn anything_else_is_not_running() {
        let e = connect_error(
            Path::new("/nowhere/api.sock"),
            io::ErrorKind::NotFound.into(),
        );
        assert!(e.downcast_ref::<NotRunning>().is_some());
    }
}
