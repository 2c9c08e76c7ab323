//! A cycle's pallet steps on the robot: the counter changes the runner asks for, made in the
//! daemon's pallet store (on disk before the answer) and journaled; the way into and out of the
//! slot in progress, queued as paths; and what a condition reads of a pallet.
//!
//! ```text
//!   Begin / Arrived / Advance / SlotDone / Restart   the store's change (Counter), Counted(None) once it
//!                                         is written, Counted(Some(why)) when it is not
//!   Advance, SlotDone                     journal: pallet_placed (slot, layer from 1), and
//!                                         pallet_full when that slot was the last
//!   the way in   from where the next order begins -> approach waypoints -> the slot
//!   the way out  the slot -> retreat waypoints
//! ```
//! A way is cut where its speed changes (a path has one speed): the stretches at one speed are
//! one path, stopped at its corners but the approach's first point when the pattern blends it
//! (`approach.blend_mm`, passed without a stop from wherever the robot comes, unless the
//! blended path would chain a part behind one too short for a serial link: then stopped there
//! too), and the paths are checked, planned one from the end of the other and queued together
//! ([`RobotHandle::submit_paths_or_stopped`]), or all refused before anything moves. The slots
//! are the patterns the program was checked against ([`crate::cycle::Checked`]).

use std::collections::BTreeMap;

use serde_json::json;
use thiserror::Error;

use crate::cycle::PalletView;
use crate::cycle::check::{Leg, PalletAct};
use crate::cycle::runner::Event;
use crate::daemon::RobotHandle;
use crate::daemon::gate::Gate;
use crate::daemon::pallets::PalletStoreError;
use crate::geometry::Pose;
use crate::order::PathOrder;
use crate::pallet::counter::Phase;
use crate::pallet::{Pattern, Slot, Waypoint};
use crate::wire::journal::Kind;

/// Closer than this to where the robot will be, a way's first waypoint is passed over, mm.
const HERE_MM: f64 = 0.01;
/// Closer than this in tool angle, rad.
const HERE_RAD: f64 = 1e-6;

/// Why a pallet step cannot be taken (the runner reads it in words).
#[derive(Debug, Error)]
enum PalletStepError {
    /// The step names a pallet the program was not checked with.
    #[error("pallet {pallet:?} is not one the program was checked with")]
    NotChecked { pallet: String },
    /// The store refused the counter's change.
    #[error(transparent)]
    Store(#[from] PalletStoreError),
    /// A way in or out with no slot to lead to.
    #[error(
        "pallet {pallet:?} has no slot in progress to go {into} (counter at slot {index}{interrupted})",
        into = if *.leg == Leg::In { "into" } else { "out of" },
        interrupted = if *.interrupted {
            ", its last place interrupted: the operator chooses redo or go on"
        } else {
            ""
        }
    )]
    NoSlot {
        pallet: String,
        leg: Leg,
        index: usize,
        /// The counter's last place was interrupted.
        interrupted: bool,
    },
}

/// The pallets a cycle runs: the patterns its program was checked against, by name.
pub(super) struct Palletising {
    patterns: BTreeMap<String, Pattern>,
}

impl Palletising {
    pub(super) fn new(patterns: BTreeMap<String, Pattern>) -> Self {
        Self { patterns }
    }

    fn pattern(&self, pallet: &str) -> Result<&Pattern, PalletStepError> {
        self.patterns
            .get(pallet)
            .ok_or_else(|| PalletStepError::NotChecked {
                pallet: pallet.to_owned(),
            })
    }

    /// Changes `pallet`'s counter (on disk before this returns): `Counted(None)`, or why not.
    pub(super) fn count(&self, handle: &RobotHandle, pallet: &str, act: PalletAct) -> Event<Gate> {
        Event::Counted(
            self.change(handle, pallet, act)
                .err()
                .map(|e| e.to_string()),
        )
    }

