//! One move through the contract: plan, upload, start; then following it by polling the status
//! block until the PLC says it is done, stopped or faulted.

use std::time::Duration;

use tokio::time::Instant;

use super::{Active, Worker, link_broken};
use crate::contract::State;
use crate::daemon::order::CheckedOrder;
use crate::daemon::report::{MoveId, Predicted, Stage};
use crate::kinematics::JOINTS;
use crate::plan::{MoveRequest, Origin, Plan, plan_move};
use crate::plc::contract::{ContractError, Status};
use crate::plc::{Plc, PlcMode};
use crate::robot::Robot;

/// Per-channel counts from per-joint ones.
fn by_channel(robot: &Robot, joints: [i64; JOINTS]) -> [i64; 4] {
    let mut out = [0; 4];
    for (j, joint) in robot.joints.iter().enumerate() {
        out[usize::from(joint.channel)] = joints[j];
    }
    out
}

/// Per-joint counts from the status block's per-channel ones.
fn by_joint(robot: &Robot, channels: [i64; 4]) -> [i64; JOINTS] {
    std::array::from_fn(|j| channels[usize::from(robot.joints[j].channel)])
}

/// Plans `order` for `robot` from `counts` (per joint).
pub(crate) fn plan_order(
    robot: &Robot,
    order: &CheckedOrder,
    counts: [i64; JOINTS],
) -> Result<Plan, crate::plan::PlanError> {
    let from = robot.pose_of(&counts);
    let to = if order.a_given {
        order.to
    } else {
        crate::geometry::Pose {
            a_rad: from.a_rad,
            ..order.to
        }
    };
    plan_move(
        robot,
        &MoveRequest {
            from: Origin::Counts(counts),
            to,
            motion: order.motion,
            seed_exact: false,
        },
    )
}

impl Worker {
    /// Plans move `id` from `chain_from` (the running move's target, per channel) or from the
    /// PLC's counts, uploads it into the idle bank and starts it.
    pub(super) async fn begin(
        &mut self,
        id: MoveId,
        order: CheckedOrder,
        chain_from: Option<[i64; 4]>,
    ) -> Result<(), ContractError> {
        let link = self.link.as_mut().expect("connected");
        let status = match link.check_alive().await {
            Ok(s) => s,
            Err(e) => return self.fail(id, e),
        };
        let counts = by_joint(
            &self.robot,
            chain_from.unwrap_or(status.block.elapsed.map(i64::from)),
        );
        let plan = match plan_order(&self.robot, &order, counts) {
            Ok(p) => p,
            Err(e) => {
                self.finish(id, Stage::Failed, Some(super::describe(&e)), None);
                return Ok(());
            }
        };
        let tables = plan
            .valid_tables(&self.robot)
            .expect("plan_move returns valid tables");
        let (seq, bank) = (self.next_seq, self.next_bank);
        let target = by_channel(&self.robot, plan.end_counts());
        self.record_plan(
            id,
            &plan,
            seq,
            bank,
            by_channel(&self.robot, counts),
            target,
        );
        let t0 = Instant::now();
        let link = self.link.as_mut().expect("connected");
        let verified = match link.upload(bank, seq, &tables).await {
            Ok(v) => v,
            Err(e) => return self.fail(id, e),
        };
        let upload_s = t0.elapsed().as_secs_f64();
        if let Err(e) = link.start(verified).await {
            return self.fail(id, e);
        }
        self.next_seq = seq.wrapping_add(1).max(1);
        self.next_bank = 1 - bank;
        self.issued.push_back(seq);
        if self.issued.len() > 32 {
            self.issued.pop_front();
        }
        let stage = if chain_from.is_some() {
            Stage::Waiting
        } else {
            Stage::Running
        };
        self.shared.moves(|m| {
            m.update(id, |r| {
                r.stage = stage;
                r.upload_s = Some(upload_s);
            });
        });
        let active = Active {
            id,
            seq,
            target: Some(target),
            duration_s: plan.profile.duration_s(),
            accepted: false,
            started: Instant::now(),
        };
        if chain_from.is_some() {
            self.waiting = Some(active);
        } else {
            self.current = Some(active);
            self.shared.state(|s| {
                s.current_move = Some(id);
                s.queued.retain(|q| *q != id);
            });
        }
        tracing::info!(robot = %self.robot.name, id, seq, bank, upload_s, "move started");
        Ok(())
    }

    fn record_plan(
        &self,
        id: MoveId,
        plan: &Plan,
        seq: u16,
        bank: u16,
        start: [i64; 4],
        target: [i64; 4],
    ) {
        let predicted = Predicted {
            rows: plan.figures.rows,
            words: plan.figures.words,
            duration_s: plan.profile.duration_s(),
            path_deviation_mm: plan.figures.path_deviation_mm,
            tracking_error_mm: plan.figures.tracking_error_mm,
        };
        self.shared.moves(|m| {
            m.update(id, |r| {
                r.stage = Stage::Uploading;
                r.seq = Some(seq);
                r.bank = Some(bank);
                r.start_counts = Some(start);
                r.target_counts = Some(target);
                r.predicted = Some(predicted);
            });
        });
    }

    /// Ends move `id` as failed by `e`; a link failure goes on up (the link is reopened).
    fn fail(&mut self, id: MoveId, e: ContractError) -> Result<(), ContractError> {
        let stage = if matches!(e, ContractError::Aborted) {
            Stage::Stopped
        } else {
            Stage::Failed
        };
        self.finish(id, stage, Some(super::describe(&e)), None);
        tracing::warn!(robot = %self.robot.name, id, error = %e, "move did not start");
        if link_broken(&e) { Err(e) } else { Ok(()) }
    }

