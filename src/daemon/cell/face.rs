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
//!  line <--read the block-- face_block: the command words, then status_words(View)
//! ```
//! Writes are taken one at a time (a second waits for the first's actions), so the refusal word
//! always answers the last command.

use std::sync::{Mutex, MutexGuard, PoisonError};

use crate::cell::Mode;
use crate::cell::face::{
    Action, BLOCK_WORDS, COMMAND_WORDS, CyclePhase, CycleView, Face, Link, Refusal, STATUS_AT,
    View, status_words,
};
use crate::config::FaceSettings;
use crate::daemon::request::{CommandError, ConflictReason};
use crate::daemon::{CycleError, CycleState, MoveOrder, RobotHandle, RobotPhase};

/// A robot's cell face: its settings and its command side.
#[derive(Debug)]
pub(crate) struct FaceCell {
    settings: FaceSettings,
    face: Mutex<Face>,
    /// One write's actions at a time.
    turn: tokio::sync::Mutex<()>,
}

impl FaceCell {
    pub(crate) fn new(settings: FaceSettings) -> Self {
        Self {
            settings,
            face: Mutex::new(Face::new()),
            turn: tokio::sync::Mutex::new(()),
        }
    }

    fn face(&self) -> MutexGuard<'_, Face> {
        self.face.lock().unwrap_or_else(PoisonError::into_inner)
    }

    pub(crate) fn mode_changed(&self) {
        self.face().mode_changed();
    }

    fn refuse(&self, why: Refusal) {
        self.face().refuse(why);
    }
}

impl RobotHandle {
    /// The robot's cell face settings, if it has one.
    #[must_use]
    pub fn face_settings(&self) -> Option<&FaceSettings> {
        self.cell.face.as_ref().map(|f| &f.settings)
    }

    /// The face's command side, for the robot's state.
    pub(crate) fn face_state(&self) -> Option<crate::wire::FaceState> {
        let cell = self.cell.face.as_ref()?;
        let face = cell.face();
        Some(crate::wire::FaceState {
            program: face.selected().map_or(0, |(n, _)| u16::from(n)),
            program_name: face.selected().map(|(_, name)| name.to_owned()),
            enabled: face.enabled(),
            commands: face.words()[crate::cell::face::command::BITS],
            refused: face.refused().map(|r| crate::daemon::FaceRefusal {
                code: r.code(),
                meaning: r.meaning().to_owned(),
            }),
        })
    }

    /// Whether the face holds every motion: remote mode with move-enable off.
    pub(crate) fn face_holds_motion(&self) -> bool {
        self.cell
            .face
            .as_ref()
            .is_some_and(|f| !f.face().enabled() && self.mode() == Mode::Remote)
    }

    /// The face's block now: the command words as written, reserved words 0, the status words.
    #[must_use]
    pub fn face_block(&self) -> Option<[u16; BLOCK_WORDS]> {
        let cell = self.cell.face.as_ref()?;
        let view = self.face_view(&cell.settings);
        let face = cell.face();
        let mut block = [0; BLOCK_WORDS];
        block[..COMMAND_WORDS].copy_from_slice(&face.words());
        block[STATUS_AT..].copy_from_slice(&status_words(&face, &view));
        Some(block)
    }

    /// The line wrote `values` from command word `at` (within the command words): the actions
    /// its edges ask for are carried out before this returns. `false` when the robot has no face.
    pub async fn face_write(&self, at: usize, values: &[u16]) -> bool {
        let Some(cell) = &self.cell.face else {
            return false;
        };
        let _turn = cell.turn.lock().await;
        let refusals = cell.face().refusals();
        let actions = cell.face().write(at, values, self.mode());
        for action in actions {
            tracing::info!(robot = %self.robot().name, ?action, "cell face command");
            self.shared.metrics.face_command(action.name());
            if let Err(why) = self.face_act(cell, &action).await {
                tracing::warn!(robot = %self.robot().name, ?action, refused = why.code(), "cell face command refused: {}", why.meaning());
                cell.refuse(why);
            }
        }
        let face = cell.face();
        if let Some(why) = face.refused().filter(|_| face.refusals() > refusals) {
            self.shared.metrics.face_refused(why.code());
        }
        true
    }

