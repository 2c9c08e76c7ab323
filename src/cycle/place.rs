//! PURE. A `place`, `pick` or `advance` step flattened into ops, against the robot's pallet
//! patterns:
//!
//! ```text
//!   Skip unless pallet begins a layer -> (the pallet's between_layers program, inlined)
//!   Pallet Begin          the slot marked in progress, on disk (refused while one is unsure)
//!   PalletPath In         from where the robot is, through the approach, into the slot
//!   Pallet Arrived        the robot at the slot, on disk
//!   (the at_slot steps)   set / wait / dwell: the gripper
//!   Pallet SlotDone       the slot done, on disk          (not with advance = false)
//!   PalletPath Out        through the retreat
//!   Skip unless pallet full -> set signal, wait for wait_for, call, reset signal, Restart
//! ```
//!
//! Every slot of a pallet a program uses, and its approach and retreat waypoints, is checked
//! against the robot's reach and joint limits once, naming the slot.

use super::check::{Flat, Flattener, Here, Leg, Op, OpKind, PalletAct, ProgramError};
use super::condition::{self, Condition, PalletTerm};
use super::step::{Action, PalletStep};
use crate::pallet::Pattern;
use crate::plan::check_pose;

impl Flattener<'_, '_> {
    /// The pattern named `pallet`, its slots checked against the robot's reach.
    fn pattern(
        &self,
        pallet: &str,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<&Pattern, ProgramError> {
        let Some(pattern) = self.ctx.pallets.get(pallet) else {
            let known: Vec<&str> = self.ctx.pallets.keys().map(String::as_str).collect();
            let known = if known.is_empty() {
                "the robot has none".to_owned()
            } else {
                format!("there are: {}", known.join(", "))
            };
            return Err(here(format!("no pallet {pallet:?}; {known}")));
        };
        for slot in pattern.slots() {
            let poses = std::iter::once(("the slot", &slot.pose))
                .chain(
                    slot.approach
                        .iter()
                        .map(|w| ("an approach waypoint", &w.pose)),
                )
                .chain(slot.retreat.iter().map(|w| ("a retreat waypoint", &w.pose)));
            for (what, pose) in poses {
                check_pose(self.ctx.robot, pose).map_err(|e| {
                    here(format!(
                        "pallet {pallet:?} slot {} (layer {}): {what} {:?} cannot be reached: {e}",
                        slot.index,
                        slot.layer,
                        pose.to_mm_deg()
                    ))
                })?;
            }
        }
        Ok(pattern)
    }

    /// Every pallet `until` reads is one of the robot's.
    pub(super) fn pallets_known(
        &self,
        until: &Condition,
        here: &dyn Fn(String) -> ProgramError,
    ) -> Result<(), ProgramError> {
        for pallet in until.pallets() {
            if !self.ctx.pallets.contains_key(pallet) {
                let known: Vec<&str> = self.ctx.pallets.keys().map(String::as_str).collect();
                return Err(here(format!(
                    "condition reads pallet {pallet:?}, which the robot does not have (pallets: {})",
                    if known.is_empty() {
                        "none".to_owned()
                    } else {
                        known.join(", ")
                    }
                )));
            }
        }
        Ok(())
    }

    fn push_op(&mut self, here: &Here<'_>, kind: OpKind, does: String) {
        self.ops.push(Op {
            at: here.at(does),
            kind,
            permit: crate::contract::Permit::NONE,
        });
    }

    /// A skip over the ops pushed by `body` unless `term` holds of `pallet`.
    fn unless(
        &mut self,
        here: &Here<'_>,
        pallet: &str,
        term: PalletTerm,
        body: impl FnOnce(&mut Self) -> Result<(), ProgramError>,
    ) -> Result<(), ProgramError> {
        let unless = Condition::Pallet {
            pallet: pallet.to_owned(),
            term,
        };
        let at = self.ops.len();
        let does = format!("unless {unless}: skip");
        self.push_op(here, OpKind::Skip { unless, to: 0 }, does);
        body(self)?;
        let end = self.ops.len();
        if let OpKind::Skip { to, .. } = &mut self.ops[at].kind {
            *to = end;
        }
        Ok(())
    }

    /// A place (or pick) step's ops.
    pub(super) fn place(
        &mut self,
        step: &PalletStep,
        pick: bool,
        here: &Here<'_>,
        chain: &mut Vec<String>,
    ) -> Result<(), ProgramError> {
        let pallet = step.pallet.as_str();
        let pattern = self.pattern(pallet, &|r| here.fail(r))?;
        if let Some(program) = pattern.between_layers.clone() {
            self.unless(here, pallet, PalletTerm::BeginsLayer, |f| {
                f.call(&program, chain, here)
            })?;
        }
        let verb = if pick { "pick from" } else { "place on" };
        let path = |leg| way(pallet, leg, step.speed_mm_s);
        self.push_op(
            here,
            counter(pallet, PalletAct::Begin),
            format!("{verb} {pallet}: next slot in progress"),
        );
        self.push_op(here, path(Leg::In), format!("{verb} {pallet}: approach"));
        self.push_op(
            here,
            counter(pallet, PalletAct::Arrived),
            format!("{verb} {pallet}: at the slot"),
        );
        for (i, s) in step.at_slot.iter().enumerate() {
            self.at_slot(i + 1, &s.action, here)?;
        }
        if step.advance {
            let done = format!("{verb} {pallet}: slot done");
            self.push_op(here, counter(pallet, PalletAct::SlotDone), done);
        }
        self.push_op(here, path(Leg::Out), format!("{verb} {pallet}: retreat"));
        if step.advance {
            self.when_full(pallet, here, chain)?;
        }
        Ok(())
    }

    /// One at-slot step: an output, a wait (no `on_timeout`: it would jump out of the place) or
    /// a dwell.
    fn at_slot(&mut self, n: usize, action: &Action, here: &Here<'_>) -> Result<(), ProgramError> {
        let fail = |r: String| here.fail(format!("at_slot step {n}: {r}"));
        let allowed = match action {
            Action::Set(_) | Action::Dwell(_) => true,
            Action::Wait(w) => w.on_timeout.as_deref().is_none_or(|t| t == "fault"),
            _ => false,
        };
        if !allowed {
            return Err(fail(
                "runs with the robot at the slot: set, wait (without on_timeout) or dwell".into(),
            ));
        }
        match self.step(action, &fail)? {
            Flat::Op(kind, does) => self.push_op(here, kind, does),
            _ => unreachable!("a set, a wait without on_timeout and a dwell are ops"),
        }
        Ok(())
    }

    /// An `advance` step's ops: the slot done, then the pallet's when-full.
    pub(super) fn advance(
        &mut self,
        pallet: &str,
        here: &Here<'_>,
        chain: &mut Vec<String>,
    ) -> Result<(), ProgramError> {
        self.pattern(pallet, &|r| here.fail(r))?;
        let kind = counter(pallet, PalletAct::Advance);
        self.push_op(here, kind, format!("advance {pallet}"));
        self.when_full(pallet, here, chain)
    }

    /// What runs when the pallet is full: its signal set, its wait, its call, the signal reset,
    /// the counter back to slot 0.
    fn when_full(
        &mut self,
        pallet: &str,
        here: &Here<'_>,
        chain: &mut Vec<String>,
    ) -> Result<(), ProgramError> {
        let when = self.pattern(pallet, &|r| here.fail(r))?.when_full.clone();
        let fail = |r: String| here.fail(format!("pallet {pallet:?} when_full: {r}"));
        let until = when
            .wait_for
            .as_deref()
            .map(|text| condition::parse(text, self.ctx.names).map_err(|e| fail(e.to_string())))
            .transpose()?;
        self.unless(here, pallet, PalletTerm::Full, |f| {
            if let Some(key) = &when.signal {
                f.full_signal(here, pallet, key, true)?;
            }
            if let Some(until) = until {
                // No timeout: an empty pallet comes when someone brings it.
                let does = format!("{pallet} full: wait for {until}");
                let kind = OpKind::Wait {
                    until,
                    timeout: None,
                    on_timeout: None,
                };
                f.push_op(here, kind, does);
            }
            if let Some(program) = &when.call {
                f.call(program, chain, here)?;
            }
            if let Some(key) = &when.signal {
                f.full_signal(here, pallet, key, false)?;
            }
            let does = format!("{pallet} full: the next pallet from slot 0");
            f.push_op(here, counter(pallet, PalletAct::Restart), does);
            Ok(())
        })
    }

    /// Pushes the op that sets full pallet `pallet`'s signal `key` `on`.
    fn full_signal(
        &mut self,
        here: &Here<'_>,
        pallet: &str,
        key: &str,
        on: bool,
    ) -> Result<(), ProgramError> {
        let fail = |r: String| here.fail(format!("pallet {pallet:?} when_full: {r}"));
        let write = self.write(key, &toml::Value::Boolean(on), &fail)?;
        let does = format!("{pallet} full: set {key} = {on}");
        self.push_op(here, OpKind::Set(vec![write]), does);
        Ok(())
    }
}

/// The op that goes `leg` of `pallet`'s slot in progress, at `speed_mm_s` where the pattern gives
/// none.
fn way(pallet: &str, leg: Leg, speed_mm_s: Option<f64>) -> OpKind {
    OpKind::PalletPath {
        pallet: pallet.to_owned(),
        leg,
        speed_mm_s,
    }
}

/// The op that changes `pallet`'s counter by `act`.
fn counter(pallet: &str, act: PalletAct) -> OpKind {
    OpKind::Pallet {
        pallet: pallet.to_owned(),
        act,
    }
}
