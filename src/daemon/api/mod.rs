//! The HTTP/JSON API of `linterpd serve` (docs/API.md), on axum: routes, handlers, errors, the
//! bearer token of a TCP listener, and the Prometheus metrics.
//!
//! ```text
//! GET  /v1/robots                          [RobotState]
//! GET  /v1/robots/{name}                   RobotState                    | 404
//! POST /v1/robots/{name}/moves             202 {"id", "ids", "report"}   | 400 | 404 | 422
//! GET  /v1/robots/{name}/moves/{id}        MoveReport                    | 404
//! GET  /v1/robots/{name}/moves/{id}/events application/x-ndjson reports  | 404
//! POST /v1/robots/{name}/stop              {"stopped": true}             | 404 | 502 | 503
//! POST /v1/robots/{name}/home              {"homed": true}               | 404 | 409 | 502 | 503
//! POST /v1/robots/{name}/clear-fault       {"cleared": true}             | 404 | 409 | 502 | 503
//! GET  /v1/robots/{name}/registers/{addr}  {"address","count","values"}  | 400 | 403 | 502 | 503
//! PUT  /v1/robots/{name}/registers/{addr}  {"address","count","values"}  | 400 | 403 | 502 | 503
//! GET  /v1/robots/{name}/positions         {"positions": [..], "warning"?}   | 404
//! GET  /v1/robots/{name}/positions/{pos}   NamedPosition                 | 400 | 404
//! PUT  /v1/robots/{name}/positions/{pos}   NamedPosition + "replaced"    | 400 | 404 | 409 | 500 | 503
//!      (POST the same: the robot's pose now saved as {pos})
//! DELETE /v1/robots/{name}/positions/{pos} {"deleted": NamedPosition}    | 400 | 404 | 500
//! POST /v1/robots/{name}/cycles            202 CycleStatus  (cycles.rs: run, stop, pause,
//! GET  /v1/robots/{name}/cycles            CycleStatus       resume a cycle program)
//! GET  /v1/live, /v1/robots/{name}/live   application/x-ndjson: the live stream (live.rs)
//! GET, PUT /v1/robots/{name}/speed-override {"percent": 1..=100}
//! GET  /v1/robots/{name}/pallets[/{pallet}]  PalletList, PalletStatus (pallets.rs: and POST
//!      .../pallets/{pallet}/set|reset|redo|go-on, the operator's changes of a count)
//! GET  /metrics                            Prometheus text
//! GET  /v1/journal                         {"entries": [Entry], "last_seq"} (journal.rs: and
//!                                          every other method's request journaled, with who)
//! ```
//! The answers are typed ([`crate::daemon::RobotState`], [`crate::daemon::MoveReport`],
//! [`crate::daemon::MoveAccepted`], [`NamedPosition`], [`Registers`], [`ErrorBody`]...) and
//! derive `Deserialize` too: the CLI reads them into the same types.
//! Every error is JSON with at least `error` (see [`ApiError`]; a rejection axum makes itself
//! is put in that shape too, `body.rs`), and `reason` (a word for programs) for 403
//! (`not-allowed`), 409, 413 (`too-large`: a body over [`MAX_BODY_BYTES`]), 502 and 503; `POST .../moves` answers 409 (`not-homed`, `homing`,
//! `faulted`, `not-ready`) or 503 (`link-down`, `stalled`) when the robot cannot take a move now.

mod answers;
mod auth;
mod body;
mod cycles;
mod error;
mod handlers;
mod journal;
mod listen;
mod live;
pub mod metrics;
pub mod mode;
mod pallets;
mod registers;
pub use cycles::{CycleOrder, CycleStop};
pub use live::SpeedOverride;
pub use pallets::PalletSet;
pub use registers::{RegisterWrite, Registers};

use std::collections::BTreeMap;
use std::sync::Arc;

use axum::Router;
use axum::routing::{get, post};
use tokio_util::sync::CancellationToken;

pub use answers::{DeletedPosition, NamedPosition, PositionList, SavedPosition};
pub use auth::{BearerToken, TokenError};
pub use body::MAX_BODY_BYTES;
pub use error::{ApiError, ErrorBody};
pub use journal::{CLI_AGENT, Caller, JournalPage, MAX_ENTRIES, metrics_text};
pub use listen::PeerCaller;
pub use listen::{HEADER_READ_TIMEOUT, serve, serve_with};

use super::RobotHandle;

/// A robot's resource: every route about one robot is under it.
const ROBOT: &str = "/v1/robots/{name}";

/// What every handler sees: the robots and the signal that the daemon is closing.
#[derive(Debug, Clone)]
pub struct Api {
    robots: Arc<BTreeMap<String, RobotHandle>>,
    closing: CancellationToken,
    /// The live streams (`GET .../live`), when the daemon publishes them.
    live: Option<super::stream::LiveHub>,
    /// The cell's journal (`GET /v1/journal`; commands journaled), when the daemon keeps one.
    journal: Option<crate::journal::Journal>,
}

