//! PURE. A step as the check reads it: the document's [`StepDoc`] (eleven optional keys, as
//! TOML and JSON write them) converted once into a [`Step`], its label and one [`Action`] that
//! carries exactly the data that action takes. The rules of the document's shape live here and
//! nowhere else: one action a step, a permit only with a motion (and then in its order), a
//! timeout only with a wait, a blend only with a move, a path step's document read in.

use std::collections::BTreeMap;

use thiserror::Error;

use super::program::{LoopDoc, PalletStepDoc, PathStep, StepDoc};
use crate::order::{MoveOrder, PathOrder};

/// A step, converted: its label and what it does.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// A name other steps jump to.
    pub label: Option<String>,
    /// What it does.
    pub action: Action,
    /// A move's end passed without stopping into the next move, within this distance of it,
    /// mm (checked by `super::blend`).
    pub blend_mm: Option<f64>,
    /// On the first move of a blended run: its path's acceleration, as written (the path
    /// document's `path_accel`, checked with it).
    pub path_accel: Option<serde_json::Value>,
}

/// What a step does, with the data that takes.
#[derive(Debug, Clone, PartialEq)]
pub enum Action {
    /// A move (the step's permit, if any, in the order).
    Move(MoveOrder),
    /// A path, its document read in (the step's permit, if any, in the order).
    Path(PathOrder),
    /// A wait on the cell's inputs.
    Wait(WaitStep),
    /// Outputs to write, as written.
    Set(BTreeMap<String, toml::Value>),
    /// A pause, as written (e.g. `"200ms"`).
    Dwell(String),
    /// Another program run here, by name.
    Call(String),
    /// A jump back to a label.
    Loop(LoopDoc),
    /// A place at a pallet's current slot.
    Place(PalletStep),
    /// A pick from a pallet's current slot.
    Pick(PalletStep),
    /// A pallet advanced to its next slot.
    Advance(String),
}

/// A `place` or `pick` step.
#[derive(Debug, Clone, PartialEq)]
pub struct PalletStep {
    /// The pallet.
    pub pallet: String,
    /// The steps run at the slot, converted.
    pub at_slot: Vec<Step>,
    /// Whether the pallet advances when they ran.
    pub advance: bool,
    /// The approach's and retreat's speed where the pattern gives none, mm/s.
    pub speed_mm_s: Option<f64>,
}

/// A `wait` step's keys.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WaitStep {
    /// The condition, as written.
    pub until: String,
    /// How long it may take, as written.
    pub timeout: Option<String>,
    /// `"fault"` or a label to go on from when it times out.
    pub on_timeout: Option<String>,
}

/// Why a step's keys do not make one step.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ShapeError {
    /// No action key.
    #[error("has no action: one of {}", ACTIONS.join(", "))]
    NoAction,
    /// More than one action key.
    #[error("has {} actions: one step does one", .0.join(" and "))]
    Actions(Vec<&'static str>),
    /// A permit on a step that does not move.
    #[error("permit goes with a move or a path")]
    PermitWithoutMotion,
    /// A timeout on a step that does not wait.
    #[error("timeout and on_timeout go with a wait")]
    TimeoutWithoutWait,
    /// A blend on a step that is not a move.
    #[error("blend_mm goes with a move (a path's corners are blended in its document)")]
    BlendWithoutMove,
    /// A path acceleration on a step that does not blend.
    #[error(
        "path_accel goes with a move that has blend_mm (the acceleration across a blended \
         run's corners; a path step gives it in its document)"
    )]
    PathAccelWithoutBlend,
    /// A permit in the step and in its order.
    #[error("permit is given twice (in the step and in its order)")]
    PermitTwice,
    /// A path step whose file was not read in.
    #[error("path file {0:?} was not read (programs are loaded with their path files)")]
    PathFileUnread(String),
    /// A path step with neither or both of `file` and `path`.
    #[error("a path step has `file` or `path`, one of them")]
    PathSource,
    /// An at-slot step whose own shape is wrong.
    #[error("at_slot step {step}: {source}")]
    AtSlot {
        /// The at-slot step, from 1.
        step: usize,
        /// Why.
        #[source]
        source: Box<ShapeError>,
    },
}

/// The action keys, in the order a message lists them.
const ACTIONS: [&str; 10] = [
    "move", "path", "wait", "set", "dwell", "call", "loop", "place", "pick", "advance",
];

impl TryFrom<&StepDoc> for Step {
    type Error = ShapeError;