    async fn face_act(&self, cell: &FaceCell, action: &Action) -> Result<(), Refusal> {
        match action {
            Action::Hold => {
                self.cycles.hold("move-enable dropped on the cell face");
                let _ = self.stop_robot().await;
                Ok(())
            }
            Action::StopNow => {
                let _ = self.stop().await;
                Ok(())
            }
            Action::Stop => {
                // Nothing to stop is no refusal: a stop is always taken.
                let _ = self.cycles.stop(false);
                Ok(())
            }
            Action::Reset => {
                self.owned_by(Mode::Remote)
                    .await
                    .map_err(|_| Refusal::Local)?;
                match self.clear_fault().await {
                    Ok(()) => Ok(()),
                    Err(CommandError::Conflict {
                        reason: ConflictReason::NoFault,
                    }) => Err(Refusal::NotNow),
                    Err(_) => Err(Refusal::NotReady),
                }
            }
            Action::Pause => {
                let _owner = self
                    .owned_by(Mode::Remote)
                    .await
                    .map_err(|_| Refusal::Local)?;
                self.pause_cycle().map(|_| ()).map_err(|_| Refusal::NotNow)
            }
            Action::Select { number } => {
                let name = self.program_numbered(*number)?;
                cell.face().select(*number, &name);
                Ok(())
            }
            Action::Start { count } => self.face_start(cell, *count).await,
            Action::Home => self.face_home(&cell.settings).await,
        }
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

    async fn face_start(&self, cell: &FaceCell, count: Option<u64>) -> Result<(), Refusal> {
        let _owner = self
            .owned_by(Mode::Remote)
            .await
            .map_err(|_| Refusal::Local)?;
        if let Some(c) = self.cycle().filter(|c| !c.state.is_final()) {
            return match c.state {
                CycleState::Paused | CycleState::Faulted => {
                    self.resume_cycle().map(|_| ()).map_err(|e| match e {
                        CycleError::FaultNotCleared { .. } => Refusal::FaultNotCleared,
                        _ => Refusal::NotNow,
                    })
                }
                _ => Err(Refusal::Busy),
            };
        }
        let selected = cell.face().selected().map(|(_, name)| name.to_owned());
        let program = selected.ok_or(Refusal::NotSelected)?;
        let state = self.state();
        if state.current_move.is_some() || !state.queued.is_empty() {
            return Err(Refusal::Busy);
        }
        if state.refuses.is_some() {
            return Err(Refusal::NotReady);
        }
        self.run_cycle(&program, count).map(|_| ()).map_err(|e| {
            tracing::warn!(robot = %self.robot().name, program, "cell face start refused: {e}");
            match e {
                CycleError::Running { .. } | CycleError::Conflict { .. } => Refusal::Busy,
                _ => Refusal::ProgramRefused,
            }
        })
    }

    async fn face_home(&self, settings: &FaceSettings) -> Result<(), Refusal> {
        let _owner = self
            .owned_by(Mode::Remote)
            .await
            .map_err(|_| Refusal::Local)?;
        if self.cycle().is_some_and(|c| !c.state.is_final()) {
            return Err(Refusal::Busy);
        }
        self.position(&settings.home).map_err(|_| Refusal::NoHome)?;
        let order = MoveOrder {
            position: Some(settings.home.clone()),
            ..MoveOrder::default()
        };
        self.submit(order).await.map(|_| ()).map_err(|e| {
            tracing::warn!(robot = %self.robot().name, "cell face home refused: {e}");
            Refusal::NotReady
        })
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
        let taught = self.positions();
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
        }
    }
}
