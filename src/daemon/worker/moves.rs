//! One move from the queue to the PLC: its turn (`start_within`), planned from the counts the PLC
//! reports (or from the running move's targets, to chain behind it), uploaded into the bank that
//! is not running, checked once more against a fresh status block, and started with one write.

use std::sync::Arc;
use std::time::Duration;

use super::dispatch::{CYCLE_WENT_ON, Finish, Queued, StartMode, Turn, TurnDecision};
use super::pace::{LinkPace, Part};
use super::placement::{Placement, directories_left};
use super::preload::{self, Choice};
use super::prepared::{Held, prepared_watch};
use super::{Worker, describe, link_broken, now};
use crate::contract::machine::{Blocker, Phase, Planned, ProgressCurve};
use crate::contract::{CHANNELS, describe_unmet};
use crate::daemon::gate::{Gate, GateState};
use crate::order::plan_order;
use crate::order::{CheckedOrder, SectionOrder};
use crate::plan::{Plan, PlanError};
use crate::plc::exchange::{
    CommandWrite, ContractError, Preload, Upload, VerifiedBank, planned_bounds,
};
use crate::robot::Robot;
use crate::table::ValidTable;
use crate::wire::{MoveId, Predicted, Stage};

/// Slack added to a move's deadline on top of its planned time and upload.
const DEADLINE_MARGIN: Duration = Duration::from_secs(2);

impl Worker {
    /// Plans, uploads and starts `queued`; a move that cannot be started ends with the reason.
    pub(super) async fn begin(&mut self, queued: Queued) -> Result<(), ContractError> {
        let incidents = self.out.incidents();
        if queued.epoch.is_some_and(|e| e != incidents.count) {
            // A cycle's move asked for before the PLC restarted, stalled or was lost.
            let why = format!(
                "cancelled: {} since its cycle asked for it",
                incidents.last.unwrap_or_default()
            );
            tracing::warn!(robot = %self.robot.name, id = queued.id, "{why}");
            self.finish(queued.id, Stage::Cancelled, Some(why), None);
            self.cancel_queue("cancelled: the move before it did not start");
            return Ok(());
        }
        let Some(mut turn) = self.turn(queued).await? else {
            return Ok(());
        };
        let Some((plan, planned)) = self.plan_turn(&turn) else {
            return Ok(());
        };
        let id = turn.id;
        let tables = plan
            .valid_tables(&self.robot)
            .expect("plan_move returns valid tables");
        let gate = turn.mode.gate().cloned();
        let gate = gate.as_ref();
        if gate.is_some_and(|g| g.state() == GateState::Shut) {
            // Its cycle went another way while it was queued: nothing written.
            return self.unprepared(id, CYCLE_WENT_ON, None);
        }
        self.dispatch.machine.upload_begun();
        self.publish_phase();
        let began = tokio::time::Instant::now();
        let exchange = self.session()?.exchange;
        let from_rest = turn.mode.ahead().is_none();
        let own = turn.preload.take().filter(|p| p.bank() == planned.bank);
        let bank = match self
            .write_bank(&planned, &tables, own, from_rest, exchange, gate)
            .await
        {
            Ok(bank) => bank,
            Err(e) if gate.is_some() => {
                let why = if gate.is_some_and(|g| g.state() == GateState::Shut) {
                    CYCLE_WENT_ON.to_owned()
                } else {
                    describe(&e)
                };
                return self.unprepared(id, &why, link_broken(&e).then_some(e));
            }
            Err(e) => return self.not_started(id, e),
        };
        let upload_s = began.elapsed().as_secs_f64();
        self.shared.metrics.uploaded(upload_s);
        let prepared = gate.is_some();
        self.shared.moves(|m| {
            m.update(id, |r| {
                r.upload_s = Some(upload_s);
                if prepared {
                    r.stage = Stage::Prepared;
                }
            });
        });
        if let Some(gate) = gate {
            match self.hold_for(gate).await {
                Ok(()) => {}
                Err(Held::Cancelled(why)) => return self.unprepared(id, why, None),
                Err(Held::Link(e)) => {
                    let why = describe(&e);
                    return self.unprepared(id, &why, Some(e));
                }
            }
        }
        // A prepared move released on a status block read within a poll (the one that met
        // its wait) starts on it, as a move's turn is planned on one; else on a fresh read.
        let fresh = gate.is_some()
            && self.dispatch.machine.read_at().is_some_and(|at| {
                now().saturating_duration_since(at) < self.settings.poll_interval
            })
            && self.dispatch.machine.may_start(&planned, now()).is_ok();
        if !fresh && let Err(e) = self.until_it_may_start(&planned).await {
            return self.not_started(id, e);
        }
        if turn.order.begins_at_speed() && self.lost_its_chain(id, turn.mode.ahead().map(|c| c.seq))
        {
            return Ok(());
        }
        self.write_start(&turn, planned, bank, upload_s).await
    }