    fn change(
        &self,
        handle: &RobotHandle,
        pallet: &str,
        act: PalletAct,
    ) -> Result<(), PalletStepError> {
        let pattern = self.pattern(pallet)?;
        let len = pattern.len();
        let robot = handle.robot().name.as_str();
        let store = handle.pallet_counters();
        match act {
            PalletAct::Begin => store.change(robot, pallet, |c| c.begin(pallet, len).map(drop)),
            PalletAct::Arrived => store.change(robot, pallet, |c| c.arrived(pallet).map(drop)),
            PalletAct::Restart => store.change(robot, pallet, |c| {
                c.restart();
                Ok(())
            }),
            PalletAct::Advance | PalletAct::SlotDone => {
                let (slot, full) = store.change(robot, pallet, |c| {
                    let slot = if act == PalletAct::SlotDone {
                        c.slot_done(pallet, len)?
                    } else {
                        c.advance_step(pallet, len)?
                    };
                    Ok((slot, c.full))
                })?;
                let journal = handle.journal();
                let layer = pattern.slot(slot).map_or(0, |s| s.layer);
                journal.pallet_placed(robot, pallet, from_1(slot), from_1(layer));
                if full {
                    journal.pallet_full(robot, pallet, u32::try_from(len).unwrap_or(u32::MAX));
                }
                return Ok(());
            }
        }
        .map_err(PalletStepError::from)
    }

    /// The PLC restarted under the cycle (its outputs went off, the gripper let go wherever the
    /// robot was): every slot of the robot's pallets in progress becomes unsure, on disk, and
    /// the journal says which; the cycle places on none of them until the operator chooses.
    pub(super) fn interrupted(handle: &RobotHandle) {
        let robot = handle.robot().name.as_str();
        let journal = handle.journal();
        match handle.pallet_counters().interrupted(robot) {
            Ok(unsure) => {
                for (pallet, slot) in unsure {
                    let reason = format!(
                        "pallet {pallet:?}: slot {} was in progress when the PLC restarted (its \
                         outputs went off): whether the part is on it is unsure; choose redo or \
                         go on",
                        from_1(slot)
                    );
                    tracing::warn!(robot, "{reason}");
                    journal.record(Some(robot), Kind::Fault { code: None, reason });
                }
            }
            Err(e) => {
                let reason = format!("the PLC restarted mid-place and {e}");
                tracing::error!(robot, "{reason}");
                journal.record(Some(robot), Kind::Fault { code: None, reason });
            }
        }
    }

    /// `pallet`'s counter as a condition reads it (`None`: not one of the program's pallets).
    pub(super) fn view(&self, handle: &RobotHandle, pallet: &str) -> Option<PalletView> {
        let pattern = self.patterns.get(pallet)?;
        let c = handle.pallet_counters().get(&handle.robot().name, pallet);
        let layer_of = |i: usize| pattern.slot(i).map(|s| s.layer);
        let last_layer = pattern.slots().last().map_or(0, |s| s.layer);
        let layer = layer_of(c.index).unwrap_or(last_layer);
        let begins_layer = !c.full && c.index > 0 && layer_of(c.index) != layer_of(c.index - 1);
        Some(PalletView {
            index: c.index,
            layer,
            begins_layer,
            full: c.full,
        })
    }

    /// Queues the way into (or out of) `pallet`'s slot in progress: its starts, or why it was
    /// refused (naming the pallet and the slot).
    pub(super) async fn submit(
        &self,
        handle: &RobotHandle,
        pallet: &str,
        leg: Leg,
        speed_mm_s: Option<f64>,
    ) -> Event<Gate> {
        let slot = match self.slot_in_progress(handle, pallet, leg) {
            Ok(slot) => slot,
            Err(why) => return Event::Refused(why.to_string()),
        };
        let from = handle
            .where_next_begins()
            .map(|counts| handle.robot().pose_of(&counts));
        let way = way(slot, leg);
        let orders = paths(&way, from.as_ref(), speed_mm_s);
        if orders.is_empty() {
            // The robot is there already.
            return Event::Queued(Vec::new());
        }
        let stopped = stopped_instead(&way, &orders, from.as_ref(), speed_mm_s);
        match handle.submit_paths_or_stopped(&orders, &stopped).await {
            Ok(ids) => Event::Queued(ids),
            Err(e) => Event::Refused(format!(
                "pallet {pallet:?} slot {} (layer {}), {}: {e}",
                slot.index,
                slot.layer,
                match leg {
                    Leg::In => "the way in",
                    Leg::Out => "the way out",
                }
            )),
        }
    }

