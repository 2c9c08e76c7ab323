//! PURE. What the API says of a move: its stage, its report (what was planned, where it runs,
//! how it ended), and the answers to a move or path order. The daemon writes these; the CLI and
//! the console read them back.

use serde::{Deserialize, Serialize};

use crate::geometry::{Path, Primitive};
use crate::order::MoveOrder;

/// A move's identifier, unique across daemon runs (see `crate::daemon::MoveIds`).
pub type MoveId = u64;

/// Where a move is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stage {
    /// Accepted, waiting its turn.
    Queued,
    /// Planned; its bank is being written and verified.
    Uploading,
    /// A cycle's move prepared ahead: its bank written and verified, held until the cycle
    /// reaches its step (nothing given to the PLC yet).
    Prepared,
    /// Uploaded and started while the previous move runs: the PLC starts it when that one ends.
    Waiting,
    /// Running on the PLC.
    Running,
    /// Ended on its target.
    Done,
    /// Stopped while it ran (a stop request, the e-stop input, PROG mode): see `error`.
    Stopped,
    /// Failed: see `error`; nothing more will happen to it.
    Failed,
    /// Never ran: nothing moved (a stop came first, the move before it did not end, the PLC
    /// restarted, the daemon shut down): see `error`.
    Cancelled,
}

impl Stage {
    /// The final stages, in the order metrics list them.
    pub const FINAL: [Self; 4] = [Self::Done, Self::Stopped, Self::Failed, Self::Cancelled];

    /// Whether nothing more will happen to the move.
    #[must_use]
    pub fn is_final(self) -> bool {
        matches!(
            self,
            Self::Done | Self::Stopped | Self::Failed | Self::Cancelled
        )
    }

    /// Its name as the API writes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Queued => "queued",
            Self::Uploading => "uploading",
            Self::Prepared => "prepared",
            Self::Waiting => "waiting",
            Self::Running => "running",
            Self::Done => "done",
            Self::Stopped => "stopped",
            Self::Failed => "failed",
            Self::Cancelled => "cancelled",
        }
    }
}

/// The planner's prediction for a move.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Predicted {
    /// Table rows over all channels.
    pub rows: usize,
    /// DT words of the tables.
    pub words: usize,
    /// Planned duration, s.
    pub duration_s: f64,
    /// Path deviation the execution model predicts, mm.
    pub path_deviation_mm: f64,
    /// Tracking error the execution model predicts, mm.
    pub tracking_error_mm: f64,
}

/// Everything known about one move. Read back (by the CLI), a field an older daemon did not
/// write is `None` (or empty, false, 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MoveReport {
    /// Its identifier.
    pub id: MoveId,
    /// The robot.
    pub robot: String,
    /// Where it is.
    pub stage: Stage,
    /// The order as accepted (empty for a move found running after a restart).
    #[serde(default)]
    pub order: MoveOrder,
    /// Found running on the PLC when the daemon (re)connected, not started by this run.
    #[serde(default)]
    pub recovered: bool,
    /// The longest the move may take from now on before it is given up, s (its planned
    /// duration and upload plus margins); what `linterpd move` waits for at most.
    pub deadline_s: Option<f64>,
    /// The contract sequence number of its start.
    pub seq: Option<u16>,
    /// The table bank it uses.
    pub bank: Option<u16>,
    /// Counts per channel it was planned from.
    pub start_counts: Option<[i64; 4]>,
    /// Counts per channel it should end at.
    pub target_counts: Option<[i64; 4]>,
    /// The plan's prediction.
    pub predicted: Option<Predicted>,
    /// Time to write and verify its bank, s.
    pub upload_s: Option<f64>,
    /// Time from its start to its end on the PLC, as polled, s.
    pub motion_s: Option<f64>,
    /// How far along its plan it is, as a share of its planned duration (0 to 1): the planned
    /// instant whose counts come nearest the counts last read from the PLC (it never goes
    /// back); by the clock only for a move the daemon found running without its plan.
    #[serde(default)]
    pub progress: f64,
    /// The latest counts per channel read while it ran.
    pub counts: Option<[i64; 4]>,
    /// Final counts minus target counts per channel (`None` until it is done, and for a move
    /// that chained into the next, whose start the PLC made from exactly these).
    pub final_error_pulses: Option<[i64; 4]>,
    /// Why it failed or stopped.
    pub error: Option<String>,
    /// A path section's move: which section, and when it runs each of the path's pieces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section: Option<SectionReport>,
    /// Why it ended short, where a client acts on it: held by the PLC (contract v3 fault 9, on
    /// the wire `"held": true`; `error` names the input), or a prepared move cancelled before
    /// its start (the daemon's own: not on the wire, `error` says it in words).
    #[serde(
        rename = "held",
        default,
        with = "end_as_held",
        skip_serializing_if = "end_as_held::not_held"
    )]
    pub end: Option<EndReason>,
}