    /// Whether `queued` may begin now, and from where ([`Dispatcher::turn`]): on a fresh
    /// status block (the one just read, if read within a poll interval). Until then the order
    /// stays at the head of the queue; a part of a path that begins at speed with nothing
    /// running to chain behind fails.
    ///
    /// [`Dispatcher::turn`]: super::dispatch::Dispatcher::turn
    async fn turn(&mut self, queued: Queued) -> Result<Option<Turn>, ContractError> {
        let fresh =
            self.dispatch.machine.read_at().is_some_and(|at| {
                now().saturating_duration_since(at) < self.settings.poll_interval
            });
        if !fresh && let Err(e) = self.poll().await {
            self.dispatch.push_front(queued);
            return Err(e);
        }
        match self.dispatch.turn(queued, now()) {
            TurnDecision::Begin(turn) => Ok(Some(*turn)),
            TurnDecision::Wait => Ok(None),
            TurnDecision::PermitNotMet(id, blocker) => {
                self.not_started(id, ContractError::Blocked(blocker))?;
                Ok(None)
            }
            TurnDecision::NothingToChainBehind(id) => {
                self.fail_at_speed(id);
                Ok(None)
            }
        }
    }

    /// The plan of `turn` and its description for the contract; `None` when it ends here: it
    /// cannot be planned (failed, the queue behind it cancelled) or has nothing to start (within
    /// a pulse of where it begins).
    fn plan_turn(&mut self, turn: &Turn) -> Option<(Plan, Planned)> {
        let (id, from) = (turn.id, turn.from);
        let lead = turn.mode.ahead().map(|c| c.tag);
        let plan = match plan_order(&self.robot, &turn.order, self.by_joint(from.map(i64::from))) {
            Ok(plan) => plan,
            Err(PlanError::ZeroLength { .. } | PlanError::NoTravel { .. }) => {
                self.in_place(id, from, from, lead);
                return None;
            }
            Err(e) => {
                self.finish(id, Stage::Failed, Some(describe(&e)), None);
                self.cancel_queue("cancelled: the move before it could not be planned");
                return None;
            }
        };
        let planned = self.planned(id, &plan, turn);
        let targets = planned.targets.expect("a plan knows its targets");
        if (0..CHANNELS).all(|c| (targets[c] - from[c]).abs() <= 1) {
            // Nothing to upload or start: no sequence number, no bank, no upload stage.
            self.in_place(id, from, targets, lead);
            return None;
        }
        self.record_plan(id, &plan, &planned);
        Some((plan, planned))
    }

    /// Writes the start of `turn` (its bank uploaded and verified, `planned`) once; whatever
    /// became of the write, its sequence number is spent.
    async fn write_start(
        &mut self,
        turn: &Turn,
        planned: Planned,
        bank: VerifiedBank,
        upload_s: f64,
    ) -> Result<(), ContractError> {
        let id = turn.id;
        let written = self.link()?.start(&bank).await;
        // A start whose fate is not known yet must never share its seq with the next.
        self.dispatch.spent(planned.seq, planned.bank);
        let written = match written {
            Ok(written) => written,
            Err(e) => return self.not_started(id, e),
        };
        let permit = planned.permit;
        let confirmed = matches!(written, CommandWrite::Confirmed);
        let (seq, planned_bank) = (planned.seq, planned.bank);
        // Chained when the move it was planned behind still runs (a prepared move, held past
        // that one's end, starts from rest).
        let chain = match &turn.mode {
            StartMode::Chained(ahead) => Some(ahead),
            StartMode::FromRest | StartMode::Gated { .. } => None,
        }
        .filter(|_| self.dispatch.machine.uploading_behind().is_some());
        self.dispatch
            .machine
            .start_written(planned, now(), confirmed);
        self.dispatch.start_written(id, permit, bank);
        if chain.is_some() {
            self.shared
                .moves(|m| m.update(id, |r| r.stage = Stage::Waiting));
        }
        self.publish_phase();
        // Chained: how long after the move before was seen running this start was written, of
        // the time that move runs (the chain's slack, as the pace check estimates it).
        let behind_s = chain
            .and_then(|c| self.dispatch.started_at(c.tag))
            .map(|seen| now().saturating_duration_since(seen).as_secs_f64());
        let runs_s = chain.map(|c| c.duration.as_secs_f64());
        tracing::info!(robot = %self.robot.name, id, seq, bank = planned_bank, upload_s, confirmed, chained = chain.is_some(), behind_s, runs_s, "start written");
        match written {
            CommandWrite::Unconfirmed(e) if e.is_link_failure() => {
                // Whether it was taken is learnt from the status block once the link is back.
                Err(ContractError::Plc(e))
            }
            _ => Ok(()),
        }
    }