    /// The slot a way leads into or out of: the counter's slot in progress, or (the way out
    /// after the slot was counted done) the slot just filled.
    fn slot_in_progress(
        &self,
        handle: &RobotHandle,
        pallet: &str,
        leg: Leg,
    ) -> Result<&Slot, PalletStepError> {
        let pattern = self.pattern(pallet)?;
        let c = handle.pallet_counters().get(&handle.robot().name, pallet);
        let index = match (c.in_progress, leg) {
            (Some(p), _) if p.phase != Phase::Unsure => Some(p.slot),
            (None, Leg::Out) => c.index.checked_sub(1),
            _ => None,
        };
        index
            .and_then(|i| pattern.slot(i))
            .ok_or_else(|| PalletStepError::NoSlot {
                pallet: pallet.to_owned(),
                leg,
                index: c.index,
                interrupted: c.needs_choice().is_some(),
            })
    }
}

/// A slot's layer or index counted from 1, as the journal counts them.
fn from_1(i: usize) -> u32 {
    u32::try_from(i + 1).unwrap_or(u32::MAX)
}

/// The way's stretches, in order: where each ends, its speed (`None`: the step's) and the
/// blend of the corner there (`None`: a stop).
fn way(slot: &Slot, leg: Leg) -> Vec<(Pose, Option<f64>, Option<f64>)> {
    let stretch = |w: &Waypoint| (w.pose, w.speed_mm_s, w.blend_mm);
    match leg {
        Leg::In => slot
            .approach
            .iter()
            .map(stretch)
            .chain([(slot.pose, slot.slot_speed_mm_s, None)])
            .collect(),
        Leg::Out => slot.retreat.iter().map(stretch).collect(),
    }
}

/// For each of `orders` (the way's paths) that blends a corner, the same path with its corners
/// stops, run instead where the blended one would chain a part behind one too short for a
/// serial link ([`RobotHandle::submit_paths_or_stopped`]).
fn stopped_instead(
    way: &[(Pose, Option<f64>, Option<f64>)],
    orders: &[PathOrder],
    from: Option<&Pose>,
    step_speed_mm_s: Option<f64>,
) -> Vec<Option<PathOrder>> {
    let unblended: Vec<_> = way
        .iter()
        .map(|&(pose, speed, _)| (pose, speed, None))
        .collect();
    let stopped = paths(&unblended, from, step_speed_mm_s);
    // A blend never changes where a way is cut: the same runs, one for one.
    debug_assert_eq!(stopped.len(), orders.len());
    orders
        .iter()
        .zip(stopped)
        .map(|(order, stopped)| (order.path != stopped.path).then_some(stopped))
        .collect()
}

