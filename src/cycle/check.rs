//! PURE. A program checked whole against its robot and cell before anything runs, and flattened
//! into the ops the runner carries out: every name resolved (positions, signals, labels, called
//! programs), every value inside its limit, every call inlined (a recursion refused, naming the
//! chain), every jump an index. An error names the program, the step (its number from 1 and its
//! label) and the value.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::time::Duration;

use thiserror::Error;

use super::condition::{self, Condition, Names};
use super::program::{LoopDoc, ProgramDoc};
use super::step::{Action, PalletStep, Step, WaitStep};
use crate::config::{DurationError, parse_duration_s};
use crate::contract::Permit;
use crate::gateway::Values;
use crate::gateway::{Address, Area, Range};
use crate::order::{MoveOrder, OrderLimits, PathOrder};
use crate::pallet::Pattern;
use crate::robot::Position;
use crate::robot::Robot;
use crate::wire::StepAt;

/// The longest a wait's timeout may be, s (a shift).
pub const MAX_TIMEOUT_S: f64 = 12.0 * 3600.0;
/// The longest a dwell may be, s.
pub const MAX_DWELL_S: f64 = 3600.0;
/// The most ops a program may flatten into (calls inlined).
pub const MAX_OPS: usize = 10_000;

/// Why a program cannot run.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("program {program:?}{}: {reason}", at_step(*step, label.as_deref()))]
pub struct ProgramError {
    /// The program.
    pub program: String,
    /// The step, from 1 (`None`: the program as a whole).
    pub step: Option<usize>,
    /// The step's label.
    pub label: Option<String>,
    /// What is wrong, naming the value.
    pub reason: String,
}

fn at_step(step: Option<usize>, label: Option<&str>) -> String {
    match (step, label) {
        (Some(n), Some(l)) => format!(" step {n} ({l})"),
        (Some(n), None) => format!(" step {n}"),
        _ => String::new(),
    }
}

/// What a program is checked against.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The robot.
    pub robot: &'a Robot,
    /// Its taught positions now.
    pub taught: &'a BTreeMap<String, Position>,
    /// Its signals, input words and gateway access list.
    pub names: Names<'a>,
    /// Every program of the robot, by name (for `call`).
    pub programs: &'a BTreeMap<String, ProgramDoc>,
    /// The robot's programs that could not be read, by name, with why.
    pub broken: &'a BTreeMap<String, String>,
    /// Whether every wait needs a timeout.
    pub require_wait_timeout: bool,
    /// The robot's counts where the program will begin (the run's), when known: the first
    /// motion is checked from there ([`super::reach`]).
    pub start: Option<[i64; crate::kinematics::JOINTS]>,
    /// Whether `taught` holds the poses the positions were taught at (the daemon's); `false`
    /// (`check-config`, which knows only their names): a move to a position is checked for its
    /// name only, its reach when it runs.
    pub poses_known: bool,
    /// The robot's pallet patterns, by name (for `place`, `pick`, `advance` and pallet
    /// conditions).
    pub pallets: &'a BTreeMap<String, Pattern>,
}

/// How a loop ends.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LoopExit {
    /// After the steps from its label ran this many times.
    Count(u64),
    /// Once the condition holds at the loop step.
    Until(Condition),
    /// Never by itself: a stop request ends the cycle.
    Stop,
}

/// What one op does.
#[derive(Debug, Clone, PartialEq)]
pub enum OpKind {
    /// A move (its permit, if any, in the order).
    Move(MoveOrder),
    /// A path (its permit, if any, in the order).
    Path(PathOrder),
    /// A wait on the cell's inputs.
    Wait {
        /// The condition.
        until: Condition,
        /// The longest it may take.
        timeout: Option<Duration>,
        /// Where to go on when it times out (`None`: the cycle faults).
        on_timeout: Option<usize>,
    },
    /// Outputs written, in order.
    Set(Vec<(Address, Values)>),
    /// A pause.
    Dwell(Duration),
    /// A pallet's counter changed (on disk before the next op).
    Pallet {
        /// The pallet.
        pallet: String,
        /// The change.
        act: PalletAct,
    },
    /// The way into (or out of) the pallet's slot in progress, as one blended path from where
    /// the robot is.
    PalletPath {
        /// The pallet.
        pallet: String,
        /// Into the slot or out of it.
        leg: Leg,
        /// The speed where the pattern gives none, mm/s.
        speed_mm_s: Option<f64>,
    },
    /// On to op `to` unless the condition holds (a pallet's between-layers and when-full steps).
    Skip {
        /// The condition the ops after this one run under.
        unless: Condition,
        /// The op after them.
        to: usize,
    },
    /// A jump back to op `to` until `exit`.
    Loop {
        /// The op jumped to.
        to: usize,
        /// When it stops jumping.
        exit: LoopExit,
    },
}

