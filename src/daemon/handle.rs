//! The daemon's face to the rest of the program: one handle per robot (submit a move, stop, home,
//! clear a fault, read state and reports, follow a move's progress, teach positions) and the
//! daemon that spawns a worker per robot, watches that they make progress, and shuts them down.

use super::cell::Cell;
use super::cycle::CycleSlot;
use super::request::ConflictReason;
use crate::contract::Permit;
use std::collections::BTreeMap;
use std::sync::atomic::Ordering;
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use thiserror::Error;
use tokio::sync::{mpsc, oneshot, watch};
use tokio::task::JoinSet;

use super::gateway::{self, GatewayError, Job, Values};
use super::positions::{Position, PositionError, TaughtPositions, check_name, unix_now_s};
use super::request::{CommandError, Reply, Request};
use super::setup::{DaemonOptions, RobotSetup};
use super::shared::Shared;
use super::worker::{Channels, Worker};
use crate::contract::machine::Blocker;
use crate::gateway::{Address, GatewaySettings, Range};
use crate::geometry::Pose;
use crate::kinematics::JOINTS;
use crate::order::{
    Accepted, CheckedOrder, MoveOrder, OrderError, OrderLimits, PathOrder, SectionOrder,
    SectionPart, Target, plan_order,
};
use crate::plan::{MoveRequest, Origin, PathPlan, PlanError, SectionPlan, line_as_path, plan_path};
use crate::plc::PlcMode;
use crate::robot::{Motion, Robot};
use crate::wire::{MoveId, MoveReport, RobotPhase, RobotState, SectionReport, Stage};

/// Why a move was not accepted.
#[derive(Debug, Error)]
pub enum SubmitError {
    /// A field of the order is wrong.
    #[error(transparent)]
    Order(#[from] OrderError),
    /// The move cannot be planned from where the robot is (or will be).
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The robot cannot take a move now (link down, not homed, a fault...).
    #[error("{blocker}{}", detail.as_ref().map(|d| format!(": {d}")).unwrap_or_default())]
    NotNow {
        /// Why.
        blocker: Blocker,
        /// The link's last error, when that is why.
        detail: Option<String>,
    },
    /// The queue would hold more starts than it takes.
    #[error(
        "{queued} starts are queued or running and the order adds {adding}; at most {limit} \
         at once: wait for some to end"
    )]
    QueueFull {
        /// Starts queued or running now.
        queued: usize,
        /// Starts the order would add.
        adding: usize,
        /// The most, [`MAX_QUEUED_STARTS`].
        limit: usize,
    },
    /// The robot is in remote mode and the cell face's move-enable is off.
    #[error(
        "the cell face's move-enable is off (remote mode): no motion until the line turns it on"
    )]
    MoveEnableOff,
    /// The daemon is shutting down.
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// Asked for by a cycle before the PLC restarted, stalled or was lost: refused.
    #[error("{why} since the cycle asked for it")]
    Untrusted {
        /// What happened.
        why: String,
    },
}

/// The most starts a robot's queue holds, the running one included: an order that would pass
/// it is refused whole.
pub const MAX_QUEUED_STARTS: usize = 1_000;

/// One robot, as the API and the CLI see it.
#[derive(Debug, Clone)]
pub struct RobotHandle {
    pub(super) robot: Arc<Robot>,
    requests: mpsc::UnboundedSender<Request>,
    stops: mpsc::UnboundedSender<Reply>,
    gateway: mpsc::UnboundedSender<Job>,
    pub(super) gateway_settings: Arc<GatewaySettings>,
    pub(super) shared: Arc<Shared>,
    pub(super) positions: Arc<TaughtPositions>,
    pub(super) cell: Arc<Cell>,
    pub(super) cycles: Arc<CycleSlot>,
    /// The PLC's incident count this handle acts under (a cycle's): its moves and writes are
    /// refused once another incident came ([`Shared::incident`]); `None`: whenever.
    epoch: Option<u64>,
    /// The speed override, 1 to 100 %: every order checked after it is set is planned at it
    /// ([`Self::limits`]).
    speed_override: Arc<std::sync::atomic::AtomicU8>,
}

/// A position saved from the robot's pose.
#[derive(Debug, Clone, PartialEq)]
pub struct Saved {
    /// The position.
    pub position: Position,
    /// Whether it replaced one of the same name.
    pub replaced: bool,
}

