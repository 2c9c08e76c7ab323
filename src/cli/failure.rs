//! [`Failure`]: how a run went wrong, sorted by whose fault it was into the exit codes of the
//! module docs of [`crate::cli`]; and the daemon's error answers mapped onto them.

use std::fmt;

use anyhow::anyhow;
use hyper::{Method, StatusCode};
use serde_json::Value;

/// Exit code for a run that worked.
pub const EXIT_OK: u8 = 0;
/// Exit code for a failure that is not the input's fault (IO, a bug, the PLC refused or failed
/// a command); for `status`, a robot that reports a fault.
pub const EXIT_FAILURE: u8 = 1;
/// Exit code for bad input: config, arguments, an impossible move, a register outside the
/// gateway's access list (400, 403, 404, 422 from the daemon). Nothing was done.
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit code when the robot did not do what was asked: refused for its state (409), a move that
/// ended stopped, failed or cancelled, a `move --timeout` that ran out; for `status`, a robot
/// whose PLC link is down or stalled.
pub const EXIT_NOT_DONE: u8 = 3;
/// Exit code when the daemon cannot be reached (not running, wrong socket, no permission), or it
/// cannot reach the PLC now (503).
pub const EXIT_UNREACHABLE: u8 = 4;
/// Exit code of an attached `move`, `run` or `cycle run --follow` ended by Ctrl-C (SIGINT), once
/// it stopped what it started (128 + SIGINT's number, as a shell reports it).
pub const EXIT_INTERRUPTED: u8 = 130;

/// A failed run: what went wrong and whose fault it was.
#[derive(Debug)]
pub enum Failure {
    /// The input is wrong (exit 2).
    BadInput(anyhow::Error),
    /// Something else failed (exit 1).
    Runtime(anyhow::Error),
    /// The robot did not do it: refused now, ended stopped or failed, timed out (exit 3).
    NotDone(anyhow::Error),
    /// The daemon cannot be reached, or it cannot reach the PLC (exit 4).
    Unreachable(anyhow::Error),
    /// Ctrl-C ended an attached command; what it started was stopped (exit 130).
    Interrupted(anyhow::Error),
    /// Exit with this code; the output already said why (`status`), nothing more is printed.
    Quiet(u8),
}

impl Failure {
    /// The process exit code for this failure.
    #[must_use]
    pub fn exit_code(&self) -> u8 {
        match self {
            Self::BadInput(_) => EXIT_BAD_INPUT,
            Self::Runtime(_) => EXIT_FAILURE,
            Self::NotDone(_) => EXIT_NOT_DONE,
            Self::Unreachable(_) => EXIT_UNREACHABLE,
            Self::Interrupted(_) => EXIT_INTERRUPTED,
            Self::Quiet(code) => *code,
        }
    }

    /// The error, unless there is nothing more to say.
    #[must_use]
    pub fn error(&self) -> Option<&anyhow::Error> {
        match self {
            Self::BadInput(e)
            | Self::Runtime(e)
            | Self::NotDone(e)
            | Self::Unreachable(e)
            | Self::Interrupted(e) => Some(e),
            Self::Quiet(_) => None,
        }
    }

    /// Whether it failed only because stdout is a pipe whose reader has gone
    /// (`linterpd plan ... | head -1`): the reader had what it wanted, so that is a success.
    #[must_use]
    pub fn is_broken_pipe(&self) -> bool {
        self.error().is_some_and(|e| {
            e.chain().any(|cause| {
                let io = cause
                    .downcast_ref::<std::io::Error>()
                    .map(std::io::Error::kind);
                let json = cause
                    .downcast_ref::<serde_json::Error>()
                    .and_then(serde_json::Error::io_error_kind);
                io.or(json) == Some(std::io::ErrorKind::BrokenPipe)
            })
        })
    }

    /// A client error: unreachable if the daemon is not there (or not ours to reach), else a
    /// runtime failure.
    #[must_use]
    pub fn from_client(e: anyhow::Error) -> Self {
        let unreachable = e.downcast_ref::<super::client::NotRunning>().is_some()
            || e.downcast_ref::<super::client::NoPermission>().is_some();
        if unreachable {
            Self::Unreachable(e)
        } else {
            Self::Runtime(e)
        }
    }

    /// A failure for an error answer of the daemon: 409 not done (exit 3), 503 unreachable
    /// (exit 4), any other 4xx bad input (exit 2), anything else a runtime failure.
    #[must_use]
    pub fn from_status(status: StatusCode, e: anyhow::Error) -> Self {
        match status {
            StatusCode::CONFLICT => Self::NotDone(e),
            StatusCode::SERVICE_UNAVAILABLE => Self::Unreachable(e),
            s if s.is_client_error() => Self::BadInput(e),
            _ => Self::Runtime(e),
        }
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.error() {
            Some(e) => write!(f, "{e:#}"),
            None => write!(f, "exit {}", self.exit_code()),
        }
    }
}

/// Bad input from anything that converts into an `anyhow::Error`.
pub fn bad_input(e: impl Into<anyhow::Error>) -> Failure {
    Failure::BadInput(e.into())
}

impl super::client::Client {
    /// Sends a request and returns the body of a success; a failed call or an error answer
    /// becomes the [`Failure`] it calls for ([`Failure::from_status`]; daemon not
    /// there: unreachable; anything else: runtime).
    pub async fn expect(
        &self,
        method: Method,
        path: &str,
        body: Option<&Value>,
    ) -> Result<Value, Failure> {
        let answer = self
            .call(method, path, body)
            .await
            .map_err(Failure::from_client)?;
        if answer.status.is_success() {
            Ok(answer.body)
        } else {
            Err(Failure::from_status(
                answer.status,
                anyhow!("{}", answer.error()),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[test]
    fn refusals_map_to_3_and_an_unreachable_plc_to_4() {
        let code = |s: StatusCode| Failure::from_status(s, anyhow::anyhow!("x")).exit_code();
        assert_eq!(code(StatusCode::CONFLICT), EXIT_NOT_DONE);
        assert_eq!(code(StatusCode::SERVICE_UNAVAILABLE), EXIT_UNREACHABLE);
        for s in [
            StatusCode::BAD_REQUEST,
            StatusCode::FORBIDDEN,
            StatusCode::NOT_FOUND,
            StatusCode::UNPROCESSABLE_ENTITY,
        ] {
            assert_eq!(code(s), EXIT_BAD_INPUT, "{s}");
        }
        assert_eq!(code(StatusCode::BAD_GATEWAY), EXIT_FAILURE);
    }

    #[test]
    fn a_broken_pipe_is_found_under_context_and_inside_serde_json() {
        let pipe = || std::io::Error::from(std::io::ErrorKind::BrokenPipe);
        let wrapped = Err::<(), _>(pipe())
            .context("writing the plan")
            .unwrap_err();
        assert!(Failure::Runtime(wrapped).is_broken_pipe());
        let json = serde_json::to_writer(BrokenPipe, &[1, 2]).unwrap_err();
        assert!(Failure::Runtime(json.into()).is_broken_pipe());
        let other = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        assert!(!Failure::Runtime(other.into()).is_broken_pipe());
        assert!(!Failure::Quiet(3).is_broken_pipe());
    }

    struct BrokenPipe;

    impl std::io::Write for BrokenPipe {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::ErrorKind::BrokenPipe.into())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
}
