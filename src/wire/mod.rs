//! PURE. What the daemon's API says: a robot's state, a move's report, a cycle's status, the
//! cell face as the robot's state shows it. The daemon writes them, the CLI and the console read
//! them back; their JSON is the API's (docs/API.md), pinned byte for byte by `json_tests`.
//!
//! ```text
//! report.rs  MoveId, Stage, MoveReport (EndReason, Predicted, SectionReport, PieceReport), MoveAccepted,
//!            PathAccepted
//! state.rs   RobotState (LinkState, RobotPhase, GatewayStats, FaceState, FaceRefusal)
//! cycle.rs   CycleStatus, CycleState, StepAt
//! ```

mod cycle;
mod report;
mod state;

pub use cycle::{CycleState, CycleStatus, StepAt};
pub use report::{
    EndReason, MoveAccepted, MoveId, MoveReport, PathAccepted, PieceKind, PieceReport, Predicted,
    SectionReport, Stage,
};
pub use state::{FaceRefusal, FaceState, GatewayStats, LinkState, RobotPhase, RobotState};

#[cfg(test)]
mod json_tests;
