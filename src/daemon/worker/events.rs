//! Reading the status block into the machine, and applying what the machine says: the one place
//! where the daemon's reports follow the PLC, and where the machine's requests (the host word, a
//! stop, a start written again, a withdrawal, a start found running) become exchanges.

use super::dispatch::{Settled, end_of, moved};
use super::{Worker, describe, link_broken, now};
use crate::contract::Permit;
use crate::contract::machine::{Blocker, Event, Outcome, Planned, Status};
use crate::contract::{CHANNELS, Fault, describe_unmet};
use crate::daemon::request::CommandError;
use crate::order::MoveOrder;
use crate::plc::exchange::{CommandWrite, ContractError};
use crate::wire::{EndReason, MoveId, MoveReport, RobotPhase, Stage};

/// Planned duration given to a start found running whose tables could not be read.
const UNKNOWN_DURATION: std::time::Duration = std::time::Duration::from_secs(60);

impl Worker {
    /// Reads the status block and applies what it means.
    pub(super) async fn poll(&mut self) -> Result<(), ContractError> {
        let session = self.session()?;
        let asked = tokio::time::Instant::now();
        let status = match session.contract.status().await {
            Ok(s) => {
                session.exchange = asked.elapsed();
                s
            }
            Err(e) if link_broken(&e) => return Err(e),
            Err(e) => {
                self.contract_unusable(&e);
                return Ok(());
            }
        };
        self.read(status).await
    }

    /// Applies a status block just read.
    pub(super) async fn read(&mut self, status: Status) -> Result<(), ContractError> {
        let events = self.dispatch.machine.on_status(&status, now());
        let incidents_before = self.out.incidents().count;
        // Counted before anything reads this block: a cycle must not take a wait met on the
        // block that shows its PLC restarted.
        self.note_incidents(&events);
        self.publish_refusal();
        self.note_status(&status);
        let result = self.apply(events).await;
        let trusted = self.out.incidents().count == incidents_before;
        self.settle(trusted.then_some(&status));
        self.publish_refusal();
        self.publish_phase();
        result
    }

    fn note_status(&self, status: &Status) {
        let counts = status.block.elapsed.map(i64::from);
        let pose = self.robot.pose_of(&self.by_joint(counts)).to_mm_deg();
        let heartbeat_age = self.dispatch.machine.heartbeat_age(now());
        let homed = self.dispatch.machine.homed();
        self.out.state(|s| {
            s.link.connected = true;
            s.link.error = None;
            s.counts = Some(counts);
            s.inputs = Some(status.block.inputs);
            s.pose = Some(pose);
            s.state = Some(status.state);
            s.fault = (status.block.fault != 0).then_some(status.block.fault);
            s.heartbeat_age_ms = heartbeat_age.map(|d| d.as_millis() as u64);
            s.homed = homed;
        });
        self.out.fresh_read();
    }

    /// Publishes why a new order would be refused now.
    pub(super) fn publish_refusal(&self) {
        let blocker = if self.conn.session.is_none() {
            Some(Blocker::LinkDown)
        } else {
            self.dispatch.machine.blocker(now())
        };
        let refusal = blocker.filter(Blocker::refuses_orders);
        self.out.set_refusal(refusal);
        let text = refusal.map(|b| b.to_string());
        self.out.state(|s| s.refuses = text);
    }

    pub(super) fn publish_phase(&self) {
        let phase = RobotPhase::from(self.dispatch.machine.phase());
        self.out.state(|s| s.phase = phase);
    }

    /// Applies the machine's events, carrying out the exchanges they ask for.
    pub(super) async fn apply(&mut self, events: Vec<Event>) -> Result<(), ContractError> {
        for event in events {
            if let Err(e) = self.apply_one(event).await {
                if link_broken(&e) {
                    return Err(e);
                }
                self.note_error(&e);
            }
        }
        Ok(())
    }

    /// Counts the incidents among `events` ([`incident`]).
    fn note_incidents(&self, events: &[Event]) {
        for event in events {
            if let Some(why) = incident(event) {
                tracing::warn!(robot = %self.robot.name, "incident: {why}");
                self.out.incident(why, matches!(event, Event::Restarted));
            }
        }
    }

    /// Applies events when no exchange is possible (the link is down).
    pub(super) fn apply_offline(&mut self, events: Vec<Event>) {
        self.note_incidents(&events);
        for event in events {
            self.report_event(event);
        }
    }

