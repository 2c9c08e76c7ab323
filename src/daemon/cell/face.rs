//! The cell face's daemon side: the command words the line wrote, the actions their edges ask
//! for carried out through the robot's handle (in remote mode, as the face's owner), and the
//! status words composed from what the robot does. The register layout and the edge logic are
//! pure (`crate::cell::face`); the Modbus face serves the block (`modbus_face/`).
//!
//! ```text
//!  line --write command words--> face_write: Face::write (edges) --> actions, one by one:
//!     Hold      cycle held (paused, its move counted held), the robot stopped now
//!     StopNow   RobotHandle::stop            Stop   the cycle stops at the step's end
//!     Reset     clear_fault                  Pause  pause_cycle
//!     Select    the program with that number, from the programs directory
//!     Start     resume a paused or faulted cycle, or run the selected program
//!     Home      a move to the `home` position
//!     PalletRedo, PalletGoOn   the shown pallet's choice (RobotHandle::pallet_command)
//!  line <--read the block-- face_block: the command words, then status_words(View)
//! ```
//! Writes are taken one at a time (a second waits for the first's actions), so the refusal word
//! always answers the last command.

use super::CellOwner;
use crate::cell::Mode;
use crate::cell::face::{
    Action, BLOCK_WORDS, COMMAND_WORDS, CyclePhase, CycleView, Link, PalletView, Refusal,
    STATUS_AT, View, status_words,
};
use crate::config::FaceSettings;
use crate::daemon::pallets::PalletStoreError;
use crate::daemon::request::{CellRequest, CommandError, ConflictReason, CycleError};
use crate::daemon::{CycleState, MoveOrder, PalletCommand, PalletOpError, RobotHandle, RobotPhase};
use crate::pallet::CounterError;

impl RobotHandle {
    /// The face's block now: the command words as written, reserved words 0, the status words.
    #[must_use]
    pub fn face_block(&self) -> Option<[u16; BLOCK_WORDS]> {
        let settings = self.face_settings()?;
        let view = self.face_view(settings);
        let cell = self.cell();
        let face = cell.face.as_ref()?;
        let mut block = [0; BLOCK_WORDS];
        block[..COMMAND_WORDS].copy_from_slice(&face.words());
        block[STATUS_AT..].copy_from_slice(&status_words(face, &view));
        Some(block)
    }

    /// The line wrote `values` from command word `at` (within the command words): the actions
    /// its edges ask for are carried out before this returns. `false` when the robot has no face.
    pub async fn face_write(&self, at: usize, values: &[u16]) -> bool {
        let values = values.to_vec();
        self.ask_cell(|reply| CellRequest::FaceWrite { at, values, reply })
            .await
            .unwrap_or(false)
    }

    /// The program whose `number` is `number`.
    fn program_numbered(&self, number: u8) -> Result<String, Refusal> {
        let live = self.live.get();
        let dir = live.cell.programs.as_ref().ok_or(Refusal::UnknownProgram)?;
        let programs = crate::cycle::load::programs(dir).map_err(|e| {
            tracing::warn!(robot = %self.robot().name, "cell face: the programs cannot be read: {e}");
            Refusal::UnknownProgram
        })?;
        match programs.numbered(number) {
            Ok(name) => Ok(name.to_owned()),
            Err(none) if none.is_empty() => Err(Refusal::UnknownProgram),
            Err(shared) => {
                tracing::warn!(robot = %self.robot().name, number, programs = %shared.join(", "), "cell face: program number {number} is shared by programs {}: neither runs until one is renumbered", shared.join(" and "));
                Err(Refusal::ProgramRefused)
            }
        }
    }