    /// The contract's first step once more, after the upload: the bank is started only once
    /// the heartbeat is seen moving, while the PLC takes it and every count is the plan's `from`
    /// (or it chains behind the start whose targets are its `from`). When two reads are needed
    /// for the heartbeat, the first is of its word alone.
    async fn until_it_may_start(&mut self, planned: &Planned) -> Result<(), ContractError> {
        loop {
            let Some(session) = self.conn.session.as_mut() else {
                return Err(ContractError::Blocked(Blocker::LinkDown));
            };
            let status = session
                .contract
                .proof_read(&mut self.dispatch.machine)
                .await?;
            self.read(status).await?;
            match self.dispatch.machine.may_start(planned, now()) {
                Ok(()) => return Ok(()),
                Err(Blocker::Unproven) => {
                    tokio::time::sleep(self.settings.scan_time / 2).await;
                }
                Err(blocker) => return Err(ContractError::Blocked(blocker)),
            }
        }
    }

    /// Writes `tables` and the command block of `planned` into its bank and reads them back;
    /// only the directories left and the block when its tables were preloaded into that bank
    /// (`own`). A start written while nothing runs (`from_rest`) first preloads the parts of a
    /// path that begin at speed behind it (`exchange`: how long a status read just took).
    async fn write_bank(
        &mut self,
        planned: &Planned,
        tables: &[ValidTable],
        own: Option<Preload>,
        from_rest: bool,
        exchange: Duration,
        gate: Option<&Gate>,
    ) -> Result<VerifiedBank, ContractError> {
        let own = if from_rest {
            // Nothing preloaded before outlives a start from rest: its section's parts are
            // preloaded afresh around it.
            self.dispatch.forget_preloads();
            self.preload_section(planned, tables, exchange).await?;
            None
        } else {
            own
        };
        let link = self.link()?;
        let upload = if let Some(preload) = own {
            link.begin_upload_preloaded(&planned.into(), tables, &preload)
        } else {
            link.begin_upload(&planned.into(), tables)
        };
        let bank = match upload {
            Ok(mut upload) => self.upload_watching(&mut upload, gate).await,
            Err(e) => Err(e),
        };
        // Written whole from the directory's end (or partly, when it failed), a bank may lie
        // over tables preloaded past its own, which no later start may rest on. Only a start
        // from rest, whose section's parts were placed around it, keeps them.
        if !matches!(&bank, Ok(bank) if bank.on_preload || from_rest) {
            self.dispatch.forget_preloads();
        }
        bank
    }

    /// Makes `upload`'s exchanges. Between two, while a start the PLC was given may run, the
    /// status block is read whenever the last read is a heartbeat timeout old: the running move
    /// stays watched (its heartbeat, counts, state, progress) through an upload that lasts
    /// seconds on a slow line, and is stopped as it would be between uploads. A prepared move
    /// (`gate`) is uploaded behind a cycle's move, whose end (done, or held by its permit) the
    /// cycle goes on from: its status block is read more often, at most a sixth of the link's
    /// time ([`prepared_watch`]). An upload the machine gave up on meanwhile (the PLC stalled or
    /// restarted) ends there, as does the upload of a prepared move whose gate shut.
    async fn upload_watching(
        &mut self,
        upload: &mut Upload,
        gate: Option<&Gate>,
    ) -> Result<VerifiedBank, ContractError> {
        let timeout = self.dispatch.machine.settings().heartbeat_timeout;
        let every = match gate {
            Some(_) => {
                prepared_watch(self.session()?.exchange, self.settings.poll_interval).min(timeout)
            }
            None => timeout,
        };
        loop {
            if gate.is_some_and(|g| g.state() == GateState::Shut) {
                return Err(ContractError::Aborted);
            }
            let due = self
                .dispatch
                .machine
                .read_at()
                .is_none_or(|at| now().saturating_duration_since(at) >= every);
            if due && !self.dispatch.machine.given().is_empty() {
                self.poll().await?;
                if !matches!(self.dispatch.machine.phase(), Phase::Uploading { .. }) {
                    // Stalled, restarted, ...: this bank will not be started; the link is
                    // needed for what comes next.
                    let why = self
                        .dispatch
                        .machine
                        .blocker(now())
                        .unwrap_or(Blocker::Full);
                    return Err(ContractError::Blocked(why));
                }
            }
            if let Some(bank) = self.link()?.upload_step(upload).await? {
                return Ok(bank);
            }
        }
    }

