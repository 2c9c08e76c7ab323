//! The `bounded-error` method: rows of any length, as few as keep the executed path within a
//! stated tolerance of the planned path (the line; a joint move's tool path), with no period grid.
//!
//! 1. The path is sampled finely ([`SAMPLE_S`]) and solved to every joint's fractional count.
//! 2. The Cartesian tolerance becomes a per-joint pulse budget through the Jacobian: a joint whose
//!    pulse moves the tool `s_j` mm may be `delta_j` pulses off where `s_j * delta_j` is its
//!    share of the tolerance left above the pulse grid's own floor.
//! 3. Every pulse gets a window of landing times ([`pulses`]); rows are the longest runs of
//!    pulses one realisable frequency lands inside their windows (Klipper's step compression,
//!    [`rows`]).
//! 4. The execution model plays the tables; a plan whose path deviation exceeds the tolerance
//!    (or whose tracking error exceeds twice it) is not returned: the windows narrow and it is
//!    planned again, and a tolerance the grid cannot reach is refused with one that works.

mod pulses;
mod rows;

use crate::geometry::Profile;
use crate::kinematics::{JOINTS, Kinematics};
use crate::robot::{Motion, Robot};
use crate::sim::{Execution, Figures, PulseEvent};
use crate::table::ChannelTable;

use super::course::Course;
use super::{PlanError, Samples, Window, simulate_within};
use pulses::{Run, Track};
use rows::Channel;

/// Sample spacing of the trajectory, s.
pub(super) const SAMPLE_S: f64 = 0.001;
/// The first try: every joint's window may take the tool this fraction of `tolerance - floor / 2`
/// off the path. The windows' errors and the pulse grid's rarely peak at the same instant or
/// point the same way, so the grid's floor is counted half; measured on the seed's move and the
/// property suites' random moves, the execution model accepts the first try on most moves (and
/// when it does not, the narrowing search below takes over).
const FIRST_BUDGET: f64 = 0.6;
/// The narrowing search's first windows, relative to the budget left above the floor: the
/// budget adds every joint's error at its worst as if they all pointed the same way, which they
/// rarely do, so the search starts wider and lets the execution model judge.
const FIRST_SCALE: f64 = 2.5;
/// Tries with narrower windows before giving up on a tolerance.
const TRIES: usize = 14;
/// Each retry narrows every window to this fraction.
const NARROWING: f64 = 0.8;
/// The widest window, pulses each side (also for joints that do not move the tool point).
const MAX_DELTA_PULSES: f64 = 8.0;

/// The first try's window scale, relative to the budget left above the floor
/// ([`FIRST_BUDGET`]).
fn first_scale(tolerance_mm: f64, floor_mm: f64) -> f64 {
    FIRST_BUDGET * (tolerance_mm - floor_mm / 2.0) / (tolerance_mm - floor_mm)
}

/// Every joint's window, pulses each side: `budget_mm * scale` over its reach, at most
/// [`MAX_DELTA_PULSES`] (a joint that cannot move the tool gets that much times the scale).
fn deltas(reach: &[f64; JOINTS], scale: f64, budget_mm: f64) -> [f64; JOINTS] {
    reach.map(|r| {
        if r > 0.0 {
            (budget_mm * scale / r).min(MAX_DELTA_PULSES)
        } else {
            MAX_DELTA_PULSES.min(scale * MAX_DELTA_PULSES)
        }
    })
}

/// A verified bounded-error plan's tables and how they ran.
pub(super) struct Verified {
    pub tables: Vec<ChannelTable>,
    pub execution: Execution,
    pub figures: Figures,
    /// The path deviation with every pulse exactly on time (the pulse grid's floor), mm.
    pub floor_mm: f64,
}

/// Everything the method needs about one move.
pub(super) struct Move<'a> {
    pub robot: &'a Robot,
    pub course: &'a Course,
    pub profile: &'a Profile,
    /// The stretch of the profile the samples cover (their point 0 is its start).
    pub window: &'a Window,
    pub samples: &'a Samples,
    pub motion: &'a Motion,
}