    async fn apply_one(&mut self, event: Event) -> Result<(), ContractError> {
        tracing::debug!(robot = %self.robot.name, ?event, phase = self.dispatch.machine.phase().name(), "machine event");
        let Some(link) = self.conn.session.as_mut().map(|s| &mut s.contract) else {
            self.report_event(event);
            return Ok(());
        };
        match event {
            Event::WriteHost => link.write_host(self.dispatch.machine.host()).await,
            Event::WriteStop => {
                tracing::warn!(robot = %self.robot.name, "writing a stop (a watchdog tripped)");
                link.stop().await
            }
            Event::Withdraw { tag } => {
                tracing::warn!(robot = %self.robot.name, id = tag, "withdrawing a start the PLC never showed waiting");
                link.withdraw().await
            }
            Event::FoundWaiting { seq } => {
                tracing::warn!(robot = %self.robot.name, seq, "withdrawing a start this run did not write");
                link.withdraw().await
            }
            Event::RewriteStart { tag } => self.rewrite_start(tag).await,
            Event::FoundRunning { seq } => self.adopt(seq).await,
            Event::Stalled { .. } => {
                self.report_event(event);
                self.read_mode().await
            }
            other => {
                self.report_event(other);
                Ok(())
            }
        }
    }

    /// Writes a start's command word again after its reply was lost and the PLC did not show
    /// it taken (the PLC ignores a repeated `seq` anyway).
    async fn rewrite_start(&mut self, tag: MoveId) -> Result<(), ContractError> {
        let bank = self.dispatch.start_of(tag).cloned();
        let link = self.link()?;
        let written = match &bank {
            Some(bank) => link.start(bank).await,
            None => Ok(CommandWrite::Unconfirmed(
                crate::plc::PlcError::InvalidRequest {
                    operation: "write the start again".into(),
                    detail: "its bank is no longer known".into(),
                },
            )),
        };
        let confirmed = matches!(written, Ok(CommandWrite::Confirmed));
        tracing::warn!(robot = %self.robot.name, id = tag, confirmed, "start written again after a lost reply");
        self.dispatch.machine.start_rewritten(now(), confirmed);
        written.map(|_| ())
    }

    /// Follows a start found running that this run did not give: described from its bank read
    /// back, reported as a recovered move.
    async fn adopt(&mut self, seq: u16) -> Result<(), ContractError> {
        let Some(status) = self.dispatch.machine.last().copied() else {
            return Ok(());
        };
        let id = self.shared.next_id();
        let planned = match self.link()?.describe_running(seq, id, &status).await {
            Ok(p) => p,
            Err(e) if link_broken(&e) => return Err(e),
            Err(e) => {
                tracing::warn!(robot = %self.robot.name, seq, error = %describe(&e), "cannot read the running start's tables; following it unbounded");
                unknown_start(id, seq, &status)
            }
        };
        let mut report = MoveReport::new(id, &self.robot.name, MoveOrder::default());
        report.recovered = true;
        report.stage = Stage::Running;
        report.seq = Some(seq);
        report.bank = Some(planned.bank);
        report.start_counts = Some(planned.from.map(i64::from));
        report.target_counts = planned.targets.map(|t| t.map(i64::from));
        report.deadline_s = Some(
            self.dispatch
                .machine
                .settings()
                .run_limit(planned.duration)
                .as_secs_f64(),
        );
        self.shared.moves(|m| m.insert(report));
        self.out.state(|s| s.current_move = Some(id));
        self.dispatch.started(id, now());
        self.dispatch.spent(seq, planned.bank);
        let bank = planned.bank;
        self.dispatch.machine.adopt(planned, now());
        tracing::info!(robot = %self.robot.name, id, seq, bank, "following a move this run did not start");
        Ok(())
    }

    /// What an event changes in the reports and the robot's state (no exchanges).
    fn report_event(&mut self, event: Event) {
        match event {
            Event::Started { tag } => self.started(tag),
            Event::Waiting { tag } => {
                self.shared
                    .moves(|m| m.update(tag, |r| r.stage = Stage::Waiting));
            }
            Event::Progress {
                tag,
                elapsed,
                fraction,
            } => self.progress(tag, elapsed, fraction),
            Event::Done { tag, elapsed } => self.done(tag, elapsed),
            Event::Ended { tag, outcome } => self.ended(tag, outcome),
            Event::Restarted => self.restarted(),
            Event::Stalled { still } => {
                tracing::error!(robot = %self.robot.name, still_ms = still.as_millis() as u64, "the PLC heartbeat stands still");
                self.cancel_queue("cancelled: the PLC heartbeat stood still");
            }
            Event::Homed => {
                tracing::info!(robot = %self.robot.name, "homed");
                self.homing_ended(&Ok(()));
            }
            Event::HomeFailed { fault } => {
                let why = CommandError::HomeFailed { fault };
                tracing::error!(robot = %self.robot.name, "{why}");
                self.homing_ended(&Err(why));
            }
            Event::WriteHost
            | Event::WriteStop
            | Event::RewriteStart { .. }
            | Event::Withdraw { .. }
            | Event::FoundRunning { .. }
            | Event::FoundWaiting { .. } => {}
        }
    }

