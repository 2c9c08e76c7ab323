//! [`ApiError`]: every way a request fails, each with its HTTP status and a JSON body
//! `{"error": "...", "field": "..."}` (`field` only where one field is to blame).

use axum::Json;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::contract::machine::Blocker;
use crate::daemon::{CommandError, GatewayError, PositionError, SubmitError};

/// Why a request failed.
#[derive(Debug, Error)]
pub enum ApiError {
    /// A robot, move or path that does not exist (404).
    #[error("{message}")]
    NotFound {
        /// What was not found and what there is.
        message: String,
        /// The path parameter to blame (`robot`, `id`), if any.
        field: Option<&'static str>,
    },
    /// A body that is not JSON, not a move order, or an order with a bad field (400).
    #[error("{message}")]
    BadRequest {
        /// What is wrong.
        message: String,
        /// The field to blame, when one is.
        field: Option<String>,
    },
    /// A register the robot's gateway access list does not let through (403).
    #[error("{0}")]
    Forbidden(String),
    /// An order that cannot be planned from where the robot is or will be (422).
    #[error("{0}")]
    Unplannable(String),
    /// The robot's state does not allow it now: not homed, a fault, a move running... (409).
    #[error("{message}")]
    Conflict {
        /// What is in the way.
        message: String,
        /// A word for programs: `not-homed`, `homing`, `faulted`, `not-ready`, `busy`.
        reason: &'static str,
    },
    /// The PLC cannot be reached, or its heartbeat stands still (503).
    #[error("{message}")]
    Unavailable {
        /// Why.
        message: String,
        /// `link-down`, `stalled` or `shutting-down`.
        reason: &'static str,
    },
    /// The PLC refused a command or failed to carry it out (502).
    #[error("{detail}")]
    Plc {
        /// What the PLC answered, or how the exchange failed.
        detail: String,
    },
    /// The daemon's own state could not be kept (a file in the state directory) (500).
    #[error(transparent)]
    Storage {
        /// The positions file that could not be written, or why none can be.
        source: PositionError,
    },
    /// The daemon is shutting down (503).
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// A TCP request without the right bearer token (401).
    #[error("missing or wrong bearer token: send Authorization: Bearer <token>")]
    Unauthorized,
    /// A method the path does not take (405).
    #[error("method not allowed here")]
    MethodNotAllowed,
    /// A body over the API's limit (413).
    #[error(
        "the body is {}; at most {limit} bytes",
        bytes.map_or_else(|| format!("more than {limit} bytes"), |b| format!("{b} bytes"))
    )]
    TooLarge {
        /// Its size, when the request declares it (`Content-Length`).
        bytes: Option<u64>,
        /// The most the API reads, bytes.
        limit: usize,
    },
    /// An error the router's machinery answered (an extractor's rejection), in its words.
    #[error("{message}")]
    Other {
        /// Its status.
        status: StatusCode,
        /// What it said.
        message: String,
    },
}

/// The JSON body of an error, as the API writes it and the CLI reads it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ErrorBody {
    /// What went wrong.
    pub error: String,
    /// The field to blame, when one is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<String>,
    /// A word for programs (`not-homed`, `link-down`, `plc`...), when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
}

impl ApiError {
    /// The HTTP status this error answers with.
    #[must_use]
    pub fn status(&self) -> StatusCode {
        match self {
            Self::NotFound { .. } => StatusCode::NOT_FOUND,
            Self::BadRequest { .. } => StatusCode::BAD_REQUEST,
            Self::Unplannable(_) => StatusCode::UNPROCESSABLE_ENTITY,
            Self::Forbidden(_) => StatusCode::FORBIDDEN,
            Self::Conflict { .. } => StatusCode::CONFLICT,
            Self::Plc { .. } => StatusCode::BAD_GATEWAY,
            Self::Storage { .. } => StatusCode::INTERNAL_SERVER_ERROR,
            Self::Unavailable { .. } | Self::ShuttingDown => StatusCode::SERVICE_UNAVAILABLE,
            Self::Unauthorized => StatusCode::UNAUTHORIZED,
            Self::MethodNotAllowed => StatusCode::METHOD_NOT_ALLOWED,
            Self::TooLarge { .. } => StatusCode::PAYLOAD_TOO_LARGE,
            Self::Other { status, .. } => *status,
        }
    }

    fn field(&self) -> Option<&str> {
        match self {
            Self::NotFound { field, .. } => *field,
            Self::BadRequest { field, .. } => field.as_deref(),
            _ => None,
        }
    }

