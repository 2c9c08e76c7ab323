//! A path's first part queued behind a running start (its parts chained at speed). The worker
//! judges it once against that start ([`Lead`]): it begins behind it, its later parts written
//! while the part before each runs, when the link has shown it can; else it waits for rest,
//! and meanwhile its second part is preloaded into the bank the running start does not use
//! (one exchange a step, the running start watched between them), so that from rest only the
//! first part is left to write, into the bank that start ran from.

use std::time::Duration;

use super::dispatch::{Activity, Ahead, AheadDue, Lead};
use super::pace::Part;
use super::placement::Placement;
use super::{Worker, describe, link_broken};
use crate::contract::CHANNELS;
use crate::contract::machine::Planned;
use crate::plan::PlanError;
use crate::plc::exchange::ContractError;
use crate::table::ValidTable;
use crate::wire::MoveId;

/// Why a path's first part waits for rest behind the start running ([`Lead::FromRest`]).
#[derive(Debug, thiserror::Error)]
enum WaitsForRest {
    #[error("no pace known on this link yet")]
    NoPace,
    #[error("it is no longer the head of the queue")]
    NotHead,
    #[error("not every part of its path is queued")]
    PartsMissing,
    #[error("the start running has no known targets")]
    NoTargets,
    #[error("it does not plan from there: {0}")]
    Plan(#[from] PlanError),
    #[error("part {part} of its section has no valid tables")]
    InvalidTables { part: usize },
    #[error("{0}")]
    Pace(ContractError),
}

impl Worker {
    /// Judges whether queued move `id`, the first part of a path section cut into parts, may
    /// begin behind `behind`, the start running ([`Lead`]): only when this link has shown its
    /// pace (a path's parts preloaded over it), every part of the section is queued and plans
    /// from `behind`'s targets into valid tables, and at that pace each part after the first
    /// can be written whole, read back and started while the part before it runs, with the
    /// check's margin ([`LinkPace::check`]). Else it waits for rest, as before.
    pub(super) fn judge_lead(&mut self, id: MoveId, behind: &Planned) {
        let seq = behind.seq;
        let lead = match self.chains_behind(behind) {
            Ok(()) => {
                tracing::info!(robot = %self.robot.name, id, behind = seq, "a path's first part begins behind the start running: its parts are written while the part before each runs");
                Lead::Behind { seq }
            }
            Err(why) => {
                tracing::info!(robot = %self.robot.name, id, behind = seq, "a path's first part waits for rest: {why}");
                Lead::FromRest { seq, ahead: false }
            }
        };
        self.dispatch.judged(id, lead);
    }

    /// Why the head of the queue, a section's first part, may not begin behind `behind`
    /// ([`Self::judge_lead`]).
    fn chains_behind(&mut self, behind: &Planned) -> Result<(), WaitsForRest> {
        let (pace, exchange) = self
            .conn
            .session
            .as_ref()
            .and_then(|s| s.pace.map(|pace| (pace, s.exchange)))
            .ok_or(WaitsForRest::NoPace)?;
        // The parts of a path are sent together: take in any not queued yet.
        self.take_pending_requests();
        let (order, all) = self.dispatch.lead_section().ok_or(WaitsForRest::NotHead)?;
        if !all {
            return Err(WaitsForRest::PartsMissing);
        }
        let targets = behind.targets.ok_or(WaitsForRest::NoTargets)?;
        let plans = order
            .section_plans(&self.robot, self.by_joint(targets.map(i64::from)))
            .ok_or(WaitsForRest::NotHead)??;
        if let Some(k) = plans
            .iter()
            .position(|plan| plan.valid_tables(&self.robot).is_none())
        {
            return Err(WaitsForRest::InvalidTables { part: k + 1 });
        }
        let parts: Vec<Part> = plans.iter().map(|plan| Part::of(plan, None)).collect();
        pace.for_section(exchange, !order.permit.is_none())
            .check(&parts)
            .map_err(WaitsForRest::Pace)
    }

    /// Begins preloading `due`'s second part ahead ([`Activity::Preloading`]): planned behind
    /// its first part, planned from the running start's targets, into the bank that start does
    /// not use, where the walk from rest would place it. A part that does not plan or place is
    /// left to its first part's turn.
    pub(super) fn begin_ahead(&mut self, due: &AheadDue) -> Result<(), ContractError> {
        let Some((tables, bank, base)) = self.ahead_tables(due) else {
            tracing::info!(robot = %self.robot.name, id = due.id, "a path's second part not preloaded ahead: it does not plan or place behind the start running");
            return Ok(());
        };
        let (upload, preload) = self.link()?.begin_preload(bank, base, &tables)?;
        let every = self.dispatch.machine.settings().heartbeat_timeout;
        self.dispatch.activity = Activity::Preloading(Box::new(Ahead {
            id: due.id,
            upload,
            preload,
            took: Duration::ZERO,
            every,
        }));
        Ok(())
    }

    /// `due`'s second part's tables, its bank and where in it ([`Self::begin_ahead`]).
    fn ahead_tables(&self, due: &AheadDue) -> Option<(Vec<ValidTable>, u16, [usize; CHANNELS])> {
        let targets = due.behind.targets?;
        let counts = self.by_joint(targets.map(i64::from));
        let plans = due.first.section_plans(&self.robot, counts)?.ok()?;
        let (first, second) = (plans.first()?, plans.get(1)?);
        let first_tables = first.valid_tables(&self.robot)?;
        let tables = second.valid_tables(&self.robot)?;
        let area_words = usize::from(
            self.conn
                .session
                .as_ref()?
                .contract
                .settings()
                .layout
                .area_words,
        );
        let bank = 1 - due.behind.bank;
        let base = Placement::new(due.behind.bank, &first_tables, area_words)
            .place(bank, &tables)
            .ok()?;
        Some((tables, bank, base))
    }

    /// One exchange of a preload ahead; before it, when the dispatcher says so (`watch`), a
    /// status read that watches the running start. Done, the part is preloaded; failed, it is
    /// not (its first part's turn writes it whole), and a link failure goes on up.
    pub(super) async fn ahead_step(
        &mut self,
        mut ahead: Box<Ahead>,
        watch: bool,
    ) -> Result<(), ContractError> {
        if watch {
            self.poll_step().await?;
        }
        let began = tokio::time::Instant::now();
        let step = self.link()?.upload_step(&mut ahead.upload).await;
        ahead.took += began.elapsed();
        match step {
            Ok(None) => self.dispatch.activity = Activity::Preloading(ahead),
            Ok(Some(_)) => {
                let Ahead {
                    id, preload, took, ..
                } = *ahead;
                tracing::info!(robot = %self.robot.name, id, bank = preload.bank(), words = preload.words(), preload_s = took.as_secs_f64(), "a path's second part preloaded ahead, behind the start running");
                self.dispatch.preloaded(id, preload, took);
            }
            Err(e) => {
                tracing::info!(robot = %self.robot.name, id = ahead.id, "a path's second part not preloaded ahead: {}", describe(&e));
                if link_broken(&e) {
                    return Err(e);
                }
            }
        }
        Ok(())
    }
}
