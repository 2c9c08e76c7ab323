//! PURE. What the daemon's API says: a robot's state, a move's report, a cycle's status, the
//! cell face as the robot's state shows it. The daemon writes them, the CLI and the console read
//! them back; their JSON is the API's (docs/API.md), pinned byte for byte by `json_tests`.
//!
//! ```text
//! report.rs  MoveId, Stage, MoveReport (EndReason, Predicted, SectionReport, PieceReport), MoveAccepted,
//!            PathAccepted
//! state.rs   RobotState (LinkState, RobotPhase, GatewayStats, FaceState, FaceRefusal)
//! cycle.rs   CycleStatus, CycleState, StepAt
//! journal/   Entry, Kind: the cell's journal, one JSON line an entry; what changed between two
//!            states of a robot (the follower's decision), production counts per shift
//! pallet.rs  PalletStatus, PalletList: a robot's pallets' counts as the operator sees them
//! live.rs    Live (a robot's live state for the console and `status --watch`), LiveMessage
//!            (the stream: the whole snapshot, then merge patches)
//! ```

mod cycle;
pub mod journal;
mod live;
mod pallet;
mod report;
mod state;

pub use cycle::{CycleState, CycleStatus, StepAt};
pub use live::{ActiveJog, ConsoleLive, JogLive, Live, LiveMessage, SeatHolder, SignalValue};
pub use pallet::{PalletList, PalletStatus, SlotInProgress};
pub use report::{
    EndReason, MoveAccepted, MoveId, MoveReport, PathAccepted, PieceKind, PieceReport, Predicted,
    SectionReport, Stage,
};
pub use state::{FaceRefusal, FaceState, GatewayStats, LinkState, RobotPhase, RobotState};

#[cfg(test)]
mod json_tests;