/// A change of a pallet's counter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PalletAct {
    /// The next slot marked in progress (refused while the last one waits for the operator).
    Begin,
    /// The robot is at the slot: its at-slot steps begin.
    Arrived,
    /// An `advance` step: the counter moves on (refused while a slot is unsure).
    Advance,
    /// A place's slot is done: the counter moves on, only from the slot the robot reached.
    SlotDone,
    /// The full pallet was changed: the counter starts again at slot 0.
    Restart,
}

/// A pallet path's leg.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Leg {
    /// Through the slot's approach waypoints into the slot.
    In,
    /// From the slot through its retreat waypoints.
    Out,
}

/// One op and the step it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Op {
    /// The step, as the status names it.
    pub at: StepAt,
    /// What it does.
    pub kind: OpKind,
    /// A move's or a path's permit, resolved once when the program is checked
    /// ([`Permit::NONE`]: none, or not a motion).
    pub permit: Permit,
}

/// A checked program: its ops, calls inlined.
#[derive(Debug, Clone, PartialEq)]
pub struct Checked {
    /// Its name.
    pub name: String,
    /// Its number, if it has one.
    pub number: Option<u8>,
    /// Its ops, in order.
    pub ops: Vec<Op>,
    /// The motions whose start depends on the run, checked when they run (one line each,
    /// naming the step).
    pub unchecked: Vec<String>,
    /// The ops that are runs of blended move steps (`super::blend`), by index.
    pub blended: Vec<usize>,
    /// The patterns of the robot's pallets as the program was checked against them, by name:
    /// its place and pick steps run these slots (a frame re-taught later changes the next
    /// check, not a cycle under way).
    pub pallets: BTreeMap<String, Pattern>,
}

/// Program `name` of `ctx.programs` flattened into its ops, with every program it calls, each
/// step checked on its own (its reach is checked after, by [`super::check`]).
///
/// # Errors
/// The first fault found, naming the program, the step and the value.
pub(super) fn flatten(name: &str, ctx: &Context<'_>) -> Result<Checked, ProgramError> {
    let whole = |reason: String| ProgramError {
        program: name.to_owned(),
        step: None,
        label: None,
        reason,
    };
    if let Some(why) = ctx.broken.get(name) {
        return Err(whole(format!("cannot be read: {why}")));
    }
    let Some(doc) = ctx.programs.get(name) else {
        return Err(whole(format!(
            "no such program; {}",
            there_are(ctx.programs, ctx.broken)
        )));
    };
    let number = number(name, doc)?;
    if let Some(n) = number
        && let Some(other) = ctx
            .programs
            .iter()
            .find(|(other, d)| *other != name && d.number == Some(i64::from(n)))
            .map(|(other, _)| other)
    {
        return Err(whole(format!(
            "number = {n} is program {other:?}'s number too: neither runs until one is \
             renumbered"
        )));
    }
    let mut ops = Vec::new();
    let mut blended = Vec::new();
    Flattener {
        ctx,
        ops: &mut ops,
        blended: &mut blended,
    }
    .program(name, &mut vec![name.to_owned()], &[])?;
    Ok(Checked {
        name: name.to_owned(),
        number,
        ops,
        unchecked: Vec::new(),
        blended,
        pallets: ctx.pallets.clone(),
    })
}