    /// Reads the status block: the robot's state, and the fate of the moves in flight.
    pub(super) async fn poll(&mut self) -> Result<(), ContractError> {
        let link = self.link.as_mut().expect("connected");
        let status = match link.status().await {
            Ok(s) => s,
            Err(e) if link_broken(&e) => return Err(e),
            Err(e) => {
                self.note_error(&e);
                return Ok(());
            }
        };
        let mode = if self.current.is_none() {
            link.plc().mode().await.ok()
        } else {
            None
        };
        let heartbeat_age = link.heartbeat().map(|(_, at)| at.elapsed());
        self.note_status(&status, mode, heartbeat_age);
        self.follow(&status);
        Ok(())
    }

    fn note_status(&self, status: &Status, mode: Option<PlcMode>, heartbeat_age: Option<Duration>) {
        let counts = status.block.elapsed.map(i64::from);
        let pose = self
            .robot
            .pose_of(&by_joint(&self.robot, counts))
            .to_mm_deg();
        self.shared.state(|s| {
            s.counts = Some(counts);
            s.pose = Some(pose);
            s.state = Some(status.state.name());
            s.fault = (status.block.fault != 0).then_some(status.block.fault);
            s.heartbeat_age_ms = heartbeat_age.map(|d| d.as_millis() as u64);
            s.link.error = None;
            if let Some(m) = mode {
                s.plc_mode = Some(if m == PlcMode::Run { "run" } else { "prog" });
            }
        });
    }

    /// Moves the moves in flight along by what the status block says.
    fn follow(&mut self, status: &Status) {
        if self.current.is_none() {
            // A start this run did not write: the bank is unknown here and only reported.
            self.adopt(status, u16::MAX);
        }
        let Some(mut cur) = self.current else { return };
        let seq = status.block.seq;
        if self.waiting.is_some_and(|w| w.seq == seq) {
            // The PLC started the waiting move, which it does only once the current one is done;
            // its final counts were not read (the next move began from them).
            self.finish(cur.id, Stage::Done, None, None);
            self.promote(status);
            return;
        }
        if seq == cur.seq {
            cur.accepted = true;
            self.current = Some(cur);
            match status.state {
                State::Done => self.done(cur, status),
                State::Stopped | State::Fault => {
                    let why = format!(
                        "the PLC program ended it {} (fault {})",
                        status.state.name(),
                        status.block.fault
                    );
                    self.finish(
                        cur.id,
                        if status.state == State::Stopped {
                            Stage::Stopped
                        } else {
                            Stage::Failed
                        },
                        Some(why),
                        None,
                    );
                    self.current = None;
                    if let Some(w) = self.waiting.take() {
                        self.finish(
                            w.id,
                            Stage::Stopped,
                            Some("the move before it did not end".into()),
                            None,
                        );
                    }
                }
                State::Running | State::Idle => self.progress(cur, status),
            }
        } else if status.state == State::Fault {
            let why = format!("the PLC refused the start: fault {}", status.block.fault);
            self.finish(cur.id, Stage::Failed, Some(why), None);
            self.current = None;
        }
    }

    fn done(&mut self, cur: Active, status: &Status) {
        let counts = status.block.elapsed.map(i64::from);
        let error = cur
            .target
            .map(|t| std::array::from_fn(|c| counts[c] - t[c]));
        let motion_s = cur.started.elapsed().as_secs_f64();
        self.shared.moves(|m| {
            m.update(cur.id, |r| {
                r.motion_s = Some(motion_s);
                r.progress = 1.0;
                r.counts = Some(counts);
            });
        });
        self.finish(cur.id, Stage::Done, None, error);
        tracing::info!(robot = %self.robot.name, id = cur.id, ?error, "move done");
        self.current = None;
        if self.waiting.is_some() {
            self.promote(status);
        }
    }

    /// The waiting move becomes the current one.
    fn promote(&mut self, status: &Status) {
        let Some(mut w) = self.waiting.take() else {
            return;
        };
        w.accepted = status.block.seq == w.seq;
        w.started = Instant::now();
        self.current = Some(w);
        self.shared
            .moves(|m| m.update(w.id, |r| r.stage = Stage::Running));
        self.shared.state(|s| {
            s.current_move = Some(w.id);
            s.queued.retain(|q| *q != w.id);
        });
    }

    fn progress(&self, cur: Active, status: &Status) {
        let counts = status.block.elapsed.map(i64::from);
        let progress = if cur.duration_s > 0.0 {
            (cur.started.elapsed().as_secs_f64() / cur.duration_s).min(1.0)
        } else {
            0.0
        };
        self.shared.moves(|m| {
            m.update(cur.id, |r| {
                r.counts = Some(counts);
                r.progress = progress;
            });
        });
    }

    /// On shutdown: a start still waiting on the PLC is withdrawn (command back to 0), so no
    /// start is left pending; a running move runs on to its end under the PLC program.
    pub(super) async fn shut_down(&mut self) {
        if let (Some(w), Some(link)) = (self.waiting.take(), self.link.as_mut()) {
            let layout = link.settings().layout;
            let result = link.plc().write_words(layout.command_base, &[0]).await;
            tracing::info!(robot = %self.robot.name, id = w.id, ?result, "withdrew the waiting start");
            self.finish(
                w.id,
                Stage::Stopped,
                Some("withdrawn: the daemon shut down".into()),
                None,
            );
        }
        for (id, _) in std::mem::take(&mut self.queue) {
            self.finish(
                id,
                Stage::Stopped,
                Some("cancelled: the daemon shut down".into()),
                None,
            );
        }
    }
}