    /// Move `tag` was seen starting: its report runs, its deadline counted from now.
    fn started(&mut self, tag: MoveId) {
        self.dispatch.started(tag, now());
        let deadline_s = self.run_deadline(tag).map(|d| d.as_secs_f64());
        self.shared.moves(|m| {
            m.update(tag, |r| {
                r.stage = Stage::Running;
                // From its start on: its run limit and the grace of a lost link (a move
                // chained behind another waited for that one first).
                r.deadline_s = deadline_s.or(r.deadline_s);
            });
        });
        self.out.state(|s| {
            s.current_move = Some(tag);
            s.queued.retain(|q| *q != tag);
        });
    }

    /// The PLC restarted: the queue cancelled, no start written again.
    fn restarted(&mut self) {
        tracing::error!(robot = %self.robot.name, "the PLC restarted: every move it was given ended failed; nothing starts until it is homed");
        self.cancel_queue("cancelled: the PLC restarted");
        self.dispatch.forget_starts();
    }

    /// Move `tag` runs on: its counts and its share of its planned path.
    fn progress(&self, tag: MoveId, elapsed: [i32; CHANNELS], fraction: f64) {
        self.shared.moves(|m| {
            m.update(tag, |r| {
                r.counts = Some(elapsed.map(i64::from));
                r.progress = fraction;
            });
        });
    }

    /// The home routine ended: every home request is answered with `result`.
    fn homing_ended(&mut self, result: &Result<(), CommandError>) {
        for reply in std::mem::take(&mut self.inbox.homing) {
            let _ = reply.send(result.clone());
        }
    }

    /// The longest move `id` can take from its start until the daemon ends it.
    fn run_deadline(&self, id: MoveId) -> Option<std::time::Duration> {
        let planned = self
            .dispatch
            .machine
            .given()
            .into_iter()
            .find(|p| p.tag == id)?;
        let watch = self.dispatch.machine.settings();
        Some(watch.run_limit(planned.duration) + watch.link_grace)
    }

    fn done(&mut self, id: MoveId, elapsed: Option<[i32; CHANNELS]>) {
        let motion_s = self
            .dispatch
            .ran(id)
            .map(|t| now().saturating_duration_since(t).as_secs_f64());
        if let Some(seconds) = motion_s {
            self.shared.metrics.moved(seconds);
        }
        let target = self
            .shared
            .moves(|m| m.get(id))
            .and_then(|r| r.target_counts);
        let error = elapsed
            .zip(target)
            .map(|(e, t)| std::array::from_fn(|c| i64::from(e[c]) - t[c]));
        self.shared.moves(|m| {
            m.update(id, |r| {
                r.motion_s = motion_s;
                r.progress = 1.0;
                if let Some(e) = elapsed {
                    r.counts = Some(e.map(i64::from));
                }
            });
        });
        self.finish(id, Stage::Done, None, error);
        let end_error_pulses = error.map(|e| e.map(|p| p.to_string()).join(","));
        tracing::info!(robot = %self.robot.name, id, end_error_pulses, "move done");
    }

    fn ended(&mut self, id: MoveId, outcome: Outcome) {
        self.dispatch.ran(id);
        let seq = self.shared.moves(|m| m.get(id)).and_then(|r| r.seq);
        let start = seq.map_or_else(|| "the start".to_owned(), |s| format!("start {s}"));
        let asked = self.dispatch.stopped_by_request(now());
        let held = matches!(outcome, Outcome::Stopped { fault } if fault == Fault::PermitDropped.word())
            && self.dispatch.permit(id).is_some();
        let because = held.then(|| self.held_because(id));
        let (stage, why) = end_of(outcome, because, asked, &start);
        tracing::warn!(robot = %self.robot.name, id, stage = stage.name(), "move ended: {why}");
        if held {
            self.shared
                .moves(|m| m.update(id, |r| r.end = Some(EndReason::Held)));
        }
        match self.dispatch.machine.last() {
            // Its counts are read once the channels have stopped: a scan after the block
            // that showed the end, with no channel of the robot busy.
            Some(last) if moved(outcome) => {
                let beat = last.block.heartbeat;
                self.dispatch.settling(id, stage, why, beat, now());
                // The PLC runs it no more; its report ends with the counts it stopped at.
                self.out.state(|s| {
                    if s.current_move == Some(id) {
                        s.current_move = None;
                    }
                });
            }
            _ => self.finish(id, stage, Some(why), None),
        }
        self.cancel_queue("cancelled: the move before it did not end done");
    }

