//! The operator's side of a robot's pallets (the API, the CLI, the cell face): every pallet's
//! count, and the operator's changes (set, reset, redo, go on), each written to the state
//! directory before it is answered.
//!
//! ```text
//!                  no cycle, or paused,    cycle running or waiting
//!                  faulted, stopped, done
//!  set, reset      taken                   refused (cycle-running): the cycle owns the count
//!  redo, go on     taken (a slot in        taken only for a slot waiting for the choice
//!                  progress to choose for) (unsure: the cycle cannot place on the pallet)
//! ```
//! The mode does not matter: a change of a count moves nothing (the face's redo and go on are
//! taken in remote mode only, as its other commands).

use thiserror::Error;

use super::RobotHandle;
use crate::daemon::pallets::PalletStoreError;
use crate::pallet::{Choice, Counter, CounterError};
use crate::wire::{CycleState, PalletList, PalletStatus};

/// An operator's change of a pallet's count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PalletCommand {
    /// The next slot is `index` (from 0; the pallet's slots: full); the slot in progress is
    /// forgotten, the counts kept.
    Set(usize),
    /// A new pallet: slot 0 next (a full pallet counted as done).
    Reset,
    /// The interrupted slot's part was not placed: place at that slot again.
    Redo,
    /// The interrupted slot's part was placed: count it, go on at the next slot.
    GoOn,
}

impl PalletCommand {
    /// Its name in the API's path (`set`, `reset`, `redo`, `go-on`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Set(_) => "set",
            Self::Reset => "reset",
            Self::Redo => "redo",
            Self::GoOn => "go-on",
        }
    }

    /// Whether it is the operator's choice for an interrupted slot.
    fn is_choice(self) -> bool {
        matches!(self, Self::Redo | Self::GoOn)
    }

    fn apply(self, pallet: &str, c: &mut Counter, len: usize) -> Result<(), CounterError> {
        match self {
            Self::Set(index) => c.set(pallet, index, len),
            Self::Reset => {
                c.restart();
                Ok(())
            }
            Self::Redo => c.choose(pallet, Choice::Redo, len),
            Self::GoOn => c.choose(pallet, Choice::GoOn, len),
        }
    }
}

/// Why an operator's change of a pallet was refused (nothing changed).
#[derive(Debug, Error)]
pub enum PalletOpError {
    /// The robot has no pallet of that name.
    #[error("robot {robot} has no pallet {pallet:?}; {}", pallets_named(known))]
    NoPallet {
        /// The robot.
        robot: String,
        /// The pallet asked for.
        pallet: String,
        /// Its pallets.
        known: Vec<String>,
    },
    /// The robot's cycle runs and may change the count itself.
    #[error(
        "cycle {program} is {state} on robot {robot}: pallet {pallet:?} takes {command} only \
         while no cycle runs, or it is paused, faulted or ended{}; pause or stop it first",
        if *choice { " (or the pallet has a slot waiting for redo or go on)" } else { "" }
    )]
    CycleRunning {
        /// The robot.
        robot: String,
        /// The cycle's program.
        program: String,
        /// `running` or `waiting`.
        state: &'static str,
        /// The pallet.
        pallet: String,
        /// What was asked.
        command: &'static str,
        /// Whether it was a choice (redo, go on).
        choice: bool,
    },
    /// The counter refused it, or the pallets file could not be written.
    #[error(transparent)]
    Store(#[from] PalletStoreError),
}

fn pallets_named(known: &[String]) -> String {
    if known.is_empty() {
        "it has none ([robots.NAME.pallets.NAME])".to_owned()
    } else {
        format!("its pallets: {}", known.join(", "))
    }
}

impl RobotHandle {
    /// Each pallet's slots' layers in fill order, by name (from the config's layouts: known
    /// without the taught positions).
    fn pallet_shapes(&self) -> Vec<(String, Vec<usize>)> {
        self.pallets
            .sets
            .get(&self.robot.name)
            .map(|set| {
                let layouts = set.layouts.iter();
                layouts.map(|(n, l)| (n.clone(), l.slot_layers())).collect()
            })
            .unwrap_or_default()
    }

    /// Whether the pallet's count is known (not lost with a corrupt or unreadable file).
    fn pallet_known(&self, pallet: &str) -> bool {
        let counters = &self.pallets.counters;
        counters.warning().is_none() || counters.of(&self.robot.name).contains_key(pallet)
    }

    fn status_of(&self, name: &str, layers: &[usize]) -> PalletStatus {
        let counter = self.pallets.counters.get(&self.robot.name, name);
        PalletStatus::new(name, &counter, layers, self.pallet_known(name))
    }

    /// Every pallet of the robot with its count, and the pallets file's warning.
    #[must_use]
    pub fn pallets(&self) -> PalletList {
        let shapes = self.pallet_shapes();
        PalletList {
            pallets: shapes.iter().map(|(n, l)| self.status_of(n, l)).collect(),
            warning: self.pallets.counters.warning().map(str::to_owned),
        }
    }

    /// Pallet `name`'s count.
    ///
    /// # Errors
    /// [`PalletOpError::NoPallet`] naming the pallets there are.
    pub fn pallet(&self, name: &str) -> Result<PalletStatus, PalletOpError> {
        let layers = self.pallet_layers(name)?;
        Ok(self.status_of(name, &layers))
    }

    fn pallet_layers(&self, name: &str) -> Result<Vec<usize>, PalletOpError> {
        let shapes = self.pallet_shapes();
        let known = shapes.iter().map(|(n, _)| n.clone()).collect();
        shapes
            .into_iter()
            .find(|(n, _)| n == name)
            .map(|(_, l)| l)
            .ok_or_else(|| PalletOpError::NoPallet {
                robot: self.robot.name.clone(),
                pallet: name.to_owned(),
                known,
            })
    }

    /// The operator's change of pallet `name`'s count, written to the state directory before
    /// it returns the pallet's count after it.
    ///
    /// # Errors
    /// No such pallet; refused while the cycle runs (see the module's table); the counter's
    /// refusal (an index past the pallet's slots, nothing to choose for); the file not written.
    pub fn pallet_command(
        &self,
        name: &str,
        command: PalletCommand,
    ) -> Result<PalletStatus, PalletOpError> {
        let layers = self.pallet_layers(name)?;
        self.cycle_allows(name, command)?;
        let len = layers.len();
        let counters = &self.pallets.counters;
        counters.set_by_operator(&self.robot.name, name, |c| command.apply(name, c, len))?;
        tracing::info!(robot = %self.robot.name, pallet = name, command = ?command, "pallet changed by the operator");
        Ok(self.status_of(name, &layers))
    }

    /// Refused while a cycle runs or waits, but a choice for a slot waiting for one.
    fn cycle_allows(&self, pallet: &str, command: PalletCommand) -> Result<(), PalletOpError> {
        let Some(cycle) = self.cycle() else {
            return Ok(());
        };
        let state = match cycle.state {
            CycleState::Running => "running",
            CycleState::Waiting => "waiting",
            _ => return Ok(()),
        };
        let counter = self.pallets.counters.get(&self.robot.name, pallet);
        if command.is_choice() && counter.needs_choice().is_some() {
            return Ok(());
        }
        Err(PalletOpError::CycleRunning {
            robot: self.robot.name.clone(),
            program: cycle.program,
            state,
            pallet: pallet.to_owned(),
            command: command.name(),
            choice: command.is_choice(),
        })
    }
}
