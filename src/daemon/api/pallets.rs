//! `/v1/robots/{name}/pallets`: the robot's pallets' counts, and the operator's changes.
//!
//! ```text
//! GET  /v1/robots/{name}/pallets                         PalletList    | 404
//! GET  /v1/robots/{name}/pallets/{pallet}                PalletStatus  | 404
//! POST /v1/robots/{name}/pallets/{pallet}/set  {"index"} PalletStatus  | 400 | 404 | 409 | 500
//! POST /v1/robots/{name}/pallets/{pallet}/reset          PalletStatus  | 400 | 404 | 409 | 500
//! POST /v1/robots/{name}/pallets/{pallet}/redo           PalletStatus  | 400 | 404 | 409 | 500
//! POST /v1/robots/{name}/pallets/{pallet}/go-on          PalletStatus  | 400 | 404 | 409 | 500
//! ```
//! 409 `cycle-running` while the robot's cycle runs or waits (a redo or go-on for a slot
//! waiting for one is taken); 409 `nothing-to-choose` for a redo or go-on with no interrupted
//! slot; 400 (`field` `index`) for an index past the pallet's slots. Every change is journaled
//! with who sent it (`journal.rs`), as every command is.

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use serde::{Deserialize, Serialize};

use super::error::ApiError;
use super::{Api, handlers};
use crate::daemon::{PalletCommand, PalletOpError};
use crate::wire::{PalletList, PalletStatus};

/// What `POST .../pallets/{pallet}/set` takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PalletSet {
    /// The slot to fill next, from 0 (the pallet's slots: full).
    pub index: usize,
}

/// The commands, by their name in the path.
const COMMANDS: [&str; 4] = ["set", "reset", "redo", "go-on"];

pub(super) async fn list(
    State(api): State<Api>,
    Path(name): Path<String>,
) -> Result<Json<PalletList>, ApiError> {
    Ok(Json(api.robot(&name)?.pallets()))
}

pub(super) async fn one(
    State(api): State<Api>,
    Path((name, pallet)): Path<(String, String)>,
) -> Result<Json<PalletStatus>, ApiError> {
    Ok(Json(api.robot(&name)?.pallet(&pallet)?))
}

pub(super) async fn command(
    State(api): State<Api>,
    Path((name, pallet, command)): Path<(String, String, String)>,
    body: Bytes,
) -> Result<Json<PalletStatus>, ApiError> {
    let robot = api.robot(&name)?;
    let command = parse_command(&command, &body)?;
    tracing::info!(robot = %name, pallet, command = command.name(), "pallet change requested");
    Ok(Json(robot.pallet_command(&pallet, command)?))
}

/// The command named `name`, with its body (`set` takes `{"index"}`; the others none).
fn parse_command(name: &str, body: &[u8]) -> Result<PalletCommand, ApiError> {
    let empty = body.iter().all(u8::is_ascii_whitespace) || is_empty_object(body);
    let command = match name {
        "set" => {
            let set: PalletSet = handlers::parse_body(body)?;
            return Ok(PalletCommand::Set(set.index));
        }
        "reset" => PalletCommand::Reset,
        "redo" => PalletCommand::Redo,
        "go-on" => PalletCommand::GoOn,
        other => {
            return Err(ApiError::NotFound {
                message: format!(
                    "no pallet command {other:?}; the commands: {}",
                    COMMANDS.join(", ")
                ),
                field: Some("command"),
            });
        }
    };
    if !empty {
        return Err(ApiError::BadRequest {
            message: format!("{name} takes no body (only set takes {{\"index\": N}})"),
            field: None,
        });
    }
    Ok(command)
}

fn is_empty_object(body: &[u8]) -> bool {
    serde_json::from_slice::<serde_json::Map<String, serde_json::Value>>(body)
        .is_ok_and(|m| m.is_empty())
}

impl From<PalletOpError> for ApiError {
    fn from(e: PalletOpError) -> Self {
        use crate::daemon::pallets::PalletStoreError;
        use crate::pallet::CounterError;
        let message = e.to_string();
        match e {
            PalletOpError::NoPallet { .. } => Self::NotFound {
                message,
                field: Some("pallet"),
            },
            PalletOpError::CycleRunning { .. } => Self::Conflict {
                message,
                reason: "cycle-running",
            },
            PalletOpError::Store(PalletStoreError::Counter(CounterError::PastEnd { .. })) => {
                Self::BadRequest {
                    message,
                    field: Some("index".to_owned()),
                }
            }
            PalletOpError::Store(PalletStoreError::Counter(CounterError::NothingToChoose {
                ..
            })) => Self::Conflict {
                message,
                reason: "nothing-to-choose",
            },
            PalletOpError::Store(
                source @ (PalletStoreError::Write { .. } | PalletStoreError::ReadOnly { .. }),
            ) => Self::PalletStorage { source },
            PalletOpError::Store(_) => Self::Conflict {
                message,
                reason: "pallet-state",
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::pallets::PalletStoreError;
    use crate::pallet::CounterError;
    use axum::http::StatusCode;

    fn field(e: &ApiError) -> Option<&str> {
        match e {
            ApiError::BadRequest { field, .. } => field.as_deref(),
            _ => None,
        }
    }

    #[test]
    fn commands_and_their_bodies_parse_and_a_wrong_one_names_the_field() {
        assert_eq!(
            parse_command("set", br#"{"index": 5}"#).unwrap(),
            PalletCommand::Set(5)
        );
        assert_eq!(parse_command("go-on", b"").unwrap(), PalletCommand::GoOn);
        assert_eq!(parse_command("redo", b"{}").unwrap(), PalletCommand::Redo);
        assert_eq!(parse_command("reset", b" ").unwrap(), PalletCommand::Reset);
        let e = parse_command("set", br#"{"index": -1}"#).unwrap_err();
        assert_eq!(
            (e.status(), field(&e)),
            (StatusCode::BAD_REQUEST, Some("index"))
        );
        let e = parse_command("set", b"").unwrap_err();
        assert_eq!(e.status(), StatusCode::BAD_REQUEST);
        let e = parse_command("reset", br#"{"index": 1}"#).unwrap_err();
        assert!(e.to_string().contains("reset takes no body"), "{e}");
        let e = parse_command("skip", b"").unwrap_err();
        assert_eq!(e.status(), StatusCode::NOT_FOUND);
        assert!(e.to_string().contains("set, reset, redo, go-on"), "{e}");
    }

    #[test]
    fn refusals_answer_with_their_status_and_reason() {
        let past = CounterError::PastEnd {
            pallet: "out".into(),
            index: 25,
            last: 23,
        };
        let e = ApiError::from(PalletOpError::Store(past.into()));
        assert_eq!(
            (e.status(), field(&e)),
            (StatusCode::BAD_REQUEST, Some("index"))
        );
        let text = e.to_string();
        assert!(
            text.contains("index 25 is past its last slot (23)")
                && text.contains("24 marks the pallet full"),
            "{text}"
        );
        let nothing = CounterError::NothingToChoose {
            pallet: "out".into(),
        };
        let e = ApiError::from(PalletOpError::Store(nothing.into()));
        assert_eq!(
            (e.status(), e.reason()),
            (StatusCode::CONFLICT, Some("nothing-to-choose"))
        );
        let write = PalletStoreError::Write {
            file: "/var/lib/linterpd/pallets.json".into(),
            source: std::io::Error::other("disk full"),
        };
        let e = ApiError::from(PalletOpError::Store(write));
        assert_eq!(
            (e.status(), e.reason()),
            (StatusCode::INTERNAL_SERVER_ERROR, Some("storage"))
        );
    }
}
