//! A robot's orders as its handle takes them: checked (every field, the permit, whether the
//! robot can move now), planned off the async runtime from where the robot will be when the
//! order's turn comes, and given to the robot's worker, which queues them whole or not at all
//! and answers with their ids. Orders are taken one at a time per robot (its `lane`), so each is
//! planned from where the one before it ends.

use std::sync::{Arc, OnceLock};
use std::time::Duration;

use super::RobotHandle;
use crate::contract::Permit;
use crate::contract::machine::Blocker;
use crate::daemon::gate::Gate;
use crate::daemon::request::{Batch, Request, SubmitError};
use crate::geometry::Pose;
use crate::kinematics::JOINTS;
use crate::order::{
    Accepted, CheckedOrder, MoveOrder, PathOrder, SectionOrder, SectionPart, Target, plan_order,
};
use crate::plan::{
    MoveRequest, Origin, PathPlan, PathRequest, Plan, PlanError, SectionPlan, line_as_path,
    plan_path,
};
use crate::plc::PlcMode;
use crate::robot::Motion;
use crate::wire::{MoveId, MoveReport, SectionReport};

/// How long an order at rest waits for the status block it is built from
/// ([`RobotHandle::read_afresh_at_rest`]): the worker reads one at once when asked, so only a
/// link that fails takes this long.
const PATH_READ_LIMIT: Duration = Duration::from_secs(5);

/// A blended path whose plan chains a part behind one shorter than this, s, runs with its
/// corners stops where it was given that choice ([`RobotHandle::submit_paths_or_stopped`]): a
/// start behind a part takes about 0.15 s over a serial link at 115200 baud with a small part's
/// tables (0.19 s with the pace check's margin), more on a slower one.
pub(crate) const SHORTEST_BLENDED_PART_S: f64 = 0.25;

/// Where the next order begins: where the last one queued or running ends, else where the PLC
/// last said the robot is (`None`: no counts read yet).
struct Start {
    counts: Option<[i64; JOINTS]>,
    /// Whether it is behind a move queued or running (then `counts` is that move's end).
    behind: bool,
}

impl Start {
    /// `checked` anchored here when it is behind a move (a jog then adds to where that move
    /// ends); else as it is.
    fn anchor(&self, checked: CheckedOrder, robot: &crate::robot::Robot) -> CheckedOrder {
        match (self.behind, self.counts) {
            (true, Some(end)) => checked.anchored_at(robot, end),
            _ => checked,
        }
    }

    /// Whether an order begun here and planned to end at `end` moves the robot (as far as it
    /// can be told: unknown counts or end, it is taken to).
    fn moves_to(&self, end: Option<[i64; JOINTS]>) -> bool {
        self.counts
            .zip(end)
            .is_none_or(|(from, end)| from.iter().zip(&end).any(|(f, e)| (e - f).abs() > 1))
    }
}

impl RobotHandle {
    /// Checks an order, refuses it at once if the robot cannot take a move now (link down, not
    /// homed, a fault), plans it from where the robot will be when its turn comes (refusing it,
    /// with nothing queued, if that fails), and queues it. A jog (`by`) behind a queued or running
    /// move is anchored here, where that move is planned to end; with none it is anchored to the
    /// PLC's counts when it begins. A `position` is looked up here: a later change of it does
    /// not move this order.
    ///
    /// Returns the id of the move's last start: the move has ended when it has (see
    /// [`RobotHandle::submit_starts`]).
    pub async fn submit(&self, order: MoveOrder) -> Result<MoveId, SubmitError> {
        let ids = self.submit_starts(order).await?;
        Ok(ids[ids.len() - 1])
    }

