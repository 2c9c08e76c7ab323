//! The worker's steps for the move whose turn came ([`Activity`]): begun (planned, its section's
//! parts preloaded, its upload made ready), then one exchange of its upload a step, one step of
//! holding a prepared bank, one proof read a step, and its start written once. Each step is
//! one round of the worker's loop ([`Worker::run`]); what a step ends in is the next activity.

use super::dispatch::{Action, Activity, CYCLE_WENT_ON, Queued, Turn, Uploaded, Uploading};
use super::prepared::prepared_watch;
use super::{Worker, describe, link_broken, now};
use crate::contract::machine::{Blocker, Phase, Planned};
use crate::daemon::gate::GateState;
use crate::plc::exchange::{ContractError, Preload, Upload, VerifiedBank};
use crate::table::ValidTable;
use crate::wire::Stage;

impl Worker {
    /// Carries out one of the dispatcher's actions on the queue's moves: a path's first part
    /// judged or its second part preloaded ahead ([`super::lead`]), a turn begun, one step of
    /// its upload, its proof, its start, its cancellation.
    pub(super) async fn move_step(&mut self, action: Action) -> Result<(), ContractError> {
        match action {
            Action::JudgeLead { id, behind } => {
                self.judge_lead(id, &behind);
                Ok(())
            }
            Action::PreloadAhead(due) => self.begin_ahead(&due),
            Action::AheadStep { ahead, watch } => self.ahead_step(ahead, watch).await,
            Action::Begin(queued) => self.begin(*queued).await,
            Action::UploadStep { uploading, watch } => self.upload_step(uploading, watch).await,
            Action::ProveRead(uploaded) => self.prove(uploaded).await,
            Action::WriteStart(uploaded) => self.start(*uploaded).await,
            Action::Unprepare { id, why } => self.unprepared(id, &why, None),
            _ => unreachable!("not a move's step: {action:?}"),
        }
    }

    /// Plans `queued` and makes its upload ready (after preloading, from rest, the parts of a
    /// path behind it); a move that cannot be started ends with the reason.
    pub(super) async fn begin(&mut self, queued: Queued) -> Result<(), ContractError> {
        let incidents = self.out.incidents();
        if let Some(why) = queued.stale(incidents.count, incidents.last.as_deref()) {
            tracing::warn!(robot = %self.robot.name, id = queued.id, "{why}");
            self.finish(queued.id, Stage::Cancelled, Some(why), None);
            self.cancel_queue("cancelled: the move before it did not start");
            return Ok(());
        }
        let Some(turn) = self.turn(queued).await? else {
            return Ok(());
        };
        let Some((plan, planned)) = self.plan_turn(&turn) else {
            return Ok(());
        };
        if turn
            .mode
            .gate()
            .is_some_and(|g| g.state() == GateState::Shut)
        {
            // Its cycle went another way while it was queued: nothing written.
            return self.unprepared(turn.id, CYCLE_WENT_ON, None);
        }
        self.upload_begun(turn, &plan, planned).await
    }

    /// The upload of `turn`'s `plan` (`planned`) begun ([`Activity::Uploading`]); an upload
    /// that cannot begin ends its move.
    async fn upload_begun(
        &mut self,
        mut turn: Turn,
        plan: &crate::plan::Plan,
        planned: Planned,
    ) -> Result<(), ContractError> {
        let tables = plan
            .valid_tables(&self.robot)
            .expect("plan_move returns valid tables");
        self.dispatch.machine.upload_begun();
        self.publish_phase();
        let began = now();
        let exchange = self.session()?.exchange;
        let from_rest = turn.mode.ahead().is_none();
        let own = turn
            .preload
            .take()
            .filter(|p| p.tables.bank() == planned.bank)
            .map(|p| p.tables);
        let gated = turn.mode.gate().is_some();
        match self
            .ready_upload(&planned, &tables, own, (from_rest, gated), exchange)
            .await
        {
            Ok((upload, every)) => {
                let uploading = Uploading {
                    turn,
                    planned,
                    upload,
                    began,
                    every,
                    from_rest,
                };
                self.dispatch.activity = Activity::Uploading(Box::new(uploading));
                Ok(())
            }
            Err(e) => self.upload_failed(&turn, e),
        }
    }

    /// The upload of `tables` and the command block of `planned` into its bank, to be read
    /// back; only the directories left and the block when its tables were preloaded into that
    /// bank (`own`). A start written while nothing runs (`from_rest`) first preloads the parts
    /// of a path that begin at speed behind it (`exchange`: how long a status read just took).
    /// With it, how often the status block is read between its exchanges, more often for a
    /// prepared move (`gated`, [`Self::upload_step`]).
    async fn ready_upload(
        &mut self,
        planned: &Planned,
        tables: &[ValidTable],
        own: Option<Preload>,
        (from_rest, gated): (bool, bool),
        exchange: std::time::Duration,
    ) -> Result<(Upload, std::time::Duration), ContractError> {
        let own = if from_rest {
            // Nothing preloaded before outlives a start from rest but its section's second
            // part preloaded ahead into the other bank: its parts are preloaded around it.
            self.dispatch.forget_preloads_but_ahead(planned.bank);
            self.preload_section(planned, tables, exchange).await?;
            None
        } else {
            own
        };
        let link = self.link()?;
        let upload = match own {
            Some(preload) => link.begin_upload_preloaded(&planned.into(), tables, &preload),
            None => link.begin_upload(&planned.into(), tables),
        }?;
        let timeout = self.dispatch.machine.settings().heartbeat_timeout;
        let every = if gated {
            prepared_watch(self.session()?.exchange, self.settings.poll_interval).min(timeout)
        } else {
            timeout
        };
        Ok((upload, every))
    }