/// The programs there are, in words: those that can be read, and apart, those that cannot.
#[must_use]
pub fn there_are(
    programs: &BTreeMap<String, ProgramDoc>,
    broken: &BTreeMap<String, String>,
) -> String {
    let names: Vec<&str> = programs.keys().map(String::as_str).collect();
    let mut text = if names.is_empty() {
        "there are none".to_owned()
    } else {
        format!("there are: {}", names.join(", "))
    };
    if !broken.is_empty() {
        let broken: Vec<&str> = broken.keys().map(String::as_str).collect();
        let _ = write!(text, " (and, unreadable: {})", broken.join(", "));
    }
    text
}

fn number(name: &str, doc: &ProgramDoc) -> Result<Option<u8>, ProgramError> {
    doc.number
        .map(|n| {
            u8::try_from(n)
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| ProgramError {
                    program: name.to_owned(),
                    step: None,
                    label: None,
                    reason: format!("number = {n}: must be 1..=255"),
                })
        })
        .transpose()
}

pub(super) struct Flattener<'c, 'o> {
    pub(super) ctx: &'c Context<'c>,
    pub(super) ops: &'o mut Vec<Op>,
    /// The ops that are runs of blended move steps.
    pub(super) blended: &'o mut Vec<usize>,
}

/// The step being flattened: what its errors and its ops name.
pub(super) struct Here<'a> {
    program: &'a str,
    /// From 1.
    pub(super) step: usize,
    label: Option<&'a String>,
    called_from: &'a [String],
}

impl Here<'_> {
    pub(super) fn fail(&self, reason: String) -> ProgramError {
        ProgramError {
            program: self.program.to_owned(),
            step: Some(self.step),
            label: self.label.cloned(),
            reason,
        }
    }

    /// The step `by` steps after this one in its program, labelled `label`.
    pub(super) fn later<'b>(&'b self, by: usize, label: Option<&'b String>) -> Here<'b> {
        Here {
            program: self.program,
            step: self.step + by,
            label,
            called_from: self.called_from,
        }
    }

    pub(super) fn at(&self, does: String) -> StepAt {
        StepAt {
            program: self.program.to_owned(),
            step: self.step,
            label: self.label.cloned(),
            does,
            called_from: self.called_from.to_vec(),
        }
    }
}

/// A jump to a label, resolved once the program's labels are known.
struct Fixup {
    op: usize,
    label: String,
    step: usize,
    step_label: Option<String>,
    backward_only: bool,
}

/// What a step turns into before its jumps are resolved.
pub(super) enum Flat {
    /// An op.
    Op(OpKind, String),
    /// A move or a path, with its permit resolved.
    Motion(OpKind, String, Permit),
    /// An op that jumps to a label (a loop; a wait's `on_timeout`).
    Jump {
        kind: OpKind,
        does: String,
        to: String,
        backward_only: bool,
    },
    /// Another program, inlined here.
    Call(String),
    /// A place (`pick` true: a pick) at a pallet's slot.
    Pallet(PalletStep, bool),
    /// A pallet advanced.
    Advance(String),
}

impl Flattener<'_, '_> {
    fn program(
        &mut self,
        name: &str,
        chain: &mut Vec<String>,
        called_from: &[String],
    ) -> Result<(), ProgramError> {
        let doc = &self.ctx.programs[name];
        if doc.step.is_empty() {
            return Err(ProgramError {
                program: name.to_owned(),
                step: None,
                label: None,
                reason: "has no step".to_owned(),
            });
        }
        let mut labels: BTreeMap<String, usize> = BTreeMap::new();
        let mut fixups = Vec::new();
        let mut i = 0;
        while let Some(written) = doc.step.get(i) {
            let here = Here {
                program: name,
                step: i + 1,
                label: written.label.as_ref(),
                called_from,
            };
            if let Some(label) = &written.label
                && labels.insert(label.clone(), self.ops.len()).is_some()
            {
                return Err(here.fail(format!("label {label:?} is used by an earlier step too")));
            }
            let step = Step::try_from(written).map_err(|e| here.fail(e.to_string()))?;
            i += if step.blend_mm.is_some() {
                self.blended(&doc.step[i..], &step, &here)?
            } else {
                let flat = self.step(&step.action, &|r| here.fail(r))?;
                self.push(flat, &here, chain, &mut fixups)?;
                1
            };
            if self.ops.len() > MAX_OPS {
                return Err(here.fail(format!(
                    "flattens into more than {MAX_OPS} steps (calls inlined)"
                )));
            }
        }
        self.resolve(name, &labels, fixups)
    }