    fn try_from(doc: &StepDoc) -> Result<Self, ShapeError> {
        let given = [
            doc.move_.is_some(),
            doc.path.is_some(),
            doc.wait.is_some(),
            doc.set.is_some(),
            doc.dwell.is_some(),
            doc.call.is_some(),
            doc.loop_.is_some(),
            doc.place.is_some(),
            doc.pick.is_some(),
            doc.advance.is_some(),
        ];
        let keys: Vec<&'static str> = ACTIONS
            .iter()
            .zip(given)
            .filter_map(|(k, given)| given.then_some(*k))
            .collect();
        match keys.as_slice() {
            [_] => {}
            [] => return Err(ShapeError::NoAction),
            _ => return Err(ShapeError::Actions(keys)),
        }
        let motion = doc.move_.is_some() || doc.path.is_some();
        if doc.permit.is_some() && !motion {
            return Err(ShapeError::PermitWithoutMotion);
        }
        if (doc.timeout.is_some() || doc.on_timeout.is_some()) && doc.wait.is_none() {
            return Err(ShapeError::TimeoutWithoutWait);
        }
        if doc.blend_mm.is_some() && doc.move_.is_none() {
            return Err(ShapeError::BlendWithoutMove);
        }
        if doc.path_accel.is_some() && (doc.blend_mm.is_none() || doc.move_.is_none()) {
            return Err(ShapeError::PathAccelWithoutBlend);
        }
        Ok(Self {
            label: doc.label.clone(),
            action: action(doc)?,
            blend_mm: doc.blend_mm,
            path_accel: doc.path_accel.clone(),
        })
    }
}

/// The one action of `doc` (its shape checked).
fn action(doc: &StepDoc) -> Result<Action, ShapeError> {
    let permit = doc.permit.as_deref();
    if let Some(order) = &doc.move_ {
        let mut order = order.clone();
        order.permit = merged(permit, order.permit)?;
        return Ok(Action::Move(order));
    }
    if let Some(path) = &doc.path {
        return path_order(path, permit).map(Action::Path);
    }
    if let Some(until) = &doc.wait {
        return Ok(Action::Wait(WaitStep {
            until: until.clone(),
            timeout: doc.timeout.clone(),
            on_timeout: doc.on_timeout.clone(),
        }));
    }
    if let Some(set) = &doc.set {
        return Ok(Action::Set(set.clone()));
    }
    if let Some(text) = &doc.dwell {
        return Ok(Action::Dwell(text.clone()));
    }
    if let Some(callee) = &doc.call {
        return Ok(Action::Call(callee.clone()));
    }
    if let Some(l) = &doc.loop_ {
        return Ok(Action::Loop(l.clone()));
    }
    if let Some(place) = &doc.place {
        return pallet_step(place).map(Action::Place);
    }
    if let Some(pick) = &doc.pick {
        return pallet_step(pick).map(Action::Pick);
    }
    let pallet = doc.advance.as_ref().ok_or(ShapeError::NoAction)?;
    Ok(Action::Advance(pallet.clone()))
}

/// A place or pick step, its at-slot steps converted.
fn pallet_step(doc: &PalletStepDoc) -> Result<PalletStep, ShapeError> {
    let at_slot = doc
        .at_slot
        .iter()
        .enumerate()
        .map(|(i, s)| {
            Step::try_from(s).map_err(|e| ShapeError::AtSlot {
                step: i + 1,
                source: Box::new(e),
            })
        })
        .collect::<Result<_, _>>()?;
    Ok(PalletStep {
        pallet: doc.pallet.clone(),
        at_slot,
        advance: doc.advance.unwrap_or(true),
        speed_mm_s: doc.speed_mm_s,
    })
}

/// The step's permit and its order's: one of them, or neither.
fn merged(step: Option<&str>, order: Option<String>) -> Result<Option<String>, ShapeError> {
    match (step, order) {
        (Some(_), Some(_)) => Err(ShapeError::PermitTwice),
        (Some(p), None) => Ok(Some(p.to_owned())),
        (None, order) => Ok(order),
    }
}

/// A path step as a path order: its document, its motion keys and the permit.
fn path_order(step: &PathStep, permit: Option<&str>) -> Result<PathOrder, ShapeError> {
    let document = match (&step.path, &step.file) {
        (Some(doc), None) => doc.clone(),
        (None, Some(file)) => return Err(ShapeError::PathFileUnread(file.clone())),
        _ => return Err(ShapeError::PathSource),
    };
    Ok(PathOrder {
        path: document,
        motion: step.motion.clone(),
        permit: permit.map(str::to_owned),
    })
}