    /// [`RobotHandle::submit`], returning the id of every start the move runs as, in order. A
    /// line on which a joint reverses while another moves is queued as the starts
    /// of a path of that one line, cut at the reversal and chained at speed
    /// ([`crate::plan::plan_line`]); any other order is one start.
    pub async fn submit_starts(&self, order: MoveOrder) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_behind(order, None, None)
            .await
            .map(|(ids, _)| ids)
    }

    /// [`RobotHandle::submit_starts`] of an order whose permit was resolved when it was checked
    /// (a cycle's move step): not parsed again.
    pub(crate) async fn submit_checked(
        &self,
        order: MoveOrder,
        permit: Permit,
    ) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_behind(order, None, Some(permit))
            .await
            .map(|(ids, _)| ids)
    }

    /// [`RobotHandle::submit`] of a move that is uploaded now and started only once `gate`
    /// opens (a cycle's move prepared during the wait before it). One start only: an order
    /// that would run as several is refused (the cycle then runs it after its wait). With its
    /// id, whether it moves: `false` when it is planned to end within a pulse of where it
    /// begins (it then ends with the move ahead of it, with no start of its own).
    /// Its permit was resolved when its cycle was checked.
    pub(crate) async fn submit_gated(
        &self,
        order: MoveOrder,
        permit: Permit,
        gate: &Gate,
    ) -> Result<(MoveId, bool), SubmitError> {
        let (ids, moves) = self.submit_behind(order, Some(gate), Some(permit)).await?;
        Ok((ids[0], moves))
    }

    /// The ids of `order`'s starts, and whether it moves the robot (as far as it can be told
    /// before its turn: no counts read yet, it is taken to). `permit`: its permit as resolved
    /// when it was checked (`None`: resolved here from its text).
    async fn submit_behind(
        &self,
        order: MoveOrder,
        gate: Option<&Gate>,
        permit: Option<Permit>,
    ) -> Result<(Vec<MoveId>, bool), SubmitError> {
        let checked = self.checked(&order, permit)?;
        self.can_move_now()?;
        let _turn = self.lane.lock().await;
        // Behind a move that is queued or running, an order starts where that one is planned
        // to end: a jog is anchored there now, so jogs queued back to back add up exactly. With
        // none, a jog stays relative and is anchored to the PLC's counts when it begins (the
        // counts read here may be a poll old); it is checked from them here.
        let start = self.start();
        let mut checked = start.anchor(checked, &self.robot);
        let mut end = None;
        if let Some(counts) = start.counts {
            match self.planned(&checked, counts).await {
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
                // One start only (a cycle then runs it after its wait, in parts).
                Err(e) if runs_in_parts(&e) && gate.is_some() => return Err(e.into()),
                Err(e) if runs_in_parts(&e) => {
                    // A path of the line: built from where it begins, read afresh.
                    let counts = self.path_start().await?;
                    return self.in_parts(&order, &checked, counts, e).await;
                }
                Err(e) => return Err(e.into()),
            }
        }
        let moves = start.moves_to(end);
        let id = self.shared.next_id();
        let report = MoveReport::new(id, &self.robot.name, order);
        self.enqueue(vec![(report, checked)], end, gate.cloned())
            .await
            .map(|ids| (ids, moves))
    }

    /// `order` (`checked`), refused with `e` from `counts` as one start, queued as a line in
    /// parts; refused with `e` when it is not a line to a pose.
    async fn in_parts(
        &self,
        order: &MoveOrder,
        checked: &CheckedOrder,
        counts: [i64; JOINTS],
        e: PlanError,
    ) -> Result<(Vec<MoveId>, bool), SubmitError> {
        match checked.pose_target(&self.robot.pose_of(&counts)) {
            Some(to) => self
                .submit_line_in_parts(order, checked, (counts, to), e)
                .await
                .map(|ids| (ids, true)),
            None => Err(e.into()),
        }
    }

    /// `order` checked, with `permit` (`None`: resolved here from its text).
    fn checked(
        &self,
        order: &MoveOrder,
        permit: Option<Permit>,
    ) -> Result<CheckedOrder, SubmitError> {
        let taught = self.taught_world()?;
        let mut checked = order.check_with(self.robot.motion, &self.limits(), &taught)?;
        checked.permit = match permit {
            Some(permit) => permit,
            None => self.permit(order.permit.as_deref())?,
        };
        Ok(checked)
    }

    /// Where the next order begins ([`Start`]).
    fn start(&self) -> Start {
        let snapshot = self.shared.snapshot();
        let behind = snapshot.state.current_move.is_some() || !snapshot.state.queued.is_empty();
        let counts = match snapshot.planned_end {
            Some(end) if behind => Some(end),
            _ => self.joints_of(snapshot.state.counts),
        };
        Start { counts, behind }
    }

    /// Where a path (or a line run as a path of its parts) begins, per joint: behind a move
    /// queued or running, where the last is planned to end; else where a status block read
    /// after this call says the robot is ([`RobotHandle::read_afresh_at_rest`]). A move is
    /// planned again from the PLC's counts when its turn comes, but a path's course is built
    /// here from where it begins, and its first section is refused at its turn when the robot
    /// is not there.
    async fn path_start(&self) -> Result<[i64; JOINTS], SubmitError> {
        self.read_afresh_at_rest().await?;
        self.start().counts.ok_or_else(|| SubmitError::NotNow {
            blocker: Blocker::LinkDown,
            detail: Some("no counts read from the PLC yet".to_owned()),
        })
    }

    /// With no move queued or running, waits for a status block read after this call (the
    /// worker woken to read one at once): what is built from where the robot is (a path's
    /// course, a cycle's check) must not take it from a block an idle poll old, which may not
    /// say where it is: the robot moved or its counts were preset since (at connect, the block
    /// the PLC wrote before its counts were set). Behind a move there is nothing to wait for:
    /// the next order begins where that one is planned to end.
    ///
    /// # Errors
    /// [`SubmitError::NotNow`] when the link is lost or no block comes within
    /// [`PATH_READ_LIMIT`]; [`SubmitError::ShuttingDown`] once the worker is gone.
    pub(crate) async fn read_afresh_at_rest(&self) -> Result<(), SubmitError> {
        if self.start().behind {
            return Ok(());
        }
        let no_read = |detail: String| SubmitError::NotNow {
            blocker: Blocker::LinkDown,
            detail: Some(detail),
        };
        let mut reads = self.shared.reads();
        self.shared.read_soon.notify_one();
        match tokio::time::timeout(PATH_READ_LIMIT, reads.next()).await {
            Ok(Ok(())) if self.shared.snapshot().read_at.is_some() => Ok(()),
            Ok(Ok(())) => Err(no_read(
                "the link was lost reading where the robot is".to_owned(),
            )),
            Ok(Err(_)) => Err(SubmitError::ShuttingDown),
            Err(_) => Err(no_read(format!(
                "no status block read from the PLC within {} s",
                PATH_READ_LIMIT.as_secs()
            ))),
        }
    }

    /// `checked` planned from `counts`, off the async runtime.
    async fn planned(
        &self,
        checked: &CheckedOrder,
        counts: [i64; JOINTS],
    ) -> Result<Plan, PlanError> {
        let (robot, checked) = (Arc::clone(&self.robot), checked.clone());
        off_runtime(move || plan_order(&robot, &checked, counts)).await
    }

    /// Gives one order's starts to the worker, whole or not at all: refused with nothing queued
    /// when the queue would pass [`MAX_QUEUED_STARTS`](crate::daemon::MAX_QUEUED_STARTS) or the
    /// worker is gone. `end`: where the last is planned to end, for the next order; `gate`: what
    /// the first start waits for once uploaded (a cycle's move or path prepared ahead).
    async fn enqueue(
        &self,
        starts: Vec<(MoveReport, CheckedOrder)>,
        end: Option<[i64; JOINTS]>,
        gate: Option<Gate>,
    ) -> Result<Vec<MoveId>, SubmitError> {
        let (reply, answer) = tokio::sync::oneshot::channel();
        let batch = Batch {
            starts,
            end,
            gate,
            epoch: self.epoch,
            reply,
        };
        self.to
            .requests
            .send(Request::Moves(batch))
            .map_err(|_| SubmitError::ShuttingDown)?;
        answer.await.map_err(|_| SubmitError::ShuttingDown)?
    }

    /// A line order from `counts` to `to` that one start cannot run (`one_start`: a joint's
    /// later F174 segment, or tables too big for their areas), planned as a path of that one
    /// line and queued as its starts, chained at speed: their ids, in order. Each start's
    /// report is the order with its target at the pose where that start ends.
    async fn submit_line_in_parts(
        &self,
        order: &MoveOrder,
        checked: &CheckedOrder,
        (counts, to): ([i64; JOINTS], Pose),
        one_start: PlanError,
    ) -> Result<Vec<MoveId>, SubmitError> {
        let req = line_as_path(&MoveRequest {
            from: Origin::Counts(counts),
            to,
            motion: checked.motion,
        });
        let path_accel_mm_s2 = req.path_accel_mm_s2;
        let planned = match self.planned_path(req).await {
            Ok(planned) => planned,
            Err(parts) if one_start.too_big() => return Err(one_start.no_parts(parts).into()),
            Err(parts) => return Err(parts.into()),
        };
        let (motion, permit) = (checked.motion, checked.permit);
        self.queue_sections(planned, path_accel_mm_s2, motion, permit, |end| {
            order.ending_at(end)
        })
        .await
    }

    /// `req` planned off the async runtime.
    async fn planned_path(&self, req: PathRequest) -> Result<PathPlan, PlanError> {
        let robot = Arc::clone(&self.robot);
        off_runtime(move || plan_path(&robot, &req)).await
    }

    /// An order's `permit` resolved against the robot's signals and input words (none: no
    /// permit).
    fn permit(&self, text: Option<&str>) -> Result<Permit, SubmitError> {
        let Some(text) = text else {
            return Ok(Permit::NONE);
        };
        let live = self.live.get();
        let names = crate::order::permit::PermitNames {
            signals: &live.cell.signals,
            inputs: &self.inputs,
        };
        crate::order::permit::resolve(text, names)
            .map_err(|e| crate::order::permit_refused(&e).into())
    }

    /// Refuses at once when the robot cannot take a move now (link down, not homed, a fault).
    fn can_move_now(&self) -> Result<(), SubmitError> {
        if let Some(why) = self.untrusted() {
            return Err(SubmitError::Untrusted { why });
        }
        if self.face_holds_motion() {
            return Err(SubmitError::MoveEnableOff);
        }
        let snapshot = self.shared.snapshot();
        let Some(blocker) = snapshot.refusal else {
            return Ok(());
        };
        let detail = match blocker {
            Blocker::LinkDown => snapshot.state.link.error.clone(),
            Blocker::Stalled if snapshot.state.plc_mode == Some(PlcMode::Prog) => {
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
    pub async fn submit_path(&self, order: &PathOrder) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_paths_with(std::slice::from_ref(order), &[], None, None)
            .await
    }

    /// [`RobotHandle::submit_path`] of a path whose permit was resolved when it was checked (a
    /// cycle's path step): not parsed again.
    pub(crate) async fn submit_checked_path(
        &self,
        order: &PathOrder,
        permit: Permit,
    ) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_paths_with(std::slice::from_ref(order), &[], Some(permit), None)
            .await
    }

    /// [`RobotHandle::submit_checked_path`] of a path prepared ahead (a cycle's path op, or
    /// its run of blended moves, prepared during the steps before it): planned as any path
    /// from where the robot will be, its first start uploaded and held until `gate` opens
    /// (started then from rest, as a move prepared ahead is), every start after it queued
    /// behind it as the path's own (the parts chained at speed preloaded around the first as
    /// for a path from rest). All or nothing: refused, nothing is queued. Once `gate` shuts
    /// before the first start, every start of it ends cancelled before its start.
    pub(crate) async fn submit_gated_path(
        &self,
        order: &PathOrder,
        permit: Permit,
        gate: &Gate,
    ) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_paths_with(std::slice::from_ref(order), &[], Some(permit), Some(gate))
            .await
    }

    /// Checks paths that run one after another (a pallet's way into a slot, cut where its
    /// speed changes), plans each from where the one before it ends (the first from where the
    /// robot will be), refusing them all if any cannot be planned; then queues every section of
    /// every path, in order, at once. Returns the sections' move ids.
    pub async fn submit_paths(&self, orders: &[PathOrder]) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_paths_with(orders, &[], None, None).await
    }

    /// [`RobotHandle::submit_paths`] of paths that blend a corner, each (`orders[k]`) with
    /// the same path with its corners stops (`stopped[k]`, where it blends one): a blended
    /// path whose plan would chain a part behind one shorter than 0.25 s is planned and run
    /// stopped instead (said in the log): the pace check would refuse it at its turn on a
    /// serial link, where the stopped one runs.
    pub async fn submit_paths_or_stopped(
        &self,
        orders: &[PathOrder],
        stopped: &[Option<PathOrder>],
    ) -> Result<Vec<MoveId>, SubmitError> {
        self.submit_paths_with(orders, stopped, None, None).await
    }

    /// [`RobotHandle::submit_paths`], each path or its `stopped` one
    /// ([`Self::submit_paths_or_stopped`]), every path under `permit` when it was resolved at
    /// a check (`None`: each path's own, from its text); the first start held behind `gate`
    /// once uploaded, if there is one.
    async fn submit_paths_with(
        &self,
        orders: &[PathOrder],
        stopped: &[Option<PathOrder>],
        permit: Option<Permit>,
        gate: Option<&Gate>,
    ) -> Result<Vec<MoveId>, SubmitError> {
        // Every field is checked before the robot's state: a bad order is a bad order.
        let limits = self.limits();
        let mut permits = Vec::with_capacity(orders.len());
        for stopped in stopped.iter().flatten() {
            stopped.check(&self.robot, &limits)?;
        }
        for order in orders {
            order.check(&self.robot, &limits)?;
            permits.push(match permit {
                Some(permit) => permit,
                None => self.permit(order.permit.as_deref())?,
            });
        }
        self.can_move_now()?;
        let _turn = self.lane.lock().await;
        let mut counts = self.path_start().await?;
        let taught = self.taught_world()?;
        let lookup = |name: &str| {
            taught.get(name).map(|p| {
                let [x, y, z, a] = p.pose;
                Pose::from_mm_deg(x, y, z, a)
            })
        };
        let mut starts = Vec::new();
        let mut end = None;
        for (k, (order, permit)) in orders.iter().zip(permits).enumerate() {
            let instead = stopped.get(k).and_then(Option::as_ref);
            let (order, planned, (path_accel_mm_s2, motion)) = self
                .plan_or_stopped((k, order, instead), counts, &limits, &lookup)
                .await?;
            if let Some(last) = planned.sections.last() {
                counts = last.end_counts();
                end = Some(counts);
            }
            let with = (path_accel_mm_s2, motion, permit);
            starts.extend(self.section_starts(planned, with, |e| order.section_report(e)));
        }
        self.enqueue(starts, end, gate.cloned()).await
    }

    /// Path `k`, `order`, planned from `counts`; or `instead` (the same path, its corners
    /// stops) where given and the blended plan would chain a part behind one shorter than
    /// [`SHORTEST_BLENDED_PART_S`]: the order planned, its plan, its path acceleration and
    /// motion.
    async fn plan_or_stopped<'o>(
        &self,
        (k, order, instead): (usize, &'o PathOrder, Option<&'o PathOrder>),
        counts: [i64; JOINTS],
        limits: &crate::order::OrderLimits,
        lookup: &(dyn Fn(&str) -> Option<Pose> + Sync),
    ) -> Result<(&'o PathOrder, PathPlan, (f64, Motion)), SubmitError> {
        let req = order.request(&self.robot, limits, counts, lookup)?;
        let with = (req.path_accel_mm_s2, req.motion);
        let planned = self.planned_path(req).await?;
        let short_s = shortest_chained_behind(&planned);
        let Some(instead) =
            instead.filter(|_| short_s.is_some_and(|s| s < SHORTEST_BLENDED_PART_S))
        else {
            return Ok((order, planned, with));
        };
        tracing::info!(robot = %self.robot.name, path = k + 1, short_s, "a blended path would chain a part behind one too short for a serial link: it runs with its corners stops");
        let req = instead.request(&self.robot, limits, counts, lookup)?;
        let with = (req.path_accel_mm_s2, req.motion);
        Ok((instead, self.planned_path(req).await?, with))
    }

    /// Queues every start of `planned`, one move each, in order: their ids. `report` gives the
    /// order a start's report shows, from the pose where that start ends.
    async fn queue_sections(
        &self,
        planned: PathPlan,
        path_accel_mm_s2: f64,
        motion: Motion,
        permit: Permit,
        report: impl Fn(&Pose) -> MoveOrder,
    ) -> Result<Vec<MoveId>, SubmitError> {
        let end = planned.sections.last().map(SectionPlan::end_counts);
        let starts = self.section_starts(planned, (path_accel_mm_s2, motion, permit), report);
        self.enqueue(starts, end, None).await
    }

    /// Every start of `planned` as the worker takes it, with its report, in order.
    fn section_starts(
        &self,
        planned: PathPlan,
        (path_accel_mm_s2, motion, permit): (f64, Motion, Permit),
        report: impl Fn(&Pose) -> MoveOrder,
    ) -> Vec<(MoveReport, CheckedOrder)> {
        let of = planned.sections.len();
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
        starts
    }
}

/// The shortest part of `planned` that another part is chained behind, s (`None`: no section
/// is cut into parts).
fn shortest_chained_behind(planned: &PathPlan) -> Option<f64> {
    planned
        .sections
        .iter()
        .filter_map(|s| s.starts.split_last().map(|(_, behind)| behind))
        .flatten()
        .map(crate::plan::Plan::duration_s)
        .reduce(f64::min)
}

/// Whether a line order one start refused runs as a path of that line cut into starts chained
/// at speed: a joint's channel would need a later F174 segment, or its tables are too big for
/// their areas.
fn runs_in_parts(e: &PlanError) -> bool {
    matches!(e, PlanError::LaterSegment { .. }) || e.too_big()
}

/// Runs `plan` on the blocking pool: planning takes milliseconds of CPU, which an async task
/// must not hold its thread for.
async fn off_runtime<T: Send + 'static>(
    plan: impl FnOnce() -> Result<T, PlanError> + Send + 'static,
) -> Result<T, PlanError> {
    tokio::task::spawn_blocking(plan)
        .await
        .unwrap_or_else(|e| std::panic::resume_unwind(e.into_panic()))
}