    /// A flattened step into the ops: an op, a jump to resolve, or the program it calls.
    fn push(
        &mut self,
        flat: Flat,
        here: &Here<'_>,
        chain: &mut Vec<String>,
        fixups: &mut Vec<Fixup>,
    ) -> Result<(), ProgramError> {
        let (kind, does, permit) = match flat {
            Flat::Call(callee) => return self.call(&callee, chain, here),
            Flat::Pallet(step, pick) => return self.place(&step, pick, here, chain),
            Flat::Advance(pallet) => return self.advance(&pallet, here, chain),
            Flat::Op(kind, does) => (kind, does, Permit::NONE),
            Flat::Motion(kind, does, permit) => (kind, does, permit),
            Flat::Jump {
                kind,
                does,
                to,
                backward_only,
            } => {
                fixups.push(Fixup {
                    op: self.ops.len(),
                    label: to,
                    step: here.step,
                    step_label: here.label.cloned(),
                    backward_only,
                });
                (kind, does, Permit::NONE)
            }
        };
        self.ops.push(Op {
            at: here.at(does),
            kind,
            permit,
        });
        Ok(())
    }

    /// A run of blended move steps' path op, at its first step.
    pub(super) fn push_blended(
        &mut self,
        here: &Here<'_>,
        kind: OpKind,
        does: String,
        permit: Permit,
    ) {
        self.blended.push(self.ops.len());
        self.ops.push(Op {
            at: here.at(does),
            kind,
            permit,
        });
    }

    /// Program `callee` inlined at `here`: refused when it is a recursion, unreadable or
    /// missing.
    pub(super) fn call(
        &mut self,
        callee: &str,
        chain: &mut Vec<String>,
        here: &Here<'_>,
    ) -> Result<(), ProgramError> {
        if chain.iter().any(|c| c == callee) {
            return Err(here.fail(format!(
                "call = {callee:?} is a recursion: {} -> {callee}",
                chain.join(" -> ")
            )));
        }
        if let Some(why) = self.ctx.broken.get(callee) {
            return Err(here.fail(format!("call = {callee:?}: cannot be read: {why}")));
        }
        if !self.ctx.programs.contains_key(callee) {
            return Err(here.fail(format!(
                "call = {callee:?}: no such program; {}",
                there_are(self.ctx.programs, self.ctx.broken)
            )));
        }
        let mut from = here.called_from.to_vec();
        from.push(format!("{} step {}", here.program, here.step));
        chain.push(callee.to_owned());
        self.program(callee, chain, &from)?;
        chain.pop();
        Ok(())
    }

    /// Points every jump of program `name` at its label's op.
    fn resolve(
        &mut self,
        name: &str,
        labels: &BTreeMap<String, usize>,
        fixups: Vec<Fixup>,
    ) -> Result<(), ProgramError> {
        for f in fixups {
            let fail = |reason: String| ProgramError {
                program: name.to_owned(),
                step: Some(f.step),
                label: f.step_label.clone(),
                reason,
            };
            let Some(&to) = labels.get(&f.label) else {
                let known: Vec<&str> = labels.keys().map(String::as_str).collect();
                let known = if known.is_empty() {
                    "none".to_owned()
                } else {
                    known.join(", ")
                };
                return Err(fail(format!(
                    "no step is labelled {:?} in this program (labels: {known})",
                    f.label
                )));
            };
            match &mut self.ops[f.op].kind {
                OpKind::Loop { to: target, .. } => {
                    if f.backward_only && to > f.op {
                        return Err(fail(format!(
                            "loop to {:?} jumps forward: a loop jumps back",
                            f.label
                        )));
                    }
                    *target = to;
                }
                OpKind::Wait { on_timeout, .. } => *on_timeout = Some(to),
                _ => {}
            }
        }
        Ok(())
    }