    /// Before a start written while nothing runs (`first`, its `tables`): when the moves queued
    /// behind it are the parts of a path that begin at speed, their tables are written and read
    /// back now, in the banks they will start from (alternating, the second part in the bank
    /// `first` does not use), each channel's after the tables placed in its area before it
    /// (after `first`'s own). The second part always is; each later one only while, at the
    /// pace the link has shown (`exchange`, a status read; a one-word read; the preloads so
    /// far), the parts not preloaded could not all be written whole while the part before each
    /// runs, and only as long as the areas hold them. A preloaded part's start is then left
    /// with its directories (past the first in each bank) and its command block to write.
    /// Nothing runs from either bank: `first` is written while nothing runs, and every
    /// preloaded word lies outside its tables. A part that cannot be planned is left to fail
    /// at its own turn. Then every part of the section must be ready to start before the part
    /// ahead of it ends: if not, this start is refused before anything moves ([`LinkPace::check`]).
    async fn preload_section(
        &mut self,
        first: &Planned,
        tables: &[ValidTable],
        exchange: Duration,
    ) -> Result<(), ContractError> {
        // The parts of a path are sent together: take in any not queued yet.
        self.take_pending_requests();
        let Some(section) = self
            .dispatch
            .queue()
            .front()
            .filter(|q| q.order.begins_at_speed())
            .and_then(|q| q.order.section().cloned())
        else {
            return Ok(());
        };
        let behind: Vec<(MoveId, CheckedOrder)> = self
            .dispatch
            .queue()
            .iter()
            .take_while(|q| {
                q.order.begins_at_speed()
                    && q.order.section().is_some_and(|s| Arc::ptr_eq(s, &section))
            })
            .map(|q| (q.id, q.order.clone()))
            .collect();
        let area_words = usize::from(self.link()?.settings().layout.area_words);
        let mut placement = Placement::new(first.bank, tables, area_words);
        let mut ends_on = first.targets.expect("a plan knows its targets");
        let mut bank = 1 - first.bank;
        let mut pace: Option<LinkPace> = None;
        let mut directories = Vec::new();
        for (id, order) in behind {
            let Ok(plan) = plan_order(&self.robot, &order, self.by_joint(ends_on.map(i64::from)))
            else {
                break;
            };
            let Some(tables) = plan.valid_tables(&self.robot) else {
                break;
            };
            let so_far = parts(&section, &directories);
            let base = match preload::choose(pace.as_ref(), &so_far, &mut placement, bank, &tables)?
            {
                Choice::Preload(base) => base,
                Choice::Enough => break,
                Choice::Full => {
                    tracing::info!(robot = %self.robot.name, id, bank, "part chained at speed not preloaded: its bank's areas are full");
                    break;
                }
            };
            let (preloaded, took) = self.preload(bank, base, &tables).await?;
            tracing::info!(robot = %self.robot.name, id, bank, words = preloaded.words(), preload_s = took.as_secs_f64(), "part chained at speed preloaded");
            let pace = match &mut pace {
                Some(pace) => pace,
                None => pace.insert(self.pace(exchange, !first.permit.is_none()).await?),
            };
            pace.preload += took;
            pace.preload_words += preloaded.words();
            directories.push(directories_left(&base, &tables));
            self.dispatch.preloaded(id, preloaded);
            ends_on = end_counts(&plan, ends_on);
            bank = 1 - bank;
        }
        let Some(pace) = pace else {
            return Ok(());
        };
        tracing::info!(robot = %self.robot.name, parts = directories.len(), words = pace.preload_words, preload_s = pace.preload.as_secs_f64(), status_s = exchange.as_secs_f64(), word_s = pace.word.as_secs_f64(), "parts chained at speed preloaded");
        pace.check(&parts(&section, &directories))
    }