/// Why a move ended short of its target, as a client acts on it (the words are in `error`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EndReason {
    /// Stopped by the PLC because its permit stopped holding: a hold, not a fault; run again,
    /// it goes on from where the robot stopped.
    Held,
    /// A cycle's move prepared ahead, cancelled before its start (nothing moved): the cycle
    /// runs it afresh at its step.
    CancelledBeforeStart,
}

impl MoveReport {
    /// Whether the PLC held it (its permit stopped holding).
    #[must_use]
    pub fn held(&self) -> bool {
        self.end == Some(EndReason::Held)
    }
}

/// The end reason on the wire: `"held": true` for a hold, nothing otherwise (as ever).
#[allow(
    clippy::ref_option,
    clippy::trivially_copy_pass_by_ref,
    reason = "serde's `with` passes the field by reference"
)]
mod end_as_held {
    use serde::{Deserialize, Deserializer, Serializer};

    use super::EndReason;

    pub(super) fn not_held(end: &Option<EndReason>) -> bool {
        *end != Some(EndReason::Held)
    }

    pub(super) fn serialize<S: Serializer>(
        end: &Option<EndReason>,
        out: S,
    ) -> Result<S::Ok, S::Error> {
        out.serialize_bool(!not_held(end))
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        from: D,
    ) -> Result<Option<EndReason>, D::Error> {
        Ok(bool::deserialize(from)?.then_some(EndReason::Held))
    }
}

/// What `POST /v1/robots/{name}/moves` answers (202).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MoveAccepted {
    /// The move's last start: the move has ended when it has.
    pub id: MoveId,
    /// Every start, in order: one, or a line cut where a joint reverses (an older daemon gave
    /// only `id`: read back, then empty).
    #[serde(default)]
    pub ids: Vec<MoveId>,
    /// The last start's report.
    pub report: MoveReport,
}

/// What `POST /v1/robots/{name}/paths` answers (202): one move per section (or part of one), in
/// order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PathAccepted {
    /// The moves' ids.
    pub ids: Vec<MoveId>,
    /// Their reports (one that ended and was dropped since is left out).
    #[serde(default)]
    pub reports: Vec<MoveReport>,
}

/// Which section of a path a move runs, and when it runs each piece of it, so that a client can
/// tell from a move's `progress` which element (or blend) the robot is on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SectionReport {
    /// The section, from 1.
    pub number: usize,
    /// How many sections the path has.
    pub of: usize,
    /// Its pieces, in order.
    pub pieces: Vec<PieceReport>,
}

/// One piece of a section, and when the move runs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PieceReport {
    /// A line or an arc.
    pub kind: PieceKind,
    /// The element it comes from (from 1); none for a blend.
    pub element: Option<usize>,
    /// A blend: the waypoint it rounds (the end of element n); none for an element's piece.
    pub waypoint: Option<usize>,
    /// Share of the move's planned duration when it is entered (0 to 1), as `progress` counts.
    pub begins: f64,
    /// Share of the move's planned duration when it is left.
    pub ends: f64,
}

