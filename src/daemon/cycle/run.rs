//! The cycle's driver: one task per cycle, carrying out the actions of its pure
//! [`Runner`] (the program counter, loops, moves prepared ahead, what ends a step) through the
//! robot's handle ([`super::act`]), writing the cycle's status ([`super::status`]), and feeding
//! back what came of each with what it sees ([`super::seen`]: the control, the PLC's
//! incidents, the time). An action on the robot gives way at once to an incident since the
//! epoch the cycle acts under (the runner then faults the cycle).

use std::ops::ControlFlow;

use tokio::sync::watch;

use super::act;
use super::pallet::Palletising;
use super::seen::Sight;
use super::status::Status;
use crate::cycle::runner::{Action, Control, Event, Motion};
use crate::cycle::{Checked, Runner};
use crate::daemon::RobotHandle;
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
    let name = program.name.clone();
    let pallets = Palletising::new(program.pallets.clone());
    let mut sight = Sight::new(handle.watch_snapshot(), control);
    let seen = sight.seen();
    let mut runner = Runner::new(program, count, &seen);
    let mut driver = Driver {
        handle: handle.clone(),
        base: handle,
        sight,
        status: Status(status),
        pallets,
    };
    let mut event = Event::Go;
    let state = loop {
        let action = runner.on(event, &driver.sight.seen());
        // What the cycle asks of the robot is refused once an incident came since its epoch.
        driver.handle = driver.base.under(runner.epoch());
        match driver.carry_out(action, runner.incident_mark()).await {
            ControlFlow::Continue(next) => event = next,
            ControlFlow::Break(state) => break state,
        }
    };
    tracing::info!(robot = %driver.handle.robot().name, program = %name, ?state, "cycle ended");
}

/// What the driver holds: the robot, what it sees, the status.
struct Driver {
    /// The robot, acting under the runner's epoch.
    handle: RobotHandle,
    /// The robot, as any client.
    base: RobotHandle,
    /// The control and the robot's incidents.
    sight: Sight,
    status: Status,
    /// The pallets the program was checked with, and their counters.
    pallets: Palletising,
}

impl Driver {
    /// Carries `action` out: what came of it, or the cycle's final state. An op's action on
    /// the robot gives way to an incident since `mark`.
    async fn carry_out(
        &mut self,
        action: Action<Gate>,
        mark: u64,
    ) -> ControlFlow<CycleState, Event<Gate>> {
        let event = match action {
            Action::End {
                state,
                why,
                unprepare,
            } => {
                act::unprepare(&self.handle, unprepare).await;
                self.status.ended(state, why);
                return ControlFlow::Break(state);
            }
            Action::Stand => self.sight.stand(mark).await,
            Action::Step(_)
            | Action::CycleDone { .. }
            | Action::Unprepare(_)
            | Action::Pause { .. }
            | Action::Fault { .. } => self.cycle(action).await,
            action => {
                let incident = self.sight.incident_since(mark);
                tokio::select! {
                    biased;
                    why = incident => Event::Incident(why),
                    event = self.op(action) => event,
                }
            }
        };
        ControlFlow::Continue(event)
    }

    /// An action of the cycle's own: a step or a cycle said, moves unprepared, a pause, a fault.
    async fn cycle(&mut self, action: Action<Gate>) -> Event<Gate> {
        let robot = &self.handle;
        match action {
            Action::Step(at) => {
                tracing::debug!(robot = %robot.robot().name, step = at.step, "cycle step");
                self.status.step(at);
            }
            Action::CycleDone {
                done,
                took_s,
                waited_s,
            } => {
                robot.cycle_done(took_s);
                self.status.cycle_done(done, took_s, waited_s);
            }
            Action::Unprepare(moves) => act::unprepare(robot, moves).await,
            Action::Pause { why, unprepare } => {
                return act::pause(robot, &self.status, why, unprepare).await;
            }
            Action::Fault {
                why,
                stop_robot,
                interrupted,
                unprepare,
            } => {
                let (base, stop) = (&self.base, (stop_robot, interrupted));
                return act::fault(robot, base, &self.status, why, stop, unprepare).await;
            }
            _ => {}
        }
        Event::Go
    }

    /// An op's action on the robot.
    async fn op(&mut self, action: Action<Gate>) -> Event<Gate> {
        let handle = &self.handle;
        let pallets = &self.pallets;
        let view = |name: &str| pallets.view(handle, name);
        let control = &mut self.sight.control;
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
            Action::Follow(ids) => act::follow_step(handle, &self.status, &ids, control).await,
            Action::Wait { at, until, timeout } => {
                let wait = (&at, &until, timeout);
                act::wait_step(handle, &self.status, wait, &view, control).await
            }
            Action::Write(writes) => act::write(handle, writes).await,
            Action::Dwell(d) => Event::Dwelt(act::dwell(d, control).await),
            Action::Decide(until) => Event::Decided(act::decide(handle, &until, &view).await),
            Action::Pace => Event::Paced(act::pace(handle).await),
            Action::Pallet { pallet, act } => pallets.count(handle, &pallet, act),
            _ => Event::Go,
        }
    }
}