    /// The word for programs, where there is one.
    #[must_use]
    pub fn reason(&self) -> Option<&'static str> {
        match self {
            Self::Conflict { reason, .. } | Self::Unavailable { reason, .. } => Some(reason),
            Self::ShuttingDown => Some("shutting-down"),
            Self::Plc { .. } => Some("plc"),
            Self::Forbidden(_) => Some("not-allowed"),
            Self::Storage { .. } => Some("storage"),
            Self::TooLarge { .. } => Some("too-large"),
            _ => None,
        }
    }

    /// The error for a robot that cannot take a move now.
    fn not_now(blocker: Blocker, message: String) -> Self {
        let reason = match blocker {
            Blocker::LinkDown => "link-down",
            Blocker::Stalled => "stalled",
            Blocker::NotHomed => "not-homed",
            Blocker::Homing => "homing",
            Blocker::Faulted { .. } => "faulted",
            Blocker::NotReady { .. } => "not-ready",
            _ => "busy",
        };
        if matches!(blocker, Blocker::LinkDown | Blocker::Stalled) {
            Self::Unavailable { message, reason }
        } else {
            Self::Conflict { message, reason }
        }
    }
}

impl From<CommandError> for ApiError {
    fn from(e: CommandError) -> Self {
        let message = e.to_string();
        match e {
            CommandError::LinkDown { .. } => Self::Unavailable {
                message,
                reason: "link-down",
            },
            CommandError::Conflict { .. } => Self::Conflict {
                message,
                reason: "conflict",
            },
            CommandError::Plc { .. } | CommandError::HomeFailed { .. } => {
                Self::Plc { detail: message }
            }
            CommandError::ShuttingDown => Self::ShuttingDown,
        }
    }
}

impl From<GatewayError> for ApiError {
    fn from(e: GatewayError) -> Self {
        let message = e.to_string();
        match e {
            GatewayError::Denied(_) => Self::Forbidden(message),
            GatewayError::BadRequest(_) => Self::BadRequest {
                message,
                field: None,
            },
            GatewayError::LinkDown { .. } => Self::Unavailable {
                message,
                reason: "link-down",
            },
            GatewayError::Plc(_) | GatewayError::Untrusted { .. } => Self::Plc { detail: message },
            GatewayError::ShuttingDown => Self::ShuttingDown,
        }
    }
}

impl From<SubmitError> for ApiError {
    fn from(e: SubmitError) -> Self {
        match e {
            SubmitError::Order(order) => Self::BadRequest {
                message: order.to_string(),
                field: Some(order.field.to_owned()),
            },
            SubmitError::Plan(plan) => Self::Unplannable(plan.to_string()),
            SubmitError::Taught(e) => Self::Unplannable(e.to_string()),
            e @ SubmitError::NotNow { blocker, .. } => Self::not_now(blocker, e.to_string()),
            e @ SubmitError::QueueFull { .. } => Self::Conflict {
                message: e.to_string(),
                reason: "queue-full",
            },
            e @ SubmitError::MoveEnableOff => Self::Conflict {
                message: e.to_string(),
                reason: "move-enable-off",
            },
            e @ SubmitError::Untrusted { .. } => Self::Conflict {
                message: e.to_string(),
                reason: "untrusted",
            },
            SubmitError::ShuttingDown => Self::ShuttingDown,
        }
    }
}

impl From<PositionError> for ApiError {
    fn from(e: PositionError) -> Self {
        let message = e.to_string();
        match e {
            PositionError::BadName { .. } => Self::BadRequest {
                message,
                field: Some("position".to_owned()),
            },
            PositionError::NotFound { .. } => Self::NotFound {
                message,
                field: Some("position"),
            },
            PositionError::NotNow { blocker } => Self::not_now(blocker, message),
            PositionError::Frame { .. } => Self::BadRequest {
                message,
                field: Some("frame".to_owned()),
            },
            PositionError::Busy { .. } => Self::Conflict {
                message,
                reason: "busy",
            },
            source @ (PositionError::Write { .. } | PositionError::ReadOnly { .. }) => {
                Self::Storage { source }
            }
        }
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        let body = ErrorBody {
            error: self.to_string(),
            field: self.field().map(str::to_owned),
            reason: self.reason().map(str::to_owned),
        };
        let mut response = (self.status(), Json(body)).into_response();
        if matches!(self, Self::Unauthorized) {
            response.headers_mut().insert(
                header::WWW_AUTHENTICATE,
                header::HeaderValue::from_static("Bearer"),
            );
        }
        response
    }
}