/// What a piece of a path is (`line` or `arc` in the API).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PieceKind {
    /// A straight line.
    Line,
    /// A circular arc: an element's, or a blend rounding a waypoint.
    Arc,
}

impl From<&Primitive> for PieceKind {
    fn from(primitive: &Primitive) -> Self {
        match primitive {
            Primitive::Line(_) => Self::Line,
            Primitive::Arc(_) => Self::Arc,
        }
    }
}

impl SectionReport {
    /// Section `number` of `of`, its path `section` (measured from its start) reached at
    /// distance `s` at `time_at_mm(s)` on its profile's time, of which this start plays `window` (a part of a section cut into several starts shows
    /// the pieces before it done and those after it not begun).
    #[must_use]
    pub fn new(
        number: usize,
        of: usize,
        section: &Path,
        time_at_mm: &dyn Fn(f64) -> f64,
        window: &crate::plan::Window,
    ) -> Self {
        let duration_s = window.duration_s();
        let share = |s_mm: f64| ((time_at_mm(s_mm) - window.from_s) / duration_s).clamp(0.0, 1.0);
        let pieces = section
            .pieces()
            .iter()
            .map(|p| PieceReport {
                kind: PieceKind::from(&p.primitive),
                element: p.element,
                waypoint: p.waypoint,
                begins: share(p.start_mm),
                ends: share(p.start_mm + p.primitive.length_mm()),
            })
            .collect();
        Self { number, of, pieces }
    }
}

impl MoveReport {
    /// A new report for an order.
    #[must_use]
    pub fn new(id: MoveId, robot: &str, order: MoveOrder) -> Self {
        Self {
            id,
            robot: robot.to_owned(),
            stage: Stage::Queued,
            order,
            recovered: false,
            deadline_s: None,
            seq: None,
            bank: None,
            start_counts: None,
            target_counts: None,
            predicted: None,
            upload_s: None,
            motion_s: None,
            progress: 0.0,
            counts: None,
            final_error_pulses: None,
            end: None,
            error: None,
            section: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Corner, Element, PathSpec, Pose, Profile, ProfileRequest};

    #[test]
    fn a_sections_report_gives_each_piece_its_share_of_the_planned_time() {
        let to = |x, y| Element::Line {
            to: Pose::from_mm_deg(x, y, 0.0, 0.0),
        };
        let path = Path::build(&PathSpec {
            start: Pose::from_mm_deg(0.0, 0.0, 0.0, 0.0),
            elements: vec![
                (to(100.0, 0.0), Corner::Blend(20.0)),
                (to(100.0, 100.0), Corner::Stop),
            ],
        })
        .unwrap();
        let profile = Profile::new(ProfileRequest {
            length_mm: path.length_mm(),
            speed_mm_s: 100.0,
            accel_s: 0.2,
            period_s: 0.01,
        })
        .unwrap();
        let report = SectionReport::new(
            2,
            3,
            &path,
            &|s| profile.time_at_mm(s),
            &crate::plan::Window::whole(&profile),
        );
        assert_eq!((report.number, report.of), (2, 3));
        let names: Vec<_> = report
            .pieces
            .iter()
            .map(|p| (p.kind, p.element, p.waypoint))
            .collect();
        assert_eq!(
            names,
            [
                (PieceKind::Line, Some(1), None),
                (PieceKind::Arc, None, Some(1)),
                (PieceKind::Line, Some(2), None)
            ]
        );
        // Back to back from 0 to 1; the blend's share is its time on the cruise.
        assert!(report.pieces[0].begins.abs() < 1e-12);
        assert!((report.pieces[2].ends - 1.0).abs() < 1e-12);
        for w in report.pieces.windows(2) {
            assert!((w[0].ends - w[1].begins).abs() < 1e-12);
        }
        let blend_s = (report.pieces[1].ends - report.pieces[1].begins) * profile.duration_s();
        let blend_mm = path.pieces()[1].primitive.length_mm();
        assert!(
            (blend_s - blend_mm / profile.speed_mm_s).abs() < 1e-6,
            "{blend_s}"
        );
    }
}