impl Move<'_> {
    /// Every joint's fractional count at every sample, joint by joint.
    fn tracks(&self) -> Vec<Vec<f64>> {
        (0..JOINTS)
            .map(|j| {
                let joint = &self.robot.joints[j];
                self.samples
                    .values
                    .iter()
                    .map(|q| (q[j] - joint.offset) / joint.step)
                    .collect()
            })
            .collect()
    }

    fn start_counts(&self) -> [i64; JOINTS] {
        self.samples.counts[0]
    }

    /// How far one pulse of each joint moves the tool point at most, mm: `(whole, off)`, its
    /// whole move, and how far it can take the tool off the path (its move across the path, or
    /// half its move along it, whichever is larger). Only the move across the path counts
    /// towards the path deviation; the move along it counts towards the tracking error, whose
    /// limit is twice the tolerance.
    fn pulse_reach_mm(&self) -> ([f64; JOINTS], [f64; JOINTS]) {
        let n = self.samples.values.len();
        let fk = |q: &crate::kinematics::Joints| self.robot.kinematics.fk(q).position_mm;
        let (mut whole, mut off) = ([0.0f64; JOINTS], [0.0f64; JOINTS]);
        for i in (0..n).step_by((n / 32).max(1)).chain([n - 1]) {
            let q = self.samples.values[i];
            let p = fk(&q);
            let (before, after) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let chord = fk(&self.samples.values[after]) - fk(&self.samples.values[before]);
            let tangent = chord.try_normalize(1e-12);
            for j in 0..JOINTS {
                let mut moved = q;
                moved[j] += self.robot.joints[j].step;
                let d = fk(&moved) - p;
                let across = tangent.map_or(d.norm(), |t| (d - t * d.dot(&t)).norm());
                whole[j] = whole[j].max(d.norm());
                off[j] = off[j].max(across.max(d.norm() / 2.0));
            }
        }
        (whole, off)
    }

    fn runs(&self, tracks: &[Vec<f64>], deltas: &[f64; JOINTS]) -> Vec<Vec<Run>> {
        let start = self.start_counts();
        (0..JOINTS)
            .map(|j| {
                Track {
                    u: &tracks[j],
                    dt_s: self.profile.period_s,
                }
                .runs(start[j], deltas[j])
            })
            .collect()
    }

    /// The path deviation with every pulse landing exactly on time. It does not depend on the
    /// tolerance: computed once per plan, from every joint's on-time pulses merged in time
    /// order (each joint's are already in order).
    fn floor_mm(&self, tracks: &[Vec<f64>]) -> f64 {
        let start = self.start_counts();
        let channels: Vec<Vec<PulseEvent>> = (0..JOINTS)
            .map(|j| {
                let track = Track {
                    u: &tracks[j],
                    dt_s: self.profile.period_s,
                };
                track
                    .on_time(start[j])
                    .into_iter()
                    .map(|(t_s, count)| PulseEvent {
                        t_s,
                        table: j,
                        count,
                    })
                    .collect()
            })
            .collect();
        crate::sim::path_deviation_mm(
            self.robot,
            &start,
            &crate::sim::merge(&channels),
            self.course.tool_path(),
        )
    }

    fn tables(&self, tracks: &[Vec<f64>], deltas: &[f64; JOINTS]) -> Vec<ChannelTable> {
        let start = self.start_counts();
        self.runs(tracks, deltas)
            .iter()
            .enumerate()
            .map(|(j, runs)| {
                let joint = &self.robot.joints[j];
                let channel = Channel {
                    joint,
                    model: self.motion.frequency_model,
                };
                let (mut t_s, mut count, mut segments) = (0.0, start[j], Vec::new());
                for (i, run) in runs.iter().enumerate() {
                    let left = crate::table::MAX_SEGMENTS
                        .saturating_sub(segments.len() + runs.len() - i - 1)
                        .max(1);
                    let (segs, end) = channel.run(run, t_s, count, left);
                    count = run.pulses.last().map_or(count, |p| p.count);
                    t_s = end;
                    segments.extend(segs);
                }
                ChannelTable {
                    channel: joint.channel,
                    start: start[j],
                    segments,
                }
            })
            .collect()
    }

    /// Plans at `tolerance_mm`, narrowing the windows until the execution model agrees.
    pub(super) fn plan(&self, tolerance_mm: f64) -> Result<Verified, PlanError> {
        let tracks = self.tracks();
        let floor_mm = self.floor_mm(&tracks);
        if floor_mm >= tolerance_mm {
            return Err(self.too_tight(&tracks, tolerance_mm, floor_mm));
        }
        match self.try_plan(&tracks, tolerance_mm, floor_mm)? {
            Some(v) => Ok(v),
            None => Err(self.too_tight(&tracks, tolerance_mm, floor_mm)),
        }
    }

    /// One try at the budget that holds on the seed's move, with windows sized by how far a
    /// pulse takes the tool off the path; then the narrowing search, with windows sized by a
    /// pulse's whole move as before the first try existed (`None` if nothing is accepted).
    fn try_plan(
        &self,
        tracks: &[Vec<f64>],
        tolerance_mm: f64,
        floor_mm: f64,
    ) -> Result<Option<Verified>, PlanError> {
        let (whole, off) = self.pulse_reach_mm();
        let first = (off, first_scale(tolerance_mm, floor_mm));
        let narrowing = (0..TRIES).map(|k| (whole, FIRST_SCALE * NARROWING.powi(k as i32)));
        for (reach, scale) in std::iter::once(first).chain(narrowing) {
            let deltas = deltas(&reach, scale, tolerance_mm - floor_mm);
            if let Some(v) = self.verify(tracks, &deltas, tolerance_mm, floor_mm)? {
                return Ok(Some(v));
            }
        }
        Ok(None)
    }

    /// Whether the first try alone (no narrowing) gives rows the execution model accepts
    /// (`None`: the tolerance is below the pulse grid's floor).
    #[cfg(test)]
    pub(super) fn first_try_accepted(&self, tolerance_mm: f64) -> Result<Option<bool>, PlanError> {
        let tracks = self.tracks();
        let floor_mm = self.floor_mm(&tracks);
        if floor_mm >= tolerance_mm {
            return Ok(None);
        }
        let scale = first_scale(tolerance_mm, floor_mm);
        let deltas = deltas(&self.pulse_reach_mm().1, scale, tolerance_mm - floor_mm);
        Ok(Some(
            self.verify(&tracks, &deltas, tolerance_mm, floor_mm)?
                .is_some(),
        ))
    }

    /// Rows for windows `deltas` pulses wide, if the execution model finds them within the
    /// tolerance (and the tracking error within twice it).
    fn verify(
        &self,
        tracks: &[Vec<f64>],
        deltas: &[f64; JOINTS],
        tolerance_mm: f64,
        floor_mm: f64,
    ) -> Result<Option<Verified>, PlanError> {
        let tables = self.tables(tracks, deltas);
        super::check_tables(self.robot, &tables, false)?;
        let run = simulate_within(
            self.robot,
            &tables,
            self.course,
            self.profile,
            self.window,
            self.motion,
            tolerance_mm,
        );
        Ok(match run {
            Some((execution, figures)) if figures.tracking_error_mm <= 2.0 * tolerance_mm => {
                Some(Verified {
                    tables,
                    execution,
                    figures,
                    floor_mm,
                })
            }
            _ => None,
        })
    }

    /// The refusal of a tolerance, naming the smallest one that does work on this move.
    fn too_tight(&self, tracks: &[Vec<f64>], tolerance_mm: f64, floor_mm: f64) -> PlanError {
        let works = [1.05, 1.1, 1.25, 1.5, 2.0, 3.0]
            .iter()
            .map(|k| (floor_mm * k * 1e4).ceil() / 1e4)
            .find(|&t| {
                t > tolerance_mm && matches!(self.try_plan(tracks, t, floor_mm), Ok(Some(_)))
            });
        PlanError::ToleranceTooSmall {
            tolerance_mm,
            floor_mm,
            works_mm: works,
        }
    }
}