impl RobotHandle {
    /// The robot.
    #[must_use]
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// Checks an order, refuses it at once if the robot cannot take a move now (link down, not
    /// homed, a fault), plans it from where the robot will be when its turn comes (refusing it,
    /// with nothing queued, if that fails), and queues it. A jog (`by`) behind a queued or running
    /// move is anchored here, where that move is planned to end; with none it is anchored to the
    /// PLC's counts when it begins. A `position` is looked up here: a later change of it does
    /// not move this order.
    ///
    /// Returns the id of the move's last start: the move has ended when it has (see
    /// [`RobotHandle::submit_starts`]).
    pub fn submit(&self, order: MoveOrder) -> Result<MoveId, SubmitError> {
        let ids = self.submit_starts(order)?;
        Ok(ids[ids.len() - 1])
    }

    /// [`RobotHandle::submit`], returning the id of every start the move runs as, in order. A
    /// line on which a joint reverses while another moves is queued as the starts
    /// of a path of that one line, cut at the reversal and chained at speed
    /// ([`crate::plan::plan_line`]); any other order is one start.
    pub fn submit_starts(&self, order: MoveOrder) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_behind(order, None).map(|(ids, _)| ids)
    }

    /// [`RobotHandle::submit`] of a move that is uploaded now and started only once `gate`
    /// opens (a cycle's move prepared during the wait before it). One start only: an order
    /// that would run as several is refused (the cycle then runs it after its wait). With its
    /// id, whether it moves: `false` when it is planned to end within a pulse of where it
    /// begins (it then ends with the move ahead of it, with no start of its own).
    pub(crate) fn submit_gated(
        &self,
        order: MoveOrder,
        gate: &super::gate::Gate,
    ) -> Result<(MoveId, bool), SubmitError> {
        let (ids, moves) = self.submit_behind(order, Some(gate))?;
        Ok((ids[0], moves))
    }

    /// The ids of `order`'s starts, and whether it moves the robot (as far as it can be told
    /// before its turn: no counts read yet, it is taken to).
    fn submit_behind(
        &self,
        order: MoveOrder,
        gate: Option<&super::gate::Gate>,
    ) -> Result<(Vec<MoveId>, bool), SubmitError> {
        let taught = self.positions.of(&self.robot.name);
        let mut checked = order.check_with(self.robot.motion, &self.limits(), &taught)?;
        checked.permit = self.permit(order.permit.as_deref())?;
        self.can_move_now()?;
        // Behind a move that is queued or running, an order starts where that one is planned
        // to end: a jog is anchored there now, so jogs queued back to back add up exactly. With
        // none, a jog stays relative and is anchored to the PLC's counts when it begins (the
        // counts read here may be a poll old); it is checked from them here.
        let ahead = self
            .shared
            .state(|s| s.current_move.is_some() || !s.queued.is_empty());
        let planned_end = self.shared.planned_end().filter(|_| ahead);
        let from = planned_end.or_else(|| self.counts_by_joint());
        let mut checked = match planned_end {
            Some(end) => checked.anchored_at(&self.robot, end),
            None => checked,
        };
        let mut end = None;
        if let Some(counts) = from {
            match plan_order(&self.robot, &checked, counts) {
                // Kept: begun from these counts, the order takes this plan.
                Ok(plan) => {
                    end = Some(plan.end_counts());
                    checked.accepted = Some(Arc::new(Accepted { counts, plan }));
                }
                // Where it starts already: it ends done there without a start (behind a move,
                // with that move).
                Err(PlanError::ZeroLength { .. } | PlanError::NoTravel { .. }) => {
                    end = Some(counts);
                }
                Err(e @ PlanError::LaterSegment { .. }) if gate.is_some() => {
                    return Err(e.into());
                }
                Err(e @ PlanError::LaterSegment { .. }) => {
                    return match checked.pose_target(&self.robot.pose_of(&counts)) {
                        Some(to) => self
                            .submit_line_in_parts(&order, &checked, counts, to)
                            .map(|ids| (ids, true)),
                        None => Err(e.into()),
                    };
                }
                Err(e) => return Err(e.into()),
            }
        }
        let moves = from
            .zip(end)
            .is_none_or(|(from, end)| from.iter().zip(&end).any(|(f, e)| (e - f).abs() > 1));
        let id = self.shared.next_id();
        let report = MoveReport::new(id, &self.robot.name, order);
        self.enqueue(vec![(report, checked)], end, gate.cloned())
            .map(|ids| (ids, moves))
    }

    /// Queues every start of one order, whole or not at all: refused with nothing queued when
    /// the queue would pass [`MAX_QUEUED_STARTS`] or the worker is gone. `end`: where the last
    /// is planned to end, for the next order; `gate`: what a single start waits for once
    /// uploaded (a cycle's move prepared ahead).
    fn enqueue(
        &self,
        starts: Vec<(MoveReport, CheckedOrder)>,
        end: Option<[i64; JOINTS]>,
        gate: Option<super::gate::Gate>,
    ) -> Result<Vec<MoveId>, SubmitError> {
        let queued = self
            .shared
            .state(|s| s.queued.len() + usize::from(s.current_move.is_some()));
        if queued + starts.len() > MAX_QUEUED_STARTS {
            return Err(SubmitError::QueueFull {
                queued,
                adding: starts.len(),
                limit: MAX_QUEUED_STARTS,
            });
        }
        let ids: Vec<MoveId> = starts.iter().map(|(r, _)| r.id).collect();
        // Reports first (the worker reports on them from its first step), then the queue.
        self.shared.moves(|m| {
            for (report, _) in &starts {
                m.insert(report.clone());
            }
        });
        self.shared.state(|s| s.queued.extend(&ids));
        for (report, order) in starts {
            let given = super::request::Given {
                id: report.id,
                order,
                gate: gate.clone(),
                epoch: self.epoch,
            };
            if self.requests.send(Request::Move(given)).is_err() {
                // The worker is gone: it took none of them.
                self.withdraw(&ids);
                return Err(SubmitError::ShuttingDown);
            }
        }
        self.shared.set_planned_end(end);
        Ok(ids)
    }

    /// Ends the reports of `ids`, never taken by the worker, cancelled.
    fn withdraw(&self, ids: &[MoveId]) {
        self.shared.moves(|m| {
            for &id in ids {
                m.update(id, |r| {
                    r.stage = Stage::Cancelled;
                    r.error = Some("cancelled: the daemon is shutting down".to_owned());
                });
            }
        });
        self.shared.state(|s| s.queued.retain(|q| !ids.contains(q)));
    }

    /// A line order from `counts` to `to` that one start cannot run
    /// ([`PlanError::LaterSegment`]), planned as a path of that one line and queued as its
    /// starts: their ids, in order. Each start's report is the order with its target at the
    /// pose where that start ends.
    fn submit_line_in_parts(
        &self,
        order: &MoveOrder,
        checked: &CheckedOrder,
        counts: [i64; JOINTS],
        to: Pose,
    ) -> Result<Vec<MoveId>, SubmitError> {
        let req = line_as_path(&MoveRequest {
            from: Origin::Counts(counts),
            to,
            motion: checked.motion,
        });
        let planned = plan_path(&self.robot, &req)?;
        let (motion, permit) = (checked.motion, checked.permit);
        self.queue_sections(planned, req.path_accel_mm_s2, motion, permit, |end| {
            order.ending_at(end)
        })
    }

    /// An order's `permit` resolved against the robot's signals and input words (none: no
    /// permit).
    fn permit(&self, text: Option<&str>) -> Result<Permit, SubmitError> {
        let Some(text) = text else {
            return Ok(Permit::NONE);
        };
        let names = super::permit::PermitNames {
            signals: &self.cell.settings.signals,
            inputs: &self.cell.inputs,
        };
        super::permit::resolve(text, names).map_err(|e| crate::order::permit_refused(&e).into())
    }

    /// Refuses at once when the robot cannot take a move now (link down, not homed, a fault).
    fn can_move_now(&self) -> Result<(), SubmitError> {
        if let Some(why) = self.untrusted() {
            return Err(SubmitError::Untrusted { why });
        }
        if self.face_holds_motion() {
            return Err(SubmitError::MoveEnableOff);
        }
        let Some(blocker) = self.shared.refusal() else {
            return Ok(());
        };
        let detail = match blocker {
            Blocker::LinkDown => self.shared.state(|s| s.link.error.clone()),
            Blocker::Stalled if self.state().plc_mode == Some(PlcMode::Prog) => {
                Some("it reports PROG mode".to_owned())
            }
            _ => None,
        };
        Err(SubmitError::NotNow { blocker, detail })
    }

    /// Checks a path, plans every section of it from where the robot will be when it starts
    /// (behind the moves queued or running, or where it is), refusing it whole if any section
    /// cannot be planned; then queues the sections, one move each, in order. Each is planned
    /// again from the counts where it begins, and only if the robot is there: a section whose
    /// move before it did not end done is cancelled with it. Returns the sections' move ids.
    pub fn submit_path(&self, order: &PathOrder) -> Result<Vec<MoveId>, SubmitError> {
        // Every field is checked before the robot's state: a bad order is a bad order.
        let limits = self.limits();
        order.check(&self.robot, &limits)?;
        let permit = self.permit(order.permit.as_deref())?;
        self.can_move_now()?;
        let ahead = self
            .shared
            .state(|s| s.current_move.is_some() || !s.queued.is_empty());
        let counts = self
            .shared
            .planned_end()
            .filter(|_| ahead)
            .or_else(|| self.counts_by_joint())
            .ok_or(SubmitError::NotNow {
                blocker: Blocker::LinkDown,
                detail: Some("no counts read from the PLC yet".to_owned()),
            })?;
        let taught = self.positions.of(&self.robot.name);
        let lookup = |name: &str| {
            taught.get(name).map(|p| {
                let [x, y, z, a] = p.pose;
                Pose::from_mm_deg(x, y, z, a)
            })
        };
        let req = order.request(&self.robot, &limits, counts, &lookup)?;
        let (path_accel_mm_s2, motion) = (req.path_accel_mm_s2, req.motion);
        let planned = plan_path(&self.robot, &req)?;
        self.queue_sections(planned, path_accel_mm_s2, motion, permit, |end| {
            order.section_report(end)
        })
    }

    /// Queues every start of `planned`, one move each, in order: their ids. `report` gives the
    /// order a start's report shows, from the pose where that start ends.
    fn queue_sections(
        &self,
        planned: PathPlan,
        path_accel_mm_s2: f64,
        motion: Motion,
        permit: Permit,
        report: impl Fn(&Pose) -> MoveOrder,
    ) -> Result<Vec<MoveId>, SubmitError> {
        let of = planned.sections.len();
        let end = planned.sections.last().map(SectionPlan::end_counts);
        let mut starts = Vec::new();
        for (n, section) in planned.sections.into_iter().enumerate() {
            let shared = Arc::new(SectionOrder {
                path: section.path,
                path_accel_mm_s2,
                accepted: section.starts,
                planned: OnceLock::new(),
            });
            let parts = shared.accepted.len();
            for (part, plan) in shared.accepted.iter().enumerate() {
                let checked = CheckedOrder {
                    target: Target::Section(SectionPart {
                        section: Arc::clone(&shared),
                        part,
                        parts,
                    }),
                    motion,
                    permit,
                    accepted: None,
                };
                let shown = SectionReport::new(
                    n + 1,
                    of,
                    &shared.path,
                    &|s| plan.time_at_course_mm(s),
                    &plan.window,
                );
                let id = self.shared.next_id();
                let mut report = MoveReport::new(
                    id,
                    &self.robot.name,
                    report(&self.robot.pose_of(&plan.end_counts())),
                );
                report.section = Some(shown);
                starts.push((report, checked));
            }
        }
        self.enqueue(starts, end, None)
    }

    /// The speed override, 1 to 100 %.
    #[must_use]
    pub fn speed_override(&self) -> u8 {
        self.speed_override.load(Ordering::SeqCst)
    }

    /// Sets the speed override (`percent` clamped to 1 to 100): every move checked from now on
    /// is planned at that share of its speed; moves already accepted keep theirs. Returns the
    /// override set.
    #[must_use = "the override set, clamped to 1 to 100"]
    pub fn set_speed_override(&self, percent: u8) -> u8 {
        let percent = percent.clamp(1, 100);
        self.speed_override.store(percent, Ordering::SeqCst);
        percent
    }

    /// What an order is checked against: the robot's limits under the speed override.
    fn limits(&self) -> OrderLimits {
        OrderLimits::of(&self.robot).overridden(self.speed_override())
    }

    /// The counts the PLC last reported, per joint.
    pub(super) fn counts_by_joint(&self) -> Option<[i64; JOINTS]> {
        let counts = self.shared.state(|s| s.counts)?;
        Some(std::array::from_fn(|j| {
            counts[usize::from(self.robot.joints[j].channel)]
        }))
    }

    /// The robot's taught positions, by name.
    #[must_use]
    pub fn positions(&self) -> BTreeMap<String, Position> {
        self.positions.of(&self.robot.name)
    }

    /// One taught position.
    pub fn position(&self, name: &str) -> Result<Position, PositionError> {
        self.positions.get(&self.robot.name, name)
    }

    /// What went wrong with the positions file at start (set aside as corrupt, unreadable), if
    /// anything did.
    #[must_use]
    pub fn positions_warning(&self) -> Option<&str> {
        self.positions.warning()
    }

    /// Saves the robot's pose, from the counts the PLC last reported, as position `name`
    /// (replacing one of that name). Refused while the link is down or stalled, the robot is
    /// not homed or homing (its counts mean nothing), or a move runs or waits.
    pub fn save_position(&self, name: &str) -> Result<Saved, PositionError> {
        check_name(name)?;
        if let Some(
            blocker @ (Blocker::LinkDown | Blocker::Stalled | Blocker::NotHomed | Blocker::Homing),
        ) = self.shared.refusal()
        {
            return Err(PositionError::NotNow { blocker });
        }
        let state = self.state();
        if state.current_move.is_some()
            || !state.queued.is_empty()
            || state.phase != RobotPhase::Idle
        {
            return Err(PositionError::Busy {
                current: state
                    .current_move
                    .map_or_else(|| "-".to_owned(), |id| id.to_string()),
                queued: state.queued.len(),
            });
        }
        let joint_counts = self.counts_by_joint().ok_or(PositionError::NotNow {
            blocker: Blocker::LinkDown,
        })?;
        let position = Position {
            pose: self.robot.pose_of(&joint_counts).to_mm_deg(),
            joint_counts,
            saved_unix_s: unix_now_s(),
        };
        let replaced = self
            .positions
            .save(&self.robot.name, name, position.clone())?;
        tracing::info!(robot = %self.robot.name, position = name, pose = %position.pose.map(|v| format!("{v:.3}")).join(","), counts = %joint_counts.map(|c| c.to_string()).join(","), replaced, "position saved");
        Ok(Saved { position, replaced })
    }

    /// Deletes a taught position; returns it.
    pub fn delete_position(&self, name: &str) -> Result<Position, PositionError> {
        let removed = self.positions.delete(&self.robot.name, name)?;
        tracing::info!(robot = %self.robot.name, position = name, "position deleted");
        Ok(removed)
    }

    /// Stops every channel and cancels every queued move; returns once the stop is written.
    pub async fn stop(&self) -> Result<(), CommandError> {
        // A stop always works, whoever runs the robot: a cycle ends with it.
        self.cycles.robot_stopped();
        self.stop_robot().await
    }

    /// Stops every channel and cancels every queued move, leaving the robot's cycle as it is
    /// (the cycle's own stop, when it faults).
    pub(crate) async fn stop_robot(&self) -> Result<(), CommandError> {
        self.shared.stop_pending.store(true, Ordering::SeqCst);
        self.shared.forget_planned_end();
        let (tx, rx) = oneshot::channel();
        self.stops
            .send(tx)
            .map_err(|_| CommandError::ShuttingDown)?;
        rx.await.map_err(|_| CommandError::ShuttingDown)?
    }

    /// Homes the robot: every joint's count is set to its home count at its home position.
    /// Returns once the PLC's home routine has ended.
    pub async fn home(&self) -> Result<(), CommandError> {
        self.command(Request::Home).await
    }

    /// Clears a latched fault on the PLC (refused while a move runs or when there is none,
    /// unless a cycle is faulted: then its fault is cleared, and it may be resumed).
    pub async fn clear_fault(&self) -> Result<(), CommandError> {
        let cycle_faulted = self
            .cycle()
            .is_some_and(|c| c.state == super::CycleState::Faulted);
        let cleared = match self.command(Request::ClearFault).await {
            Err(CommandError::Conflict {
                reason: ConflictReason::NoFault,
            }) if cycle_faulted => Ok(()),
            other => other,
        };
        // Only a clear that happened lets a faulted cycle be resumed.
        if cleared.is_ok() {
            self.cycles.fault_cleared(self.shared.incidents().count);
        }
        cleared
    }

    async fn command(&self, request: fn(Reply) -> Request) -> Result<(), CommandError> {
        let (tx, rx) = oneshot::channel();
        self.requests
            .send(request(tx))
            .map_err(|_| CommandError::ShuttingDown)?;
        rx.await.map_err(|_| CommandError::ShuttingDown)?
    }

    /// The robot's gateway settings (its access list, its Modbus face).
    #[must_use]
    pub fn gateway(&self) -> &GatewaySettings {
        &self.gateway_settings
    }

    /// Reads `count` registers (DT words) or bits (X, Y, R) from `start`, if the access list
    /// allows, through the robot's link.
    pub async fn read_registers(&self, start: Address, count: u32) -> Result<Values, GatewayError> {
        let range = gateway::range(start, count)?;
        self.gateway_settings.access.check_read(&range)?;
        self.gateway_job(range, None).await
    }

    /// Writes `values` from `start` (words to DT, bits to Y or R), if the access list allows.
    pub async fn write_registers(
        &self,
        start: Address,
        values: Values,
    ) -> Result<(), GatewayError> {
        gateway::check_values(start.area, &values)?;
        let range = gateway::range(start, values.len() as u32)?;
        self.gateway_settings.access.check_write(&range)?;
        self.gateway_job(range, Some(values)).await.map(|_| ())
    }

    pub(super) async fn gateway_job(
        &self,
        range: Range,
        write: Option<Values>,
    ) -> Result<Values, GatewayError> {
        if let Some(why) = self.untrusted() {
            return Err(GatewayError::Untrusted { why });
        }
        let (tx, rx) = oneshot::channel();
        let mut job = Job::new(range, write, tx);
        job.epoch = self.epoch;
        self.gateway
            .send(job)
            .map_err(|_| GatewayError::ShuttingDown)?;
        rx.await.map_err(|_| GatewayError::ShuttingDown)?
    }

    /// The robot's state as last read.
    #[must_use]
    pub fn state(&self) -> RobotState {
        let mut state = self.shared.state(|s| s.clone());
        state.cycle = self.cycles.status();
        state.mode = self.mode();
        state.face = self.face_state();
        state
    }

    /// A move's report.
    #[must_use]
    pub fn report(&self, id: MoveId) -> Option<MoveReport> {
        self.shared.moves(|m| m.get(id))
    }

    /// Every kept report.
    #[must_use]
    pub fn reports(&self) -> Vec<MoveReport> {
        self.shared.moves(|m| m.all())
    }

    /// The daemon's metrics (shared by every robot of one daemon).
    #[must_use]
    pub fn metrics(&self) -> &super::metrics::Metrics {
        self.shared.metrics.daemon()
    }

    /// A move's progress feed: every change of its report.
    #[must_use]
    pub fn subscribe(&self, id: MoveId) -> Option<watch::Receiver<MoveReport>> {
        self.shared.moves(|m| m.subscribe(id))
    }

    /// Waits until move `id` has ended (or `limit` passes) and returns its report.
    pub async fn wait(&self, id: MoveId, limit: Duration) -> Option<MoveReport> {
        let mut feed = self.subscribe(id)?;
        let _ = tokio::time::timeout(limit, feed.wait_for(|r| r.stage.is_final())).await;
        self.report(id)
    }

    /// Wakes on every status block the worker reads (and every link lost): what a cycle's wait
    /// decides on.
    #[must_use]
    pub fn watch_reads(&self) -> watch::Receiver<u64> {
        self.shared.watch_reads()
    }

    /// How long ago the worker last read the status block (`None`: never since the link came).
    #[must_use]
    pub fn since_status_read(&self) -> Option<Duration> {
        self.shared.since_read()
    }

    /// Whether a cycle waits on the inputs now: the worker then reads the status block at its
    /// busy pace.
    pub(crate) fn watch_inputs(&self, on: bool) {
        self.shared.inputs_watched.store(on, Ordering::Relaxed);
        if on {
            self.shared.read_soon.notify_one();
        }
    }

    /// Shuts `gate`, a prepared move's, and wakes the worker to end that move at once wherever
    /// it is (queued, uploading or held).
    pub(crate) fn shut_gate(&self, gate: &super::gate::Gate) {
        gate.shut();
        self.shared.read_soon.notify_one();
    }

    /// This handle acting under the PLC's incident count `epoch` (a cycle's, from its start or
    /// its last resume): what it asks for is refused, or not carried out, once another incident
    /// came.
    pub(crate) fn under(&self, epoch: u64) -> Self {
        Self {
            epoch: Some(epoch),
            ..self.clone()
        }
    }

    /// What happened since this handle's epoch, if anything did.
    fn untrusted(&self) -> Option<String> {
        let epoch = self.epoch?;
        let incidents = self.shared.incidents();
        (incidents.count != epoch).then(|| incidents.last.unwrap_or_default())
    }

    /// The PLC's incidents so far (a restart, a stall or PROG mode, a link lost past a move's
    /// end): a cycle faults on every one, whatever its step.
    #[must_use]
    pub fn incidents(&self) -> super::shared::Incidents {
        self.shared.incidents()
    }

    /// Wakes on every incident ([`Self::incidents`]).
    #[must_use]
    pub fn watch_incidents(&self) -> watch::Receiver<super::shared::Incidents> {
        self.shared.watch_incidents()
    }

    /// How long ago the robot's worker last went round its loop.
    #[must_use]
    pub fn since_worker_beat(&self) -> Option<Duration> {
        self.shared.since_loop_beat()
    }
}