    /// What the status words need of the robot now.
    fn face_view(&self, settings: &FaceSettings) -> View {
        let state = self.state();
        let link = match state.phase {
            RobotPhase::LinkDown | RobotPhase::NotPublished => Link::Down,
            RobotPhase::Stalled => Link::Stalled,
            _ => Link::Up,
        };
        let linked = link != Link::Down;
        let moving = state.current_move.is_some() || !state.queued.is_empty();
        let counts = self.counts_by_joint().filter(|_| linked && !moving);
        // A position kept in a frame that cannot be carried to the world is at no counts.
        let taught = self.taught_world().unwrap_or_default();
        let at = |name: &str| {
            counts.is_some_and(|c| taught.get(name).is_some_and(|p| p.joint_counts == c))
        };
        let position = settings
            .positions
            .iter()
            .position(|name| at(name))
            .and_then(|i| u16::try_from(i + 1).ok());
        let cycle = state.cycle.as_ref().map(|c| CycleView {
            phase: match c.state {
                CycleState::Running => CyclePhase::Running,
                CycleState::Waiting => CyclePhase::Waiting,
                CycleState::Paused => CyclePhase::Paused,
                CycleState::Faulted => CyclePhase::Faulted,
                CycleState::Stopped | CycleState::Done => CyclePhase::Ended,
            },
            step: c
                .step
                .as_ref()
                .and_then(|s| u16::try_from(s.step).ok())
                .unwrap_or(0),
            done: c.done,
        });
        View {
            mode: self.mode(),
            link,
            accepts_moves: state.refuses.is_none(),
            plc_fault: state.fault.filter(|f| *f != 0),
            moving,
            cycle,
            heartbeat: self.snapshot().reads,
            position,
            in_home: at(&settings.home),
            pallet: self.face_pallet(settings),
        }
    }

    /// The pallet the face shows, as its words need it.
    fn face_pallet(&self, settings: &FaceSettings) -> Option<PalletView> {
        let p = self.pallet(settings.pallet.as_deref()?).ok()?;
        Some(PalletView {
            known: p.known,
            index: p.index,
            slots: p.slots,
            layer: p.layer,
            full: p.full,
            unsure: p.unsure(),
        })
    }
}

impl CellOwner {
    /// The line wrote `values` from command word `at`: the actions its edges ask for carried
    /// out, one by one, through `robot`, the face published after each. `false` when the
    /// robot has no face.
    pub(super) async fn face_write(
        &mut self,
        robot: &RobotHandle,
        at: usize,
        values: &[u16],
    ) -> bool {
        let mode = self.view.mode;
        let Some(face) = self.view.face.as_mut() else {
            return false;
        };
        let refusals = face.refusals();
        let actions = face.write(at, values, mode);
        self.publish();
        let metrics = &robot.shared.metrics;
        for action in actions {
            tracing::info!(robot = %robot.robot().name, ?action, "cell face command");
            metrics.face_command(action.name());
            if let Err(why) = self.face_act(robot, &action).await {
                tracing::warn!(robot = %robot.robot().name, ?action, refused = why.code(), "cell face command refused: {}", why.meaning());
                self.face(|f| f.refuse(why));
            }
        }
        let face = self
            .view
            .face
            .as_ref()
            .expect("the face is never taken away");
        if let Some(why) = face.refused().filter(|_| face.refusals() > refusals) {
            metrics.face_refused(why.code());
        }
        true
    }

    /// Changes the face by `f` and publishes it.
    fn face(&mut self, f: impl FnOnce(&mut crate::cell::face::Face)) {
        if let Some(face) = self.view.face.as_mut() {
            f(face);
            self.publish();
        }
    }

    /// Refused unless the cell face drives the robot (the owner alone changes the mode, so it
    /// holds while the action is carried out).
    fn remote(&self) -> Result<(), Refusal> {
        if self.view.mode == Mode::Remote {
            Ok(())
        } else {
            Err(Refusal::Local)
        }
    }

    async fn face_act(&mut self, robot: &RobotHandle, action: &Action) -> Result<(), Refusal> {
        match action {
            Action::Hold | Action::StopNow | Action::Stop => {
                face_stop(robot, action).await;
                Ok(())
            }
            Action::Reset => {
                self.remote()?;
                face_reset(robot).await
            }
            Action::Pause => {
                self.remote()?;
                robot
                    .pause_cycle()
                    .await
                    .map(|_| ())
                    .map_err(|_| Refusal::NotNow)
            }
            Action::Select { number } => {
                let name = robot.program_numbered(*number)?;
                self.face(|f| f.select(*number, &name));
                Ok(())
            }
            Action::Start { count } => self.face_start(robot, *count).await,
            Action::Home => {
                self.remote()?;
                face_home(robot).await
            }
            Action::PalletRedo | Action::PalletGoOn => {
                self.remote()?;
                face_pallet_choice(robot, action)
            }
        }
    }