/// The way as paths, one per run of stretches at one speed; a corner within a run is blended
/// where its waypoint asks for it (the approach's first point), every other corner a stop; a
/// first waypoint where the robot will be already (`from`) passed over, its corner with it.
fn paths(
    way: &[(Pose, Option<f64>, Option<f64>)],
    from: Option<&Pose>,
    step_speed_mm_s: Option<f64>,
) -> Vec<PathOrder> {
    let at = |a: &Pose, b: &Pose| {
        (a.position_mm - b.position_mm).norm() < HERE_MM && (a.a_rad - b.a_rad).abs() < HERE_RAD
    };
    let skip = match (way.first(), from) {
        (Some((first, ..)), Some(from)) if at(first, from) => 1,
        _ => 0,
    };
    let way = &way[skip..];
    let speed_of = |k: usize| way.get(k).map(|(_, speed, _)| speed.or(step_speed_mm_s));
    let mut runs: Vec<(Option<f64>, Vec<serde_json::Value>)> = Vec::new();
    for (k, (pose, _, blend_mm)) in way.iter().enumerate() {
        let speed = speed_of(k).flatten();
        let mut element = json!({ "line": pose.to_mm_deg() });
        // A corner is blended only inside a run: the next stretch at the same speed.
        if let Some(mm) = blend_mm.filter(|_| speed_of(k + 1) == Some(speed)) {
            element["blend"] = json!(format!("{mm}mm"));
        }
        match runs.last_mut() {
            Some((s, elements)) if *s == speed => elements.push(element),
            _ => runs.push((speed, vec![element])),
        }
    }
    runs.into_iter()
        .map(|(speed_mm_s, elements)| PathOrder {
            path: json!({ "linterpd_path": 1, "element": elements }),
            motion: crate::order::OrderMotion {
                speed_mm_s,
                ..Default::default()
            },
            ..PathOrder::default()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slot() -> Slot {
        let p = |z| Pose::from_mm_deg(-1000.0, 600.0, z, 0.0);
        Slot {
            index: 0,
            layer: 0,
            row: 0,
            column: 0,
            pose: p(100.0),
            approach: vec![
                Waypoint {
                    pose: p(180.0),
                    speed_mm_s: None,
                    blend_mm: None,
                },
                Waypoint {
                    pose: p(130.0),
                    speed_mm_s: None,
                    blend_mm: None,
                },
            ],
            slot_speed_mm_s: Some(40.0),
            retreat: vec![
                Waypoint {
                    pose: p(130.0),
                    speed_mm_s: Some(40.0),
                    blend_mm: None,
                },
                Waypoint {
                    pose: p(180.0),
                    speed_mm_s: None,
                    blend_mm: None,
                },
            ],
        }
    }

    fn lines(order: &PathOrder) -> Vec<f64> {
        order.path["element"]
            .as_array()
            .unwrap()
            .iter()
            .map(|e| e["line"][2].as_f64().unwrap())
            .collect()
    }

    #[test]
    fn the_way_in_is_cut_where_its_speed_changes_and_ends_on_the_slot_at_the_slow_speed() {
        let orders = paths(&way(&slot(), Leg::In), None, Some(300.0));
        assert_eq!(orders.len(), 2);
        assert_eq!(orders[0].motion.speed_mm_s, Some(300.0));
        assert_eq!(lines(&orders[0]), [180.0, 130.0]);
        assert_eq!(orders[1].motion.speed_mm_s, Some(40.0));
        assert_eq!(lines(&orders[1]), [100.0]);
        // Every order is a path document the daemon reads, its corners stops.
        for o in &orders {
            let doc = crate::config::PathDoc::from_json(o.path.clone()).unwrap();
            assert!(
                doc.elements
                    .iter()
                    .all(|e| e.corner == crate::geometry::Corner::Stop)
            );
        }
    }

    #[test]
    fn the_way_out_leaves_slowly_and_a_first_waypoint_where_the_robot_is_is_passed_over() {
        let orders = paths(&way(&slot(), Leg::Out), None, None);
        assert_eq!(orders.len(), 2);
        assert_eq!(
            (orders[0].motion.speed_mm_s, lines(&orders[0])),
            (Some(40.0), vec![130.0])
        );
        assert_eq!(
            (orders[1].motion.speed_mm_s, lines(&orders[1])),
            (None, vec![180.0])
        );
        let s = slot();
        let above = s.approach[0].pose;
        let orders = paths(&way(&s, Leg::In), Some(&above), None);
        assert_eq!(lines(&orders[0]), [130.0]);
        let orders = paths(&way(&s, Leg::In)[2..], Some(&s.pose), None);
        assert!(orders.is_empty());
    }

    /// The corners of each order, as the daemon reads its path document.
    fn corners(order: &PathOrder) -> Vec<crate::geometry::Corner> {
        crate::config::PathDoc::from_json(order.path.clone())
            .unwrap()
            .elements
            .iter()
            .map(|e| e.corner)
            .collect()
    }

    /// The approach's first point blended: the corner there (between the line from where the
    /// robot comes and the line toward the slot, at one speed) is a blend of the path; passed
    /// over (the robot there already), or ending a run (the next stretch slower), it is none.
    #[test]
    fn the_approachs_first_point_is_blended_only_where_a_run_goes_on_through_it() {
        use crate::geometry::Corner::{Blend, Stop};
        let mut s = slot();
        s.approach[0].blend_mm = Some(30.0);
        let orders = paths(&way(&s, Leg::In), None, Some(300.0));
        assert_eq!(orders.len(), 2);
        assert_eq!(corners(&orders[0]), [Blend(30.0), Stop]);
        assert_eq!(corners(&orders[1]), [Stop]);
        // The robot there already: the corner is passed over with its point.
        let above = s.approach[0].pose;
        let orders = paths(&way(&s, Leg::In), Some(&above), Some(300.0));
        assert_eq!(corners(&orders[0]), [Stop]);
        // No slow stretch, the slot at the step's speed: blended into the line to the slot.
        let mut direct = s.clone();
        direct.approach.truncate(1);
        direct.slot_speed_mm_s = None;
        let orders = paths(&way(&direct, Leg::In), None, Some(300.0));
        assert_eq!(orders.len(), 1);
        assert_eq!(corners(&orders[0]), [Blend(30.0), Stop]);
        // The line after it slower (the slot at its own speed): a stop, the run ends there.
        direct.slot_speed_mm_s = Some(40.0);
        let orders = paths(&way(&direct, Leg::In), None, Some(300.0));
        assert_eq!(orders.len(), 2);
        assert_eq!(corners(&orders[0]), [Stop]);
    }
}