impl Api {
    /// An API over these robots (by name, as [`super::Daemon::robots`] gives them).
    #[must_use]
    pub fn new(robots: BTreeMap<String, RobotHandle>) -> Self {
        Self {
            robots: Arc::new(robots),
            closing: CancellationToken::new(),
            live: None,
            journal: None,
        }
    }

    /// This API journaling every command into `journal` and reading it (`GET /v1/journal`).
    #[must_use]
    pub fn with_journal(self, journal: crate::journal::Journal) -> Self {
        Self {
            journal: journal.is_on().then_some(journal),
            ..self
        }
    }

    /// This API with the live streams of `hub` (`GET /v1/live`, `GET /v1/robots/{name}/live`).
    #[must_use]
    pub fn with_live(self, hub: super::stream::LiveHub) -> Self {
        Self {
            live: Some(hub),
            ..self
        }
    }

    /// Cancelled when the daemon begins to close: open event streams end.
    #[must_use]
    pub fn closing(&self) -> CancellationToken {
        self.closing.clone()
    }

    /// The routes; with a token, every request must carry it as `Authorization: Bearer`.
    pub fn router(&self, token: Option<BearerToken>) -> Router {
        let router = Router::new()
            .route("/v1/robots", get(handlers::robots))
            .route(ROBOT, get(handlers::robot))
            .route("/v1/live", get(live::all))
            .route(&format!("{ROBOT}/live"), get(live::one))
            .merge(Self::motion_routes())
            .merge(Self::cycle_routes())
            .merge(Self::store_routes())
            .route("/metrics", get(handlers::metrics))
            .route("/v1/journal", get(journal::read))
            .fallback(handlers::no_route)
            .method_not_allowed_fallback(handlers::wrong_method)
            .layer(axum::middleware::from_fn_with_state(
                self.clone(),
                journal::commands,
            ))
            .with_state(self.clone());
        let router = match token {
            Some(token) => router.layer(axum::middleware::from_fn_with_state(
                token,
                auth::require_token,
            )),
            None => router,
        };
        router.layer(axum::middleware::map_response(body::json_errors))
    }

    /// What moves a robot or changes how it moves: moves, paths, stop, home, mode, override.
    fn motion_routes() -> Router<Self> {
        Router::new()
            .route(
                &format!("{ROBOT}/speed-override"),
                get(live::get_override).put(live::put_override),
            )
            .route(&format!("{ROBOT}/moves"), post(handlers::submit))
            .route(&format!("{ROBOT}/paths"), post(handlers::submit_path))
            .route(&format!("{ROBOT}/moves/{{id}}"), get(handlers::report))
            .route(
                &format!("{ROBOT}/moves/{{id}}/events"),
                get(handlers::events),
            )
            .route(&format!("{ROBOT}/stop"), post(handlers::stop))
            .route(&format!("{ROBOT}/clear-fault"), post(handlers::clear_fault))
            .route(&format!("{ROBOT}/home"), post(handlers::home))
            .route(&format!("{ROBOT}/mode"), get(mode::get).put(mode::put))
    }

    /// A robot's cycles: status, run, stop, pause, resume.
    fn cycle_routes() -> Router<Self> {
        Router::new()
            .route(
                &format!("{ROBOT}/cycles"),
                get(cycles::status).post(cycles::run),
            )
            .route(&format!("{ROBOT}/cycles/stop"), post(cycles::stop))
            .route(&format!("{ROBOT}/cycles/pause"), post(cycles::pause))
            .route(&format!("{ROBOT}/cycles/resume"), post(cycles::resume))
    }

    /// What a robot keeps and what it reads: registers, taught positions, pallet counters.
    fn store_routes() -> Router<Self> {
        Router::new()
            .route(
                &format!("{ROBOT}/registers/{{address}}"),
                get(registers::read).put(registers::write),
            )
            .route(&format!("{ROBOT}/positions"), get(handlers::positions))
            .route(
                &format!("{ROBOT}/positions/{{pos}}"),
                get(handlers::position)
                    .put(handlers::save_position)
                    .post(handlers::save_position)
                    .delete(handlers::delete_position),
            )
            .route(&format!("{ROBOT}/pallets"), get(pallets::list))
            .route(&format!("{ROBOT}/pallets/{{pallet}}"), get(pallets::one))
            .route(
                &format!("{ROBOT}/pallets/{{pallet}}/{{command}}"),
                post(pallets::command),
            )
    }

    /// The robot called `name`, or a 404 naming the robots there are.
    fn robot(&self, name: &str) -> Result<&RobotHandle, ApiError> {
        self.robots.get(name).ok_or_else(|| {
            let known: Vec<&str> = self.robots.keys().map(String::as_str).collect();
            ApiError::NotFound {
                message: format!("no robot {name:?}; robots: {}", known.join(", ")),
                field: Some("robot"),
            }
        })
    }
}