    /// Ends the moves that stopped short and have waited too long for a block that shows their
    /// channels still (the link is down): with the counts last read.
    pub(super) fn settle_late(&mut self) {
        let late = self.dispatch.settled_late(now());
        self.end_settled(late, None);
    }

    /// Ends the moves that stopped short once a status block read a scan after their end
    /// shows the robot's channels still: their report's counts are that block's, with the
    /// error to their targets. `None`: the PLC can no longer tell (the link, a restart, a
    /// stall); they end with the counts last read.
    pub(super) fn settle(&mut self, status: Option<&Status>) {
        let settled = self.dispatch.settled(status, self.channel_mask(), now());
        self.end_settled(settled, status);
    }

    /// The robot's channels, as a bit mask.
    fn channel_mask(&self) -> u16 {
        self.robot
            .joints
            .iter()
            .fold(0_u16, |m, j| m | 1 << j.channel)
    }

    /// Ends the reports of `settled`, their counts `status`'s when it shows the channels still.
    fn end_settled(&mut self, settled: Vec<Settled>, status: Option<&Status>) {
        let mask = self.channel_mask();
        for s in settled {
            let counts = status
                .filter(|b| b.block.busy & mask == 0)
                .map(|b| b.block.elapsed.map(i64::from));
            let target = self
                .shared
                .moves(|m| m.get(s.id))
                .and_then(|r| r.target_counts);
            let error = counts
                .zip(target)
                .map(|(c, t)| std::array::from_fn(|ch| c[ch] - t[ch]));
            if let Some(c) = counts {
                self.shared
                    .moves(|m| m.update(s.id, |r| r.counts = Some(c)));
            }
            self.finish(s.id, s.stage, Some(s.why), error);
        }
    }
}

impl Worker {
    /// Why the PLC held move `id` (fault 9): the inputs of its permit that stopped holding, as
    /// the last status block shows them.
    fn held_because(&self, id: MoveId) -> String {
        let inputs = self
            .dispatch
            .machine
            .last()
            .map(|s| s.block.inputs)
            .unwrap_or_default();
        let unmet = self
            .dispatch
            .permit(id)
            .map(|p| describe_unmet(p, &inputs, &self.settings.layout.inputs))
            .filter(|text| !text.is_empty());
        match unmet {
            Some(text) => format!("held by the PLC: its permit stopped holding ({text})"),
            None => "held by the PLC: its permit stopped holding (fault 9)".to_owned(),
        }
    }
}

/// What an event makes untrustworthy, in words (a cycle faults on it, whatever its step).
fn incident(event: &Event) -> Option<String> {
    match event {
        Event::Restarted => Some(
            "the PLC restarted (its host word was cleared): nothing moves until it is homed"
                .to_owned(),
        ),
        Event::Stalled { still } => Some(format!(
            "the PLC's heartbeat stood still for {:.1} s (stalled, or in PROG mode)",
            still.as_secs_f64()
        )),
        Event::Ended {
            tag,
            outcome: Outcome::LinkLost { down },
        } => Some(format!(
            "the PLC link was down {:.1} s, past move {tag}'s end: what became of it is unknown",
            down.as_secs_f64()
        )),
        _ => None,
    }
}

/// A start found running whose tables could not be read: bounded only in time.
fn unknown_start(tag: MoveId, seq: u16, status: &Status) -> Planned {
    Planned {
        tag,
        seq,
        bank: 0,
        from: status.block.elapsed,
        targets: None,
        envelope: [(i32::MIN, i32::MAX); CHANNELS],
        duration: UNKNOWN_DURATION,
        curve: None,
        // Not known: a start found running is followed, never written again.
        permit: Permit::NONE,
    }
}

impl Worker {
    /// Per-joint counts from per-channel ones.
    pub(super) fn by_joint(&self, channels: [i64; CHANNELS]) -> [i64; crate::kinematics::JOINTS] {
        std::array::from_fn(|j| channels[usize::from(self.robot.joints[j].channel)])
    }
}