    /// One exchange of an upload; before it, when the dispatcher says so (`watch`: a start
    /// the PLC was given may run and the last read is `every` old), a status read: the running
    /// move stays watched (its heartbeat, counts, state, progress) through an upload that lasts
    /// seconds on a slow line, and is stopped as it would be between uploads. A prepared move
    /// is uploaded behind a cycle's move, whose end (done, or held by its permit) the cycle goes
    /// on from: its status block is read more often, at most a sixth of the link's time
    /// ([`prepared_watch`]). An upload the machine gave up on meanwhile (the PLC stalled or
    /// restarted) ends there.
    pub(super) async fn upload_step(
        &mut self,
        mut uploading: Box<Uploading>,
        watch: bool,
    ) -> Result<(), ContractError> {
        match self.upload_exchange(&mut uploading, watch).await {
            Ok(None) => {
                self.dispatch.activity = Activity::Uploading(uploading);
                Ok(())
            }
            Ok(Some(bank)) => {
                self.uploaded(*uploading, bank);
                Ok(())
            }
            Err(e) => self.upload_failed(&uploading.turn, e),
        }
    }

    async fn upload_exchange(
        &mut self,
        uploading: &mut Uploading,
        watch: bool,
    ) -> Result<Option<VerifiedBank>, ContractError> {
        if watch {
            self.poll().await?;
            if !matches!(self.dispatch.machine.phase(), Phase::Uploading { .. }) {
                // Stalled, restarted, ...: this bank will not be started; the link is needed
                // for what comes next.
                let why = self
                    .dispatch
                    .machine
                    .blocker(now())
                    .unwrap_or(Blocker::Full);
                return Err(ContractError::Blocked(why));
            }
        }
        self.link()?.upload_step(&mut uploading.upload).await
    }

    /// Its bank written and verified ([`Dispatcher::uploaded`]): its upload time recorded, a
    /// prepared move's report says so.
    ///
    /// [`Dispatcher::uploaded`]: super::dispatch::Dispatcher::uploaded
    fn uploaded(&mut self, uploading: Uploading, bank: VerifiedBank) {
        let (id, upload_s, prepared) = self.dispatch.uploaded(uploading, bank, now());
        self.shared.metrics.uploaded(upload_s);
        self.shared.moves(|m| {
            m.update(id, |r| {
                r.upload_s = Some(upload_s);
                if prepared {
                    r.stage = Stage::Prepared;
                }
            });
        });
    }

    /// Ends the move of `turn`, whose upload failed by `e`: a prepared move is cancelled before
    /// its start, any other ends not started; a link failure goes on up.
    fn upload_failed(&mut self, turn: &Turn, e: ContractError) -> Result<(), ContractError> {
        self.dispatch.forget_preloads();
        let Some(gate) = turn.mode.gate() else {
            return self.not_started(turn.id, e);
        };
        let why = if gate.state() == GateState::Shut {
            CYCLE_WENT_ON.to_owned()
        } else {
            describe(&e)
        };
        self.unprepared(turn.id, &why, link_broken(&e).then_some(e))
    }

    /// The contract's first step once more, after the upload: the bank is started only once
    /// the heartbeat is seen moving, while the PLC takes it and every count is the plan's `from`
    /// (or it chains behind the start whose targets are its `from`). When two reads are needed
    /// for the heartbeat, the first is of its word alone. One read a step.
    pub(super) async fn prove(&mut self, uploaded: Box<Uploaded>) -> Result<(), ContractError> {
        match self.proof_read(&uploaded.planned).await {
            Ok(proven) => match self.dispatch.proven(uploaded, proven, now()) {
                Some(uploaded) => self.start(*uploaded).await,
                None => Ok(()),
            },
            Err(e) => self.not_started(uploaded.turn.id, e),
        }
    }

    /// Reads the status block for `planned`'s start: whether the PLC may take it now (`false`:
    /// the heartbeat is not proven yet).
    async fn proof_read(&mut self, planned: &Planned) -> Result<bool, ContractError> {
        let Some(session) = self.conn.session.as_mut() else {
            return Err(ContractError::Blocked(Blocker::LinkDown));
        };
        let status = session
            .contract
            .proof_read(&mut self.dispatch.machine)
            .await?;
        self.read(status).await?;
        match self.dispatch.machine.may_start(planned, now()) {
            Ok(()) => Ok(true),
            Err(Blocker::Unproven) => Ok(false),
            Err(blocker) => Err(ContractError::Blocked(blocker)),
        }
    }

    /// Writes the start of `uploaded`, unless it begins at speed and the start it was to chain
    /// behind ended meanwhile.
    pub(super) async fn start(&mut self, uploaded: Uploaded) -> Result<(), ContractError> {
        let Uploaded {
            turn,
            planned,
            bank,
            upload_s,
        } = uploaded;
        let ahead = turn.mode.ahead().map(|c| c.seq);
        if turn.order.begins_at_speed() && self.lost_its_chain(turn.id, ahead) {
            return Ok(());
        }
        self.write_start(&turn, planned, bank, upload_s).await
    }
}
