//! The cycle's driver: one task per cycle, carrying out the actions of its pure
//! [`Runner`] (the program counter, loops, moves prepared ahead, what ends a step) through the
//! robot's handle ([`super::act`]), writing the cycle's status ([`super::status`]), and feeding
//! back what came of each with what it sees: the control, the PLC's incidents, the time. An
//! action on the robot gives way at once to an incident since the epoch the cycle acts under
//! (the runner then faults the cycle).

use std::time::Instant;

use tokio::sync::watch;

use super::act;
use super::pallet::Palletising;
use super::status::Status;
use crate::cycle::runner::{Action, Control, Event, Motion, MotionEnd, Prepared, Seen};
use crate::cycle::{Checked, Runner};
use crate::daemon::RobotHandle;
use crate::daemon::Snapshot;
use crate::daemon::gate::Gate;
use crate::daemon::shared::CycleOut;
use crate::wire::CycleState;

/// Runs `program` `count` times (or until stopped).
pub(crate) async fn run(
    handle: RobotHandle,
    program: Checked,
    count: Option<u64>,
    control: watch::Receiver<Control>,
    status: CycleOut,
) {
    let incidents = handle.watch_snapshot();
    let epoch = incidents.borrow().incidents.count;
    let name = program.name.clone();
    let pallets = Palletising::new(program.pallets.clone());
    let mut runner = Runner::new(program, count, epoch, Instant::now());
    let restarts = incidents.borrow().incidents.restarts;
    let mut driver = Driver {
        handle: handle.under(epoch),
        restarts,
        base: handle,
        epoch,
        incidents,
        control,
        orphaned: false,
        status: Status(status),
        pallets,
    };
    let mut event = Event::Go;
    let state = loop {
        let action = runner.on(event, &driver.seen());
        driver.act_under(runner.epoch());
        if let Action::End {
            state,
            why,
            unprepare,
        } = action
        {
            act::unprepare(&driver.handle, unprepare).await;
            driver.status.ended(state, why);
            break state;
        }
        event = driver.carry_out(action, runner.incident_mark()).await;
    };
    tracing::info!(robot = %driver.handle.robot().name, program = %name, ?state, "cycle ended");
}

/// What the driver holds: the robot, the watches it feeds the runner from, the status.
struct Driver {
    /// The robot, acting under [`Self::epoch`]: what the cycle asks for is refused once
    /// another incident came.
    handle: RobotHandle,
    /// The robot, as any client.
    base: RobotHandle,
    /// The incident count [`Self::handle`] acts under.
    epoch: u64,
    /// The PLC's restarts the cycle has seen (a restart mid-place makes the slot unsure).
    restarts: u64,
    /// The robot's snapshot, for its incidents.
    incidents: watch::Receiver<Snapshot>,
    control: watch::Receiver<Control>,
    /// The controller is gone (the daemon shuts down): taken as a stop.
    orphaned: bool,
    status: Status,
    /// The pallets the program was checked with, and their counters.
    pallets: Palletising,
}

impl Driver {
    /// What the runner sees now.
    fn seen(&mut self) -> Seen {
        let mut control = *self.control.borrow_and_update();
        if self.orphaned {
            control.stop(false);
        }
        let snapshot = self.incidents.borrow();
        Seen {
            control,
            incidents: snapshot.incidents.count,
            last_incident: snapshot.incidents.last.clone(),
            now: Instant::now(),
        }
    }

    /// Acts under `epoch` from now on (a resume after a fault cleared).
    fn act_under(&mut self, epoch: u64) {
        if epoch != self.epoch {
            self.epoch = epoch;
            self.handle = self.base.under(epoch);
        }
    }

