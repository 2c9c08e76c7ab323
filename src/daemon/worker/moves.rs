//! One move from the queue to the PLC: its turn (`start_within`), planned from the counts the PLC
//! reports (or from the running move's targets, to chain behind it), uploaded into the bank that
//! is not running, checked once more against a fresh status block, and started with one write.

use std::sync::Arc;
use std::time::Duration;

use super::dispatch::{Finish, Queued, StartMode, Turn, TurnDecision};
use super::pace::{LinkPace, Part};
use super::placement::{Placement, directories_left};
use super::preload::{self, Choice};
use super::{Worker, describe, link_broken, now};
use crate::contract::machine::{Blocker, Planned, ProgressCurve};
use crate::contract::{CHANNELS, describe_unmet};
use crate::order::plan_order;
use crate::order::{CheckedOrder, SectionOrder};
use crate::plan::{Plan, PlanError};
use crate::plc::exchange::{CommandWrite, ContractError, VerifiedBank, planned_bounds};
use crate::robot::Robot;
use crate::table::ValidTable;
use crate::wire::{EndReason, MoveId, Predicted, Stage};

/// Slack added to a move's deadline on top of its planned time and upload.
const DEADLINE_MARGIN: Duration = Duration::from_secs(2);

impl Worker {
    /// Whether `queued` may begin now, and from where ([`Dispatcher::turn`]): on a fresh
    /// status block (the one just read, if read within a poll interval). Until then the order
    /// stays at the head of the queue; a part of a path that begins at speed with nothing
    /// running to chain behind fails.
    ///
    /// [`Dispatcher::turn`]: super::dispatch::Dispatcher::turn
    pub(super) async fn turn(&mut self, queued: Queued) -> Result<Option<Turn>, ContractError> {
        if !self.dispatch.is_fresh(now())
            && let Err(e) = self.poll().await
        {
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
    pub(super) fn plan_turn(&mut self, turn: &Turn) -> Option<(Plan, Planned)> {
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
    pub(super) async fn write_start(
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
        self.log_start(id, (seq, planned_bank), upload_s, confirmed, chain);
        match written {
            CommandWrite::Unconfirmed(e) if e.is_link_failure() => {
                // Whether it was taken is learnt from the status block once the link is back.
                Err(ContractError::Plc(e))
            }
            _ => Ok(()),
        }
    }

    /// Says a start was written: chained (behind `chain`), how long after the move before was
    /// seen running, of the time that move runs (the chain's slack, as the pace check
    /// estimates it).
    fn log_start(
        &self,
        id: MoveId,
        (seq, bank): (u16, u16),
        upload_s: f64,
        confirmed: bool,
        chain: Option<&Planned>,
    ) {
        let behind_s = chain
            .and_then(|c| self.dispatch.started_at(c.tag))
            .map(|seen| now().saturating_duration_since(seen).as_secs_f64());
        let runs_s = chain.map(|c| c.duration.as_secs_f64());
        tracing::info!(robot = %self.robot.name, id, seq, bank, upload_s, confirmed, chained = chain.is_some(), behind_s, runs_s, "start written");
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
    pub(super) async fn preload_section(
        &mut self,
        first: &Planned,
        tables: &[ValidTable],
        exchange: Duration,
    ) -> Result<(), ContractError> {
        // The parts of a path are sent together: take in any not queued yet.
        self.take_pending_requests();
        let Some((section, behind)) = self.dispatch.section_behind() else {
            return Ok(());
        };
        let area_words = usize::from(self.link()?.settings().layout.area_words);
        let mut walk = Walk {
            placement: Placement::new(first.bank, tables, area_words),
            ends_on: first.targets.expect("a plan knows its targets"),
            bank: 1 - first.bank,
            pace: None,
            directories: Vec::new(),
            permit: !first.permit.is_none(),
            exchange,
        };
        for (id, order) in behind {
            if !self.preload_part(&mut walk, &section, id, &order).await? {
                break;
            }
        }
        let Walk {
            pace, directories, ..
        } = walk;
        let Some(pace) = pace else {
            return Ok(());
        };
        tracing::info!(robot = %self.robot.name, parts = directories.len(), words = pace.preload_words, preload_s = pace.preload.as_secs_f64(), status_s = exchange.as_secs_f64(), word_s = pace.word.as_secs_f64(), "parts chained at speed preloaded");
        self.session()?.pace = Some(pace);
        pace.check(&parts(&section, &directories))
    }

    /// Preloads part `id` (`order`) of `section` on `walk`, if [`preload::choose`] says so:
    /// whether the walk goes on to the next part.
    async fn preload_part(
        &mut self,
        walk: &mut Walk,
        section: &SectionOrder,
        id: MoveId,
        order: &CheckedOrder,
    ) -> Result<bool, ContractError> {
        let Some((plan, tables)) = self.plan_part(walk, order) else {
            return Ok(false);
        };
        let bank = walk.bank;
        let base = match walk.choose(section, &tables)? {
            Choice::Preload(base) => base,
            Choice::Enough => return Ok(false),
            Choice::Full => {
                tracing::info!(robot = %self.robot.name, id, bank, "part chained at speed not preloaded: its bank's areas are full");
                return Ok(false);
            }
        };
        let (preloaded, took) = match self.preloaded_ahead(id, bank, base, &tables) {
            Some(ahead) => ahead,
            None => self.preload(id, bank, base, &tables).await?,
        };
        let pace = match &mut walk.pace {
            Some(pace) => pace,
            None => walk
                .pace
                .insert(self.pace(walk.exchange, walk.permit).await?),
        };
        pace.preload += took;
        pace.preload_words += preloaded.words();
        walk.directories.push(directories_left(&base, &tables));
        self.dispatch.preloaded(id, preloaded, took);
        walk.ends_on = end_counts(&plan, walk.ends_on);
        walk.bank = 1 - bank;
        Ok(true)
    }

    /// A part's plan from where the part before it ends, and its tables: `None` when it
    /// cannot be planned (it is left to fail at its own turn).
    fn plan_part(&self, walk: &Walk, order: &CheckedOrder) -> Option<(Plan, Vec<ValidTable>)> {
        let from = self.by_joint(walk.ends_on.map(i64::from));
        let plan = plan_order(&self.robot, order, from).ok()?;
        let tables = plan.valid_tables(&self.robot)?;
        Some((plan, tables))
    }

    /// Part `id`'s preload made ahead of its first part's turn ([`Self::begin_ahead`]), and how
    /// long it took, when it is `tables` placed in `bank` at `base` word for word: nothing is
    /// written again.
    fn preloaded_ahead(
        &mut self,
        id: MoveId,
        bank: u16,
        base: [usize; CHANNELS],
        tables: &[ValidTable],
    ) -> Option<(crate::plc::exchange::Preload, Duration)> {
        let ahead = self.dispatch.preload_of(id)?;
        let link = &self.conn.session.as_ref()?.contract;
        link.preloaded_as(&ahead.tables, bank, base, tables)
            .then(|| (ahead.tables.clone(), ahead.took))
    }

    /// Writes and reads back part `id`'s `tables` into `bank` at `base` (per channel): what was
    /// written, and how long it took.
    async fn preload(
        &mut self,
        id: MoveId,
        bank: u16,
        base: [usize; CHANNELS],
        tables: &[ValidTable],
    ) -> Result<(crate::plc::exchange::Preload, Duration), ContractError> {
        let began = tokio::time::Instant::now();
        let preloaded = self.link()?.preload(bank, base, tables).await?;
        let took = began.elapsed();
        tracing::info!(robot = %self.robot.name, id, bank, words = preloaded.words(), preload_s = took.as_secs_f64(), "part chained at speed preloaded");
        Ok((preloaded, took))
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
    pub(super) fn lost_its_chain(&mut self, id: MoveId, running: Option<u16>) -> bool {
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
    pub(super) fn not_started(
        &mut self,
        id: MoveId,
        e: ContractError,
    ) -> Result<(), ContractError> {
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

    /// Cancels every queued move (never given to the PLC).
    pub(super) fn cancel_queue(&mut self, why: &str) {
        let ends = self.dispatch.cancel_queue(why);
        self.finish_all(ends);
    }

    /// Says why move `id` ends, on its report, before its final stage is said.
    pub(super) fn mark_end(&self, id: MoveId, reason: EndReason) {
        self.shared.moves(|m| {
            m.update(id, |r| {
                if !r.stage.is_final() {
                    r.end = Some(reason);
                }
            });
        });
    }

    /// Ends the reports of `ends`, in order.
    /// A move that failed before its start (its turn came too late) is said in the journal.
    pub(super) fn finish_all(&mut self, ends: Vec<Finish>) {
        for end in ends {
            if end.stage == Stage::Failed
                && let Some(why) = &end.error
            {
                tracing::warn!(robot = %self.robot.name, id = end.id, "{why}");
            }
            if let Some(reason) = end.end {
                self.mark_end(end.id, reason);
            }
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
        self.end_followers(id, stage, error.as_deref(), final_error);
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

/// A section's parts preloaded so far, behind its first part.
struct Walk {
    /// Where the parts went in the banks' areas.
    placement: Placement,
    /// Where the last part preloaded ends, per channel.
    ends_on: [i32; CHANNELS],
    /// The next part's bank.
    bank: u16,
    /// The link's pace, once the first part was preloaded.
    pace: Option<LinkPace>,
    /// Per part preloaded, the directories its start still writes.
    directories: Vec<usize>,
    /// Whether the first part's start writes a permit.
    permit: bool,
    /// How long a status read just took.
    exchange: Duration,
}

impl Walk {
    /// What to do with the next part of `section`, whose tables are `tables`
    /// ([`preload::choose`]).
    fn choose(
        &mut self,
        section: &SectionOrder,
        tables: &[ValidTable],
    ) -> Result<Choice, ContractError> {
        let so_far = parts(section, &self.directories);
        preload::choose(
            self.pace.as_ref(),
            &so_far,
            &mut self.placement,
            self.bank,
            tables,
        )
    }
}

/// The parts of `section` (planned) as the pace check sees them: the first
/// `directories.len()` after its first preloaded, each with that many directories left for its
/// start, the rest written whole at their turns.
pub(super) fn parts(section: &SectionOrder, directories: &[usize]) -> Vec<Part> {
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
