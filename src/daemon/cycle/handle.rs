//! What a robot's handle does with its cycle: run one (checked whole first), stop, pause and
//! resume it, each a request to the cycle's owner ([`super::slot`]), and the metrics its
//! driver reports. The cycle's status is read from what the owner publishes
//! ([`RobotHandle::cycle`]).

use crate::daemon::RobotHandle;
use crate::daemon::request::{CycleError, CycleRequest};
use crate::wire::CycleStatus;

impl RobotHandle {
    /// Stops the robot's cycle at the end of its current step, or `now`.
    pub async fn stop_cycle(&self, now: bool) -> Result<CycleStatus, CycleError> {
        let status = self
            .ask_cycle(|reply| CycleRequest::Stop { now, reply })
            .await
            .unwrap_or(Err(CycleError::ShuttingDown))?;
        if now {
            // The runner stops the robot too; this makes it sure even if it is between steps.
            let _ = self.stop().await;
        }
        Ok(status)
    }

    /// Runs cycle program `program` (`count` cycles, or until stopped): loaded from the robot's
    /// programs directory and checked whole before anything moves.
    pub async fn run_cycle(
        &self,
        program: &str,
        count: Option<u64>,
    ) -> Result<CycleStatus, CycleError> {
        if count == Some(0) {
            return Err(CycleError::Program(
                "count = 0: run at least 1 cycle".to_owned(),
            ));
        }
        // Checked from where the robot is (its first blended corner, its reach): read afresh.
        // A link lost here leaves the check to what it knows.
        let _ = self.read_afresh_at_rest().await;
        let checked = self.check_program(program)?;
        for note in &checked.unchecked {
            tracing::info!(robot = %self.robot.name, program, "not checked before the run: {note}");
        }
        // The cycle runs with the signals and lists it was checked with, whatever a reload does.
        let handle = self.pinned();
        tracing::info!(robot = %self.robot.name, program, count, ops = checked.ops.len(), "cycle starts");
        let runner: crate::daemon::request::CycleRunner = Box::new(move |control, status| {
            Box::pin(super::run::run(handle, checked, count, control, status))
        });
        let status = Box::new(CycleStatus::starting(program, count));
        self.ask_cycle(|reply| CycleRequest::Run {
            status,
            runner,
            reply,
        })
        .await
        .unwrap_or(Err(CycleError::ShuttingDown))
    }

    /// Program `name` of the robot's programs directory, read and checked whole against the
    /// robot, its cell and its taught positions now.
    pub fn check_program(&self, name: &str) -> Result<crate::cycle::Checked, CycleError> {
        let live = self.live.get();
        let Some(dir) = &live.cell.programs else {
            return Err(CycleError::Program(format!(
                "robot {} has no cycle programs: set [robots.{}.cell] programs",
                self.robot.name, self.robot.name
            )));
        };
        let programs =
            crate::cycle::load::programs(dir).map_err(|e| CycleError::Program(e.to_string()))?;
        if !programs.docs.contains_key(name) && !programs.broken.contains_key(name) {
            return Err(CycleError::Program(format!(
                "program {name:?}: no such program; {} (in {}, which has no {name}.toml)",
                crate::cycle::check::there_are(&programs.docs, &programs.broken),
                dir.display()
            )));
        }
        for (program, why) in &programs.broken {
            // Said once each time a program is run; it keeps no other from running.
            tracing::warn!(robot = %self.robot.name, program, "a cycle program cannot be read: {why}");
        }
        let in_words = |e: crate::pallet::PalletError| {
            CycleError::Program(format!("robot {}: {e}", self.robot.name))
        };
        let taught = self.taught_world().map_err(in_words)?;
        let pallets = self.pallets_laid_out(&taught).map_err(in_words)?;
        let ctx = crate::cycle::Context {
            robot: &self.robot,
            taught: &taught,
            names: crate::cycle::Names {
                permit: crate::daemon::permit::PermitNames {
                    signals: &live.cell.signals,
                    inputs: &self.inputs,
                },
                access: &live.gateway.access,
            },
            programs: &programs.docs,
            broken: &programs.broken,
            require_wait_timeout: live.cell.require_wait_timeout,
            start: self.where_next_begins(),
            poses_known: true,
            pallets: &pallets,
        };
        crate::cycle::check(name, &ctx).map_err(|e| CycleError::Program(e.to_string()))
    }

    /// Where the robot will be when the next order begins, per joint: where the last order
    /// queued or running is planned to end, else where the PLC last said it is; `None` while its
    /// counts mean nothing (not homed, no link).
    pub(super) fn where_next_begins(&self) -> Option<[i64; crate::kinematics::JOINTS]> {
        let snapshot = self.shared.snapshot();
        let state = snapshot.state;
        if !state.homed || !state.link.connected {
            return None;
        }
        let ahead = state.current_move.is_some() || !state.queued.is_empty();
        match snapshot.planned_end {
            Some(end) if ahead => Some(end),
            _ if ahead => None,
            _ => self.counts_by_joint(),
        }
    }

    /// A cycle ended after `seconds` (metrics).
    pub(crate) fn cycle_done(&self, seconds: f64) {
        self.shared.metrics.cycle_done(seconds);
    }

    /// A cycle's wait step at `at` waited `seconds` (metrics).
    pub(crate) fn waited(&self, at: &crate::wire::StepAt, seconds: f64) {
        self.shared
            .metrics
            .cycle_waited(&at.program, at.step, seconds);
    }

    /// Pauses the robot's cycle at the end of its current step.
    pub async fn pause_cycle(&self) -> Result<CycleStatus, CycleError> {
        self.ask_cycle(CycleRequest::Pause)
            .await
            .unwrap_or(Err(CycleError::ShuttingDown))
    }

    /// Resumes a paused cycle, or a faulted one once its fault was cleared.
    pub async fn resume_cycle(&self) -> Result<CycleStatus, CycleError> {
        let incidents = self.incidents().count;
        self.ask_cycle(|reply| CycleRequest::Resume { incidents, reply })
            .await
            .unwrap_or(Err(CycleError::ShuttingDown))
    }

    /// Holds the robot's cycle from outside the PLC (`why`): the move running ends held and
    /// the cycle pauses (the caller stops the robot). Whether a cycle was under way.
    pub(crate) async fn hold_cycle(&self, why: &'static str) -> bool {
        self.ask_cycle(|reply| CycleRequest::Hold { why, reply })
            .await
            .unwrap_or(false)
    }
}
