//! PURE. The operator's console's decisions, apart from any server: the jog lease machine, the
//! control seat and its roles, a snapshot's changes as a merge patch, failed logins
//! rate-limited, a jog's pieces and its worst-case travel. `now` is an argument everywhere;
//! nothing here imports `daemon`, `cli` or `plc`. The server around them (the listener, the
//! WebSocket, cookies, the publisher and the jog driver) is `daemon::console`.
//!
//! ```text
//! lease.rs    the jog lease: (state, event, now) -> actions (stop, submit a piece, ended)
//! seat.rs     one control seat per robot; viewer / operator / admin
//! patch.rs    a snapshot's changes as a JSON merge patch (RFC 7396), and applying one
//! limiter.rs  failed logins, per client address and per user, within a window
//! jog.rs      a jog's pieces (constant-speed `by` orders), its speed under the drives'
//!             start_hz, its worst-case travel after the last keep-alive
//! ```

pub mod jog;
pub mod lease;
pub mod limiter;
pub mod patch;
pub mod seat;

/// A console user's role and the robots' manual speeds are config's words (config reads them).
pub use crate::config::{DEFAULT_MANUAL_SPEED_MM_S, MAX_MANUAL_SPEED_MM_S, Role};
pub use jog::{Travel, TravelInputs, piece_order, start_hz_speed};
pub use lease::{
    Action, EndedBy, Event, JogAxis, JogFacts, LEASE, Lease, LeaseSettings, PIECE, SessionId,
};
pub use limiter::{Limited, LoginLimiter};
pub use seat::{Asker, Command, Holder, Refusal, Seat};