    /// Carries `action` out: what came of it. One on the robot gives way to an incident since
    /// `mark`.
    async fn carry_out(&mut self, action: Action<Gate>, mark: u64) -> Event<Gate> {
        match action {
            Action::Step(at) => {
                tracing::debug!(robot = %self.handle.robot().name, step = at.step, "cycle step");
                self.status.step(at);
            }
            Action::CycleDone {
                done,
                took_s,
                waited_s,
            } => {
                self.handle.cycle_done(took_s);
                self.status.cycle_done(done, took_s, waited_s);
            }
            Action::Unprepare(moves) => act::unprepare(&self.handle, moves).await,
            Action::Pause { why, unprepare } => {
                tracing::warn!(robot = %self.handle.robot().name, "cycle paused: {why}");
                act::unprepare(&self.handle, unprepare).await;
                self.status.paused(why);
                return Event::Changed;
            }
            Action::Fault {
                why,
                stop_robot,
                unprepare,
            } => {
                self.fault(why, stop_robot, unprepare).await;
                return Event::Changed;
            }
            Action::Stand => return self.stand(mark).await,
            action => {
                let mut incidents = self.incidents.clone();
                return tokio::select! {
                    biased;
                    why = until_incident(&mut incidents, mark) => Event::Incident(why),
                    event = self.op(action) => event,
                };
            }
        }
        Event::Go
    }

    /// Faults the cycle on its step (`why`): the robot stopped, the prepared moves unprepared.
    async fn fault(&mut self, why: String, stop_robot: bool, unprepare: Vec<Prepared<Gate>>) {
        tracing::warn!(robot = %self.handle.robot().name, "cycle faulted: {why}");
        let restarts = self.incidents.borrow().incidents.restarts;
        if restarts != self.restarts {
            self.restarts = restarts;
            Palletising::interrupted(&self.base);
        }
        if stop_robot {
            let _ = self.base.stop_robot().await;
        }
        act::unprepare(&self.handle, unprepare).await;
        self.status.ended(CycleState::Faulted, Some(why));
    }

    /// Stands until the control changes or an incident comes since `mark`.
    async fn stand(&mut self, mark: u64) -> Event<Gate> {
        let mut incidents = self.incidents.clone();
        tokio::select! {
            changed = self.control.changed() => {
                self.orphaned |= changed.is_err();
                Event::Changed
            }
            why = until_incident(&mut incidents, mark) => Event::Incident(why),
        }
    }

    /// An op's action on the robot.
    async fn op(&mut self, action: Action<Gate>) -> Event<Gate> {
        let handle = &self.handle;
        let pallets = &self.pallets;
        let view = |name: &str| pallets.view(handle, name);
        match action {
            Action::Submit(Motion::Pallet {
                pallet,
                leg,
                speed_mm_s,
            }) => pallets.submit(handle, &pallet, leg, speed_mm_s).await,
            Action::Submit(motion) => act::submit(handle, motion).await,
            Action::Prepare { motion, .. } => act::prepare(handle, motion).await,
            Action::Release(gate) => {
                gate.open();
                Event::Go
            }
            Action::Follow(ids) => {
                let mut started = Vec::new();
                let end = act::follow(handle, &ids, &mut self.control, &mut started).await;
                if end != MotionEnd::NotStarted {
                    self.status.moves(&started);
                }
                Event::Followed(end)
            }
            Action::Wait { at, until, timeout } => {
                let wait = (&at, &until, timeout);
                act::wait_step(handle, &self.status, wait, &view, &mut self.control).await
            }
            Action::Write(writes) => act::write(handle, writes).await,
            Action::Dwell(d) => Event::Dwelt(act::dwell(d, &mut self.control).await),
            Action::Decide(until) => Event::Decided(act::decide(handle, &until, &view).await),
            Action::Pace => Event::Paced(act::pace(handle).await),
            Action::Pallet { pallet, act } => pallets.count(handle, &pallet, act),
            _ => Event::Go,
        }
    }
}

/// Waits until the incident count is other than `mark`: the last incident, in words.
async fn until_incident(incidents: &mut watch::Receiver<Snapshot>, mark: u64) -> String {
    loop {
        {
            let now = &incidents.borrow_and_update().incidents;
            if now.count != mark {
                return now.last.clone().unwrap_or_default();
            }
        }
        if incidents.changed().await.is_err() {
            // The robot's worker is gone: nothing more comes.
            std::future::pending::<()>().await;
        }
    }
}