    /// Writes and reads back `tables` into `bank` at `base` (per channel): what was written, and
    /// how long it took.
    async fn preload(
        &mut self,
        bank: u16,
        base: [usize; CHANNELS],
        tables: &[ValidTable],
    ) -> Result<(crate::plc::exchange::Preload, Duration), ContractError> {
        let began = tokio::time::Instant::now();
        let preloaded = self.link()?.preload(bank, base, tables).await?;
        Ok((preloaded, began.elapsed()))
    }

    /// The link's pace before any preload: the status read `exchange` just took and a one-word
    /// read made now.
    async fn pace(&mut self, exchange: Duration, permit: bool) -> Result<LinkPace, ContractError> {
        Ok(LinkPace {
            permit_write: permit,
            status: exchange,
            word: self.link()?.one_word_exchange().await?,
            preload: Duration::ZERO,
            preload_words: 0,
            read_back: self.settings.verify,
            watch_every: self.dispatch.machine.settings().heartbeat_timeout,
        })
    }

    /// Whether the start `running` (its seq) that move `id` was to chain behind ended while `id`
    /// was uploaded: started now, it would start at speed from rest, so it fails instead.
    fn lost_its_chain(&mut self, id: MoveId, running: Option<u16>) -> bool {
        if self.dispatch.machine.uploading_behind().map(|c| c.seq) == running {
            return false;
        }
        self.dispatch.machine.upload_ended();
        self.publish_phase();
        self.fail_at_speed(id);
        true
    }

    /// A part of a path section that begins at speed found the part before it no longer
    /// running: it is not started (from rest it would start at speed), and the queue behind it
    /// is cancelled.
    fn fail_at_speed(&mut self, id: MoveId) {
        self.finish(
            id,
            Stage::Failed,
            Some(
                "this part of the path begins at speed and must wait behind the part before it \
                 while that one runs, but that one had ended (the robot stopped there at speed): \
                 its upload took longer than the part before it runs; use a faster link, or \
                 stop at a waypoint"
                    .to_owned(),
            ),
            None,
        );
        self.cancel_queue("cancelled: a part of the path before it could not be chained");
    }

    /// The contract's description of a plan: its sequence number, bank, counts and envelope.
    fn planned(&self, id: MoveId, plan: &Plan, turn: &Turn) -> Planned {
        let from = turn.from;
        let (envelope, targets) = planned_bounds(from, &channel_tables(plan));
        Planned {
            tag: id,
            seq: self.dispatch.next_seq(),
            bank: self
                .dispatch
                .next_bank(turn.mode.ahead().map(|ahead| ahead.bank)),
            from,
            targets: Some(targets),
            envelope,
            duration: Duration::from_secs_f64(plan.duration_s()),
            curve: progress_curve(&self.robot, plan, from).map(Arc::new),
            permit: turn.order.permit,
        }
    }

    fn record_plan(&self, id: MoveId, plan: &Plan, planned: &Planned) {
        let predicted = Predicted {
            rows: plan.figures.rows,
            words: plan.figures.words,
            duration_s: plan.duration_s(),
            path_deviation_mm: plan.figures.path_deviation_mm,
            tracking_error_mm: plan.figures.tracking_error_mm,
        };
        let watch = self.dispatch.machine.settings();
        // The longest the daemon can take to end it: its run limit, the grace a lost link gets.
        let limit = watch.run_limit(planned.duration) + watch.link_grace;
        self.shared.moves(|m| {
            m.update(id, |r| {
                r.stage = Stage::Uploading;
                r.seq = Some(planned.seq);
                r.bank = Some(planned.bank);
                r.start_counts = Some(planned.from.map(i64::from));
                r.target_counts = planned.targets.map(|t| t.map(i64::from));
                r.predicted = Some(predicted);
                r.deadline_s =
                    Some((limit + self.dispatch.start_within() + DEADLINE_MARGIN).as_secs_f64());
            });
        });
    }

    /// Ends move `id`, whose start was not written, by `e`; a link failure goes on up.
    fn not_started(&mut self, id: MoveId, e: ContractError) -> Result<(), ContractError> {
        self.dispatch.machine.upload_ended();
        self.publish_phase();
        let stage = if matches!(e, ContractError::Aborted) {
            Stage::Cancelled
        } else {
            Stage::Failed
        };
        let why = match &e {
            ContractError::Aborted => "cancelled by a stop request during its upload".to_owned(),
            ContractError::Blocked(Blocker::PermitNotMet { permit, inputs }) => format!(
                "not started: its permit does not hold: {}; nothing was written",
                describe_unmet(permit, inputs, &self.settings.layout.inputs)
            ),
            other => format!("not started: {}", describe(other)),
        };
        tracing::warn!(robot = %self.robot.name, id, "{why}");
        self.finish(id, stage, Some(why), None);
        self.cancel_queue("cancelled: the move before it did not start");
        if link_broken(&e) { Err(e) } else { Ok(()) }
    }