/// The daemon: a worker per robot.
#[derive(Debug)]
pub struct Daemon {
    robots: BTreeMap<String, RobotHandle>,
    shutdown: watch::Sender<bool>,
    workers: JoinSet<String>,
}

impl Daemon {
    /// Spawns a worker for each robot.
    #[must_use]
    pub fn spawn(robots: Vec<RobotSetup>, options: &DaemonOptions) -> Self {
        let (shutdown, _) = watch::channel(false);
        let mut handles = BTreeMap::new();
        let mut workers = JoinSet::new();
        let metrics = super::metrics::Metrics::new();
        for setup in robots {
            let name = setup.robot.name.clone();
            let shared = Arc::new(Shared::new(
                &name,
                Arc::clone(&options.ids),
                metrics.robot(&name),
            ));
            let (requests, requests_rx) = mpsc::unbounded_channel();
            let (stops, stops_rx) = mpsc::unbounded_channel();
            let (gateway, gateway_rx) = mpsc::unbounded_channel();
            let handle = RobotHandle {
                robot: Arc::new(setup.robot.clone()),
                requests,
                stops,
                gateway,
                gateway_settings: Arc::new(setup.gateway.clone()),
                shared: Arc::clone(&shared),
                positions: Arc::clone(&options.positions),
                cell: Arc::new(Cell::new(setup.cell.clone(), setup.settings.layout.inputs)),
                cycles: Arc::new(CycleSlot::default()),
                epoch: None,
                speed_override: Arc::new(std::sync::atomic::AtomicU8::new(100)),
            };
            let worker = Worker::new(
                setup,
                options,
                Channels {
                    requests: requests_rx,
                    stops: stops_rx,
                    gateway: gateway_rx,
                    shutdown: shutdown.subscribe(),
                },
                shared,
            );
            let task_name = name.clone();
            workers.spawn(async move {
                worker.run().await;
                task_name
            });
            handles.insert(name, handle);
        }
        Self {
            robots: handles,
            shutdown,
            workers,
        }
    }

    /// The robots, by name.
    #[must_use]
    pub fn robots(&self) -> &BTreeMap<String, RobotHandle> {
        &self.robots
    }

    /// A robot by name.
    #[must_use]
    pub fn robot(&self, name: &str) -> Option<&RobotHandle> {
        self.robots.get(name)
    }

    /// Completes when a worker ends before shutdown (it panicked), with what happened.
    pub async fn worker_failed(&mut self) -> String {
        match self.workers.join_next().await {
            Some(Ok(name)) => format!("the worker of robot {name:?} ended"),
            Some(Err(e)) if e.is_panic() => format!("a robot's worker panicked: {e}"),
            Some(Err(e)) => format!("a robot's worker was cancelled: {e}"),
            None => std::future::pending().await,
        }
    }

    /// Shuts every worker down cleanly (no half-written bank, no start left waiting) and waits
    /// for them.
    pub async fn shut_down(mut self) {
        let _ = self.shutdown.send(true);
        while self.workers.join_next().await.is_some() {}
    }

    /// Ends every worker at once, as a killed process would (no withdrawal, nothing written):
    /// for tests of a daemon restart.
    pub async fn kill(mut self) {
        self.workers.abort_all();
        while self.workers.join_next().await.is_some() {}
    }
}