    async fn face_start(&self, robot: &RobotHandle, count: Option<u64>) -> Result<(), Refusal> {
        self.remote()?;
        if let Some(c) = robot.cycle().filter(|c| !c.state.is_final()) {
            return match c.state {
                CycleState::Paused | CycleState::Faulted => {
                    robot.resume_cycle().await.map(|_| ()).map_err(|e| match e {
                        CycleError::FaultNotCleared { .. } => Refusal::FaultNotCleared,
                        _ => Refusal::NotNow,
                    })
                }
                _ => Err(Refusal::Busy),
            };
        }
        let selected = self.view.face.as_ref().and_then(|f| f.selected());
        let program = selected
            .map(|(_, name)| name.to_owned())
            .ok_or(Refusal::NotSelected)?;
        let state = robot.state();
        if state.current_move.is_some() || !state.queued.is_empty() {
            return Err(Refusal::Busy);
        }
        if state.refuses.is_some() {
            return Err(Refusal::NotReady);
        }
        robot.run_cycle(&program, count).await.map(|_| ()).map_err(|e| {
            tracing::warn!(robot = %robot.robot().name, program, "cell face start refused: {e}");
            match e {
                CycleError::Running { .. } | CycleError::Conflict { .. } => Refusal::Busy,
                _ => Refusal::ProgramRefused,
            }
        })
    }
}

/// The line's choice for the shown pallet's interrupted slot.
fn face_pallet_choice(robot: &RobotHandle, action: &Action) -> Result<(), Refusal> {
    let choice = match action {
        Action::PalletRedo => PalletCommand::Redo,
        _ => PalletCommand::GoOn,
    };
    let pallet = robot
        .face_settings()
        .and_then(|f| f.pallet.clone())
        .ok_or(Refusal::NoPallet)?;
    robot.pallet_command(&pallet, choice).map(|_| ()).map_err(|e| {
        tracing::warn!(robot = %robot.robot().name, pallet, "cell face pallet {} refused: {e}", choice.name());
        match e {
            PalletOpError::NoPallet { .. } => Refusal::NoPallet,
            PalletOpError::CycleRunning { .. } => Refusal::Busy,
            PalletOpError::Store(PalletStoreError::Counter(CounterError::NothingToChoose {
                ..
            })) => Refusal::NothingToChoose,
            PalletOpError::Store(PalletStoreError::Write { .. } | PalletStoreError::ReadOnly { .. }) => {
                Refusal::PalletNotWritten
            }
            PalletOpError::Store(_) => Refusal::NotNow,
        }
    })
}

/// A stop the face asks (`Hold`, `StopNow`, `Stop`): taken in any mode. Nothing to stop is no
/// refusal: a stop is always taken.
async fn face_stop(robot: &RobotHandle, action: &Action) {
    match action {
        Action::Hold => {
            robot
                .hold_cycle("move-enable dropped on the cell face")
                .await;
            let _ = robot.stop_robot().await;
        }
        Action::StopNow => {
            let _ = robot.stop().await;
        }
        _ => {
            let _ = robot.stop_cycle(false).await;
        }
    }
}

/// The face's reset: the fault cleared (none to clear: not now).
async fn face_reset(robot: &RobotHandle) -> Result<(), Refusal> {
    match robot.clear_fault().await {
        Ok(()) => Ok(()),
        Err(CommandError::Conflict {
            reason: ConflictReason::NoFault,
        }) => Err(Refusal::NotNow),
        Err(_) => Err(Refusal::NotReady),
    }
}

/// A move to the face's `home` position, in remote mode.
async fn face_home(robot: &RobotHandle) -> Result<(), Refusal> {
    if robot.cycle().is_some_and(|c| !c.state.is_final()) {
        return Err(Refusal::Busy);
    }
    let home = robot
        .face_settings()
        .map(|f| f.home.clone())
        .ok_or(Refusal::NoHome)?;
    robot.position(&home).map_err(|_| Refusal::NoHome)?;
    let order = MoveOrder {
        position: Some(home),
        ..MoveOrder::default()
    };
    robot.submit(order).await.map(|_| ()).map_err(|e| {
        tracing::warn!(robot = %robot.robot().name, "cell face home refused: {e}");
        Refusal::NotReady
    })
}