    /// Ends the head of the queue once it waited too long for its turn
    /// ([`Dispatcher::expire`]), and the rest behind it.
    ///
    /// [`Dispatcher::expire`]: super::dispatch::Dispatcher::expire
    pub(super) fn expire_queue(&mut self) {
        let ends = self.dispatch.expire(self.conn.session.is_some(), now());
        if let Some(head) = ends.first() {
            let why = head.error.as_deref().unwrap_or_default();
            tracing::warn!(robot = %self.robot.name, id = head.id, "{why}");
        }
        self.finish_all(ends);
    }

    /// Cancels every queued move (never given to the PLC).
    pub(super) fn cancel_queue(&mut self, why: &str) {
        let ends = self.dispatch.cancel_queue(why);
        self.finish_all(ends);
    }

    /// Ends the reports of `ends`, in order.
    pub(super) fn finish_all(&mut self, ends: Vec<Finish>) {
        for end in ends {
            self.finish(end.id, end.stage, end.error, end.final_error);
        }
    }

    pub(super) fn finish(
        &mut self,
        id: MoveId,
        stage: Stage,
        error: Option<String>,
        final_error: Option<[i64; CHANNELS]>,
    ) {
        self.end_followers(id, stage, error.as_deref());
        let mut ended = false;
        self.shared.moves(|m| {
            m.update(id, |r| {
                if !r.stage.is_final() {
                    r.stage = stage;
                    r.error = error;
                    r.final_error_pulses = final_error;
                    ended = true;
                }
            });
        });
        if ended {
            self.shared.metrics.move_ended(stage);
        }
        self.out.state(|s| {
            s.queued.retain(|q| *q != id);
            if s.current_move == Some(id) {
                s.current_move = None;
            }
        });
        if stage != Stage::Done {
            // Later orders are checked from where the robot really is, not from a target this
            // move will not reach.
            self.out.set_planned_end(None);
        }
    }
}

/// The parts of `section` (planned) as the pace check sees them: the first
/// `directories.len()` after its first preloaded, each with that many directories left for its
/// start, the rest written whole at their turns.
fn parts(section: &SectionOrder, directories: &[usize]) -> Vec<Part> {
    section
        .planned
        .get()
        .map(|starts| {
            starts
                .iter()
                .enumerate()
                .map(|(k, plan)| {
                    Part::of(
                        plan,
                        k.checked_sub(1).and_then(|k| directories.get(k).copied()),
                    )
                })
                .collect()
        })
        .unwrap_or_default()
}

/// The counts per channel where `plan`, started from `from`, ends.
fn end_counts(plan: &Plan, from: [i32; CHANNELS]) -> [i32; CHANNELS] {
    planned_bounds(from, &channel_tables(plan)).1
}

/// Each of `plan`'s tables with its pulse channel.
fn channel_tables(plan: &Plan) -> Vec<(usize, &[crate::table::Segment])> {
    plan.tables
        .iter()
        .map(|t| (usize::from(t.channel), t.segments.as_slice()))
        .collect()
}

/// The plan's counts per channel at each of its sample points over the start's own time (equally
/// spaced by the profile's period from the start's 0, the last at its end; a channel without a
/// joint stays at `from`), for the machine to follow the start's progress by its counts.
fn progress_curve(robot: &Robot, plan: &Plan, from: [i32; CHANNELS]) -> Option<ProgressCurve> {
    let period_s = plan.profile.period_s;
    let duration_s = plan.duration_s();
    let last = plan.samples.counts.len().saturating_sub(1);
    let points: Vec<(Duration, [i32; CHANNELS])> = plan
        .samples
        .counts
        .iter()
        .enumerate()
        .map(|(k, joints)| {
            // The last point is the end: a time-optimal profile's last period has its own length.
            let at_s = if k == last {
                duration_s
            } else {
                (k as f64 * period_s).min(duration_s)
            };
            let mut counts = from;
            for (joint, &count) in robot.joints.iter().zip(joints) {
                counts[usize::from(joint.channel)] =
                    count.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32;
            }
            (Duration::from_secs_f64(at_s.max(0.0)), counts)
        })
        .collect();
    ProgressCurve::new(&points)
}
