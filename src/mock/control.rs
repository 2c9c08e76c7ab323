//! The mock's control socket (`linterpd mock-plc --control PATH`): an operator's hand on the
//! simulated cell, never a PLC's protocol. One request a line, one reply a line:
//!
//! ```text
//!  force press_open off     -> ok X5 forced off
//!  force X7 on              -> ok X7 forced on
//!  release press_open       -> ok X5 released
//!  release all              -> ok released X5, X7
//!  status                   -> ok press[0] open, 3 strokes; stack[0] 997 of 1000 parts
//!  anything else            -> error ...
//! ```
//! [`execute`] is the pure part (a line and the cell in, the reply out); [`serve`] the Unix
//! socket around it. `linterpd io force|release|cell --mock PATH` is its client.

use std::path::Path;

use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};
use tokio::net::{UnixListener, UnixStream};

use super::SharedMock;
use super::cell::Cell;

/// The longest request line taken, bytes.
const MAX_LINE: usize = 256;

/// Carries out one request line on `cell`: the reply, `ok ...` or `error ...`.
#[must_use]
pub fn execute(cell: &mut Cell, line: &str) -> String {
    let words: Vec<&str> = line.split_whitespace().collect();
    let reply = match words.as_slice() {
        ["force", target, value] => match on_off(value) {
            Some(on) => cell
                .force(target, on)
                .map(|a| format!("{a} forced {value}"))
                .map_err(|e| e.to_string()),
            None => Err(format!("{value:?} is not on or off")),
        },
        ["release", "all"] => {
            let released: Vec<String> =
                cell.release_all().iter().map(ToString::to_string).collect();
            Ok(if released.is_empty() {
                "nothing was forced".to_owned()
            } else {
                format!("released {}", released.join(", "))
            })
        }
        ["release", target] => cell
            .release(target)
            .map(|a| format!("{a} released"))
            .map_err(|e| e.to_string()),
        ["status"] => Ok(cell.describe()),
        _ => Err(format!(
            "{:?}: the requests are `force NAME on|off`, `release NAME|all` and `status`",
            line.trim()
        )),
    };
    match reply {
        Ok(text) => format!("ok {text}"),
        Err(text) => format!("error {text}"),
    }
}

fn on_off(value: &str) -> Option<bool> {
    match value {
        "on" | "1" | "true" => Some(true),
        "off" | "0" | "false" => Some(false),
        _ => None,
    }
}

/// Binds the control socket at `path` (its directory made when missing), replacing a socket
/// file left behind (no other file).
pub fn bind(path: &Path) -> std::io::Result<UnixListener> {
    use std::os::unix::fs::FileTypeExt;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_socket()) {
        std::fs::remove_file(path)?;
    }
    UnixListener::bind(path)
}

/// Serves the control socket for ever, each connection on its own task.
pub async fn serve(listener: UnixListener, shared: SharedMock) {
    loop {
        let Ok((stream, _)) = listener.accept().await else {
            continue;
        };
        tokio::spawn(connection(stream, shared.clone()));
    }
}

async fn connection(stream: UnixStream, shared: SharedMock) {
    let (read, mut write) = stream.into_split();
    let mut lines = BufReader::new(read.take(64 * 1024)).lines();
    while let Ok(Some(line)) = lines.next_line().await {
        let reply = if line.len() > MAX_LINE {
            format!("error a request is at most {MAX_LINE} bytes")
        } else {
            let reply = shared.with(|m| execute(m.cell_mut(), &line));
            tracing::info!(request = %line.trim(), %reply, "control");
            reply
        };
        if write
            .write_all(format!("{reply}\n").as_bytes())
            .await
            .is_err()
        {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mock::cell::Description;

    fn press() -> Cell {
        let text = include_str!("../../config/examples/cells/press.toml");
        Cell::new(Description::from_toml(text).unwrap())
    }

    #[test]
    fn requests_force_release_and_describe_the_cell() {
        let mut cell = press();
        assert_eq!(
            execute(&mut cell, "force press_open off"),
            "ok X5 forced off"
        );
        assert_eq!(execute(&mut cell, "force X7 on\n"), "ok X7 forced on");
        assert!(execute(&mut cell, "status").ends_with("forced: X5 off, X7 on"));
        assert_eq!(execute(&mut cell, "release press_open"), "ok X5 released");
        assert_eq!(execute(&mut cell, "release all"), "ok released X7");
        assert_eq!(execute(&mut cell, "release all"), "ok nothing was forced");
    }

    #[test]
    fn bad_requests_say_what_is_taken() {
        let mut cell = press();
        assert_eq!(
            execute(&mut cell, "force X5 maybe"),
            "error \"maybe\" is not on or off"
        );
        assert!(
            execute(&mut cell, "force press_go on")
                .starts_with("error \"press_go\": Y0 is an output")
        );
        assert!(execute(&mut cell, "jump").starts_with("error \"jump\": the requests are"));
    }

    #[tokio::test]
    async fn the_socket_answers_a_line_per_request() {
        let dir = std::env::temp_dir().join(format!("linterpd-control-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("control.sock");
        let mut mock = crate::mock::MockPlc::new(crate::mock::MockConfig::default()).unwrap();
        mock.set_cell(press());
        let shared = SharedMock::new(mock);
        let server = tokio::spawn(serve(bind(&path).unwrap(), shared.clone()));
        let stream = UnixStream::connect(&path).await.unwrap();
        let (read, mut write) = stream.into_split();
        write
            .write_all(b"force part_present off\nstatus\n")
            .await
            .unwrap();
        let mut lines = BufReader::new(read).lines();
        assert_eq!(
            lines.next_line().await.unwrap().unwrap(),
            "ok X2 forced off"
        );
        let status = lines.next_line().await.unwrap().unwrap();
        assert!(status.ends_with("forced: X2 off"), "{status}");
        assert_eq!(shared.with(|m| m.cell().forced().len()), 1);
        server.abort();
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