    pub(super) fn step(
        &self,
        action: &Action,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<Flat, ProgramError> {
        match action {
            Action::Move(order) => self.move_step(order, here),
            Action::Path(order) => self.path_step(order, here),
            Action::Wait(wait) => self.wait_step(wait, here),
            Action::Set(set) => self.set_step(set, here),
            Action::Dwell(text) => {
                let d = duration("dwell", text, MAX_DWELL_S).map_err(|e| here(e.to_string()))?;
                Ok(Flat::Op(OpKind::Dwell(d), format!("dwell {text}")))
            }
            Action::Call(callee) => Ok(Flat::Call(callee.clone())),
            Action::Loop(l) => self.loop_step(l, here),
            Action::Place(step) => Ok(Flat::Pallet(step.clone(), false)),
            Action::Pick(step) => Ok(Flat::Pallet(step.clone(), true)),
            Action::Advance(pallet) => Ok(Flat::Advance(pallet.clone())),
        }
    }

    /// A step's permit resolved (none: [`Permit::NONE`]): once, here; it travels with the op.
    fn permit(
        &self,
        permit: Option<&str>,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<Permit, ProgramError> {
        permit.map_or(Ok(Permit::NONE), |p| {
            crate::order::permit::resolve(p, self.ctx.names.permit).map_err(|e| here(e.to_string()))
        })
    }

    pub(super) fn move_step(
        &self,
        order: &MoveOrder,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<Flat, ProgramError> {
        let permit = self.permit(order.permit.as_deref(), here)?;
        let robot = self.ctx.robot;
        order
            .check_with(robot.motion, &OrderLimits::of(robot), self.ctx.taught)
            .map_err(|e| here(format!("move: {e}")))?;
        let does = describe_move(order);
        Ok(Flat::Motion(OpKind::Move(order.clone()), does, permit))
    }

    pub(super) fn path_step(
        &self,
        order: &PathOrder,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<Flat, ProgramError> {
        let permit = self.permit(order.permit.as_deref(), here)?;
        let robot = self.ctx.robot;
        order
            .check(robot, &OrderLimits::of(robot))
            .map_err(|e| here(format!("path: {e}")))?;
        let does = match &order.permit {
            Some(p) => format!("path (permit {p})"),
            None => "path".to_owned(),
        };
        Ok(Flat::Motion(OpKind::Path(order.clone()), does, permit))
    }

    fn wait_step(
        &self,
        wait: &WaitStep,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<Flat, ProgramError> {
        let text = &wait.until;
        let until =
            condition::parse(text, self.ctx.names).map_err(|e| here(format!("wait: {e}")))?;
        self.pallets_known(&until, here)?;
        let timeout = wait
            .timeout
            .as_deref()
            .map(|t| duration("timeout", t, MAX_TIMEOUT_S))
            .transpose()
            .map_err(|e| here(e.to_string()))?;
        if timeout.is_none() && self.ctx.require_wait_timeout {
            return Err(here(format!(
                "wait = {text:?} has no timeout, and [robots.NAME.cell] require_wait_timeout = true"
            )));
        }
        let does = format!("wait for {until}");
        let kind = OpKind::Wait {
            until,
            timeout,
            on_timeout: None,
        };
        match wait.on_timeout.as_deref() {
            None | Some("fault") => Ok(Flat::Op(kind, does)),
            Some(_) if timeout.is_none() => Err(here(
                "on_timeout without a timeout never happens".to_owned(),
            )),
            Some(label) => Ok(Flat::Jump {
                kind,
                does,
                to: label.to_owned(),
                backward_only: false,
            }),
        }
    }

    fn set_step(
        &self,
        set: &BTreeMap<String, toml::Value>,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<Flat, ProgramError> {
        if set.is_empty() {
            return Err(here("set = {} writes nothing".to_owned()));
        }
        let mut writes = Vec::new();
        let mut does = Vec::new();
        for (key, value) in set {
            writes.push(self.write(key, value, here)?);
            does.push(format!("{key} = {value}"));
        }
        Ok(Flat::Op(
            OpKind::Set(writes),
            format!("set {}", does.join(", ")),
        ))
    }

    /// One output of a `set`: its address (a signal's, or written out) and its value, in the
    /// gateway's access list and the value's range.
    pub(super) fn write(
        &self,
        key: &str,
        value: &toml::Value,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<(Address, Values), ProgramError> {
        let signals = self.ctx.names.permit.signals;
        let address = match signals.get(key) {
            Some(a) => *a,
            None => key.parse::<Address>().map_err(|_| {
                here(format!(
                    "set: {key:?} is neither a signal nor an address (Y0, R20, DT100)"
                ))
            })?,
        };
        let range = Range::from_count(address, 1)
            .ok_or_else(|| here(format!("set: {address} does not exist")))?;
        self.ctx
            .names
            .access
            .check_write(&range)
            .map_err(|e| here(format!("set: {key} = {value}: {e}")))?;
        let values = match (address.area, value) {
            (Area::Dt, toml::Value::Integer(v)) if (-32_768..=65_535).contains(v) => {
                Values::Words(vec![*v as u16])
            }
            (Area::Dt, _) => {
                return Err(here(format!(
                    "set: {key} = {value}: a DT word takes a whole number in -32768..=65535"
                )));
            }
            (_, toml::Value::Boolean(on)) => Values::Bits(vec![*on]),
            (_, _) => {
                return Err(here(format!(
                    "set: {key} = {value}: a bit takes true or false"
                )));
            }
        };
        Ok((address, values))
    }

    fn loop_step(
        &self,
        l: &LoopDoc,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<Flat, ProgramError> {
        let exit = match (l.count, l.until.as_deref()) {
            (Some(_), Some(_)) => {
                return Err(here("loop has count and until: give one".to_owned()));
            }
            (Some(c), None) => {
                let c = u64::try_from(c)
                    .ok()
                    .filter(|&c| c >= 1)
                    .ok_or_else(|| here(format!("loop count = {c}: must be at least 1")))?;
                LoopExit::Count(c)
            }
            (None, Some("stop")) => LoopExit::Stop,
            (None, Some(text)) => {
                let until = condition::parse(text, self.ctx.names)
                    .map_err(|e| here(format!("loop until: {e}")))?;
                self.pallets_known(&until, here)?;
                LoopExit::Until(until)
            }
            (None, None) => {
                return Err(here(format!(
                    "loop to {:?} has no exit: give count, until = \"<condition>\" or until = \"stop\"",
                    l.to
                )));
            }
        };
        let label = &l.to;
        let does = match &exit {
            LoopExit::Count(c) => format!("loop to {label} ({c} times in all)"),
            LoopExit::Until(c) => format!("loop to {label} until {c}"),
            LoopExit::Stop => format!("loop to {label} until stopped"),
        };
        Ok(Flat::Jump {
            kind: OpKind::Loop { to: 0, exit },
            does,
            to: label.clone(),
            backward_only: true,
        })
    }
}

/// A step's duration (a wait's timeout, a dwell) that cannot be.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum DurationFault {
    /// Not a duration.
    #[error("{key} = {text:?}: {source}")]
    Unparsed {
        /// The key.
        key: &'static str,
        /// Its text.
        text: String,
        /// Why.
        #[source]
        source: DurationError,
    },
    /// Not above 0 or past its longest.
    #[error("{key} = {text:?}: must be above 0 s and at most {max_s} s")]
    OutOfRange {
        /// The key.
        key: &'static str,
        /// Its text.
        text: String,
        /// The longest it may be, s.
        max_s: f64,
    },
}

fn duration(key: &'static str, text: &str, max_s: f64) -> Result<Duration, DurationFault> {
    let s = parse_duration_s(text).map_err(|source| DurationFault::Unparsed {
        key,
        text: text.to_owned(),
        source,
    })?;
    if !(s > 0.0 && s <= max_s) {
        return Err(DurationFault::OutOfRange {
            key,
            text: text.to_owned(),
            max_s,
        });
    }
    Ok(Duration::from_secs_f64(s))
}

pub(super) fn describe_move(order: &MoveOrder) -> String {
    let target = if let Some(p) = &order.position {
        format!("move to @{p}")
    } else if let Some(to) = &order.to {
        format!("move to {to:?}")
    } else if let Some(by) = &order.by {
        format!("move by {by:?}")
    } else if let Some(j) = &order.joints {
        format!("joint move to {j:?}")
    } else {
        "move".to_owned()
    };
    match &order.permit {
        Some(p) => format!("{target} (permit {p})"),
        None => target,
    }
}