impl From<crate::daemon::CycleError> for ApiError {
    fn from(e: crate::daemon::CycleError) -> Self {
        use crate::daemon::CycleError;
        let message = e.to_string();
        match e {
            CycleError::NoCycle => Self::NotFound {
                message,
                field: None,
            },
            CycleError::Program(_) => Self::BadRequest {
                message,
                field: Some("program".to_owned()),
            },
            CycleError::Running { .. } => Self::Conflict {
                message,
                reason: "cycle-running",
            },
            CycleError::Conflict { .. } => Self::Conflict {
                message,
                reason: "cycle-state",
            },
            CycleError::FaultNotCleared { .. } => Self::Conflict {
                message,
                reason: "faulted",
            },
            CycleError::ShuttingDown => Self::ShuttingDown,
        }
    }
}

impl From<crate::daemon::ModeError> for ApiError {
    fn from(e: crate::daemon::ModeError) -> Self {
        use crate::cell::Mode;
        use crate::daemon::ModeError;
        match &e {
            ModeError::NotYours { mode } => Self::Conflict {
                message: e.to_string(),
                reason: match mode {
                    Mode::Remote => "mode-remote",
                    Mode::Local => "mode-local",
                },
            },
            ModeError::Busy { .. } => Self::Conflict {
                message: e.to_string(),
                reason: "busy",
            },
            ModeError::NoFace { .. } => Self::BadRequest {
                message: e.to_string(),
                field: Some("mode".to_owned()),
            },
            ModeError::ShuttingDown => Self::ShuttingDown,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::OrderError;

    #[test]
    fn order_error_is_a_bad_request_naming_its_field() {
        let e = ApiError::from(SubmitError::Order(OrderError {
            field: "speed_mm_s",
            value: "0".into(),
            reason: "must be a number above 0".into(),
        }));
        assert_eq!(e.status(), StatusCode::BAD_REQUEST);
        assert_eq!(e.field(), Some("speed_mm_s"));
    }

    /// Each command error answers as before issue 26 typed them: the same status, `reason`
    /// word and message.
    #[test]
    fn command_errors_keep_their_status_reason_and_message() {
        use crate::contract::State;
        use crate::daemon::ConflictReason;
        let cases = [
            (
                CommandError::LinkDown {
                    detail: Some("timed out".into()),
                },
                StatusCode::SERVICE_UNAVAILABLE,
                "link-down",
                "the PLC link is down: timed out",
            ),
            (
                CommandError::Conflict {
                    reason: ConflictReason::PlcBusy {
                        state: State::Running,
                    },
                },
                StatusCode::CONFLICT,
                "conflict",
                "the PLC is running: stop it first; a fault is cleared only when nothing runs",
            ),
            (
                CommandError::Conflict {
                    reason: ConflictReason::MoveRuns,
                },
                StatusCode::CONFLICT,
                "conflict",
                "a move runs: stop it before homing",
            ),
            (
                CommandError::Plc {
                    detail: "the PLC answered error 61".into(),
                },
                StatusCode::BAD_GATEWAY,
                "plc",
                "the PLC answered error 61",
            ),
            (
                CommandError::HomeFailed { fault: 0 },
                StatusCode::BAD_GATEWAY,
                "plc",
                "the home routine did not end with the homed bit set",
            ),
            (
                CommandError::ShuttingDown,
                StatusCode::SERVICE_UNAVAILABLE,
                "shutting-down",
                "the daemon is shutting down",
            ),
        ];
        for (command, status, reason, message) in cases {
            let e = ApiError::from(command);
            assert_eq!(
                (e.status(), e.reason(), e.to_string().as_str()),
                (status, Some(reason), message)
            );
        }
    }

    #[test]
    fn a_positions_file_that_cannot_be_written_is_a_storage_error_keeping_its_cause() {
        let e = ApiError::from(PositionError::Write {
            file: "/var/lib/linterpd/positions.json".into(),
            source: std::io::Error::other("disk full"),
        });
        assert_eq!(e.status(), StatusCode::INTERNAL_SERVER_ERROR);
        assert_eq!(e.reason(), Some("storage"));
        assert!(
            e.to_string().starts_with("cannot write the positions file"),
            "{e}"
        );
        let cause = std::error::Error::source(&e).map(ToString::to_string);
        assert_eq!(cause.as_deref(), Some("disk full"));
    }

    #[test]
    fn error_body_leaves_out_an_absent_field() {
        let body = ErrorBody {
            error: "x".into(),
            field: None,
            reason: None,
        };
        assert_eq!(serde_json::to_string(&body).unwrap(), r#"{"error":"x"}"#);
    }
}
