//! The `bounded-error` method: rows of any length, as few as keep the executed path within a
//! stated tolerance of the planned path (the line; a joint move's tool path), with no period grid.
//!
//! 1. The path is sampled finely ([`SAMPLE_S`]) and solved to every joint's fractional count.
//! 2. The Cartesian tolerance becomes a per-joint pulse budget through the Jacobian ([`budget`]):
//!    every joint may be `1/2 + delta_j` pulses off, the widest windows whose worst case, the
//!    joints' errors combined as the vectors their pulses move the tool by, stays within the
//!    tolerance.
//! 3. Every pulse gets a window of landing times ([`pulses`]), read by pieces along which
//!    a row's bound is monotone ([`windows`]); rows are the longest runs of pulses one
//!    realisable frequency lands inside their windows (Klipper's step compression, [`rows`]).
//! 4. The execution model plays the tables; a plan whose path deviation exceeds the tolerance
//!    (or whose tracking error exceeds twice it) is not returned. The windows of step 2 make
//!    that rare (the linearisation is the only gap); when it happens the windows narrow and it
//!    is planned again, and a tolerance the grid cannot reach is refused with one that works.
//!
//! The pulse grid's floor (the path deviation with every pulse on time) is played only when the
//! narrowing search needs it, after the first two tries (sized by the pulse vectors alone) are
//! refused, or to refuse a tolerance below it.

use std::cell::RefCell;

mod budget;
mod pulses;
mod rows;
mod windows;

use crate::geometry::Profile;
use crate::kinematics::JOINTS;
use crate::robot::{Motion, Robot};
use crate::sim::{Figures, PulseEvent};
use crate::table::{ChannelTable, FrequencyRange};

use super::course::Course;
use super::error::{Creep, PlanError};
use super::judge::{check_tables, simulate_within};
use super::planned::{Window, settings};
use super::samples::Samples;
use budget::Budget;
use pulses::{Counts, Run, Track};
use rows::{Bounds, Channel};
use windows::{Pulses, Stretch};

/// Sample spacing of the trajectory, s.
pub(super) const SAMPLE_S: f64 = 0.001;
/// The first try: every joint's window may take the tool this fraction of `tolerance - grid / 2`
/// off the path, `grid` the pulse grid's linearised worst case ([`Budget::worst_mm`] of windows
/// of width 0). Not a bound: the windows' errors and the pulse grid's rarely peak at the same
/// instant or point the same way, so the grid is counted half and every joint gets the whole
/// share. Fitted on the seed's move, where it holds with the fewest rows; on most other moves
/// the execution model would refuse it, so it is made only where [`FITTED_BUSY`] says it may
/// hold, and elsewhere the second try, sized by the worst case ([`Budget::widest`]), is the
/// first made.
const FIRST_BUDGET: f64 = 0.62;
/// When the fitted first try is made: where its windows' worst case, counting only the joints
/// that make more than the first figure's pulses ([`Budget::busy_worst_mm`]), is at most the
/// second figure times the tolerance. Measured on 132 tries (60 random lines of the seed robot,
/// every other one under each frequency model, and six more lines, among them the seed's move,
/// each at 0.05 and 0.10 mm: `docs/BENCHMARKS.md`, stop 39): every fitted try the execution
/// model accepted but three came at or under 1.16, every one it refused but one (1.12) above
/// 1.19. Past it the fitted try is not made: it would be refused, and a refused try costs the
/// move's tables and most of a simulation.
const FITTED_BUSY: (f64, f64) = (100.0, 1.175);
/// The narrowing search's first windows, relative to the budget left above the floor: the
/// budget adds every joint's error at its worst as if they all pointed the same way, which they
/// rarely do, so the search starts wider and lets the execution model judge.
const FIRST_SCALE: f64 = 2.5;
/// Tries with narrower windows before giving up on a tolerance.
const TRIES: usize = 14;
/// Pulses a run may leave off their windows to stay one F174 segment, per round of tries: every
/// try first lets a run keep one segment at the cost of a couple of pulses played as near their
/// windows as its range allows (the execution model judges them), and only if no try is accepted
/// so are the tries made again splitting wherever no range plays a run within its windows. A
/// channel's later segment starts up to a PLC scan late (ACCURACY.md), holding the rest of its
/// run back by that much at whatever speed it reaches: at 18 kHz a 2 ms scan is 36 pulses.
const OFF_WINDOW_TRIES: [usize; 2] = [2, 0];

/// Each retry narrows every window to this fraction.
const NARROWING: f64 = 0.8;
/// The widest window, pulses each side (also for joints that do not move the tool point).
const MAX_DELTA_PULSES: f64 = 8.0;

thread_local! {
    /// A row's scan's buffers ([`rows::Channel`]), kept on a thread between tries and plans.
    static BOUNDS: RefCell<Bounds> = RefCell::new(Bounds::default());
}
/// The most pieces [`BOUNDS`] keeps after a plan, 24 bytes each per side: 12 MB at most.
const BOUNDS_KEPT: usize = 1 << 18;

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

/// How many times the windows of a joint whose drive refused a try's rows are halved before
/// every pulse is made on time.
const DRIVE_NARROWINGS: usize = 4;

/// A try a joint's drive could not follow: why, and its windows.
struct DriveRefusal {
    error: PlanError,
    deltas: [f64; JOINTS],
}

/// A verified bounded-error plan's tables and how they ran.
pub(super) struct Verified {
    pub tables: Vec<ChannelTable>,
    pub figures: Figures,
}

/// What the tries are sized by: the path's pulse vectors, and the pulse grid's floor, played
/// once and only when the narrowing search or a refusal needs it.
struct Sizing<'a> {
    budget: Budget,
    tracks: &'a [Counts],
    floor_mm: std::cell::OnceCell<f64>,
}

impl Sizing<'_> {
    /// The fitted first try ([`FIRST_BUDGET`]), if the grid's worst case leaves it room and
    /// the busy joints' worst case ([`FITTED_BUSY`]) says it may be accepted.
    fn fitted(&self, tolerance_mm: f64) -> Option<[f64; JOINTS]> {
        self.fitted_windows(tolerance_mm)
            .filter(|deltas| self.fitted_likely(deltas, tolerance_mm))
    }

    /// The fitted first try's windows, if the grid's worst case leaves them room.
    fn fitted_windows(&self, tolerance_mm: f64) -> Option<[f64; JOINTS]> {
        let grid_mm = self.budget.worst_mm(&[0.0; JOINTS]).0;
        (grid_mm < tolerance_mm).then(|| {
            deltas(
                &self.budget.reach_mm(),
                FIRST_BUDGET,
                tolerance_mm - grid_mm / 2.0,
            )
        })
    }

    /// Whether the fitted try's windows `deltas` are likely to be accepted ([`FITTED_BUSY`]).
    fn fitted_likely(&self, deltas: &[f64; JOINTS], tolerance_mm: f64) -> bool {
        let (busy, share) = FITTED_BUSY;
        self.budget.busy_worst_mm(deltas, busy) <= share * tolerance_mm
    }

    /// The first two tries, each made only when asked for: the fitted ([`Self::fitted`]),
    /// then the widest windows whose worst case keeps the tool within the tolerance
    /// ([`Budget::widest`]; `None` when not even the grid's does).
    fn first_two(&self, tolerance_mm: f64) -> impl Iterator<Item = Option<[f64; JOINTS]>> + '_ {
        std::iter::once_with(move || self.fitted(tolerance_mm)).chain(std::iter::once_with(
            move || self.budget.widest(tolerance_mm, MAX_DELTA_PULSES),
        ))
    }

    /// The narrowing search, should the execution model refuse the first two: windows sized by
    /// a pulse's whole move and the budget left above the floor.
    fn narrowing(
        &self,
        tolerance_mm: f64,
        floor_mm: f64,
    ) -> impl Iterator<Item = [f64; JOINTS]> + use<> {
        let whole = self.budget.whole_mm();
        (0..TRIES).map(move |k| {
            let scale = FIRST_SCALE * NARROWING.powi(k as i32);
            deltas(&whole, scale, tolerance_mm - floor_mm)
        })
    }
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
    /// Every joint's fractional count at every sample ([`Counts`]), joint by joint.
    fn tracks(&self) -> Vec<Counts> {
        (0..JOINTS)
            .map(|j| {
                let joint = &self.robot.joints[j];
                Counts::new(
                    self.samples
                        .values
                        .iter()
                        .map(|q| (q[j] - joint.offset) / joint.step)
                        .collect(),
                )
            })
            .collect()
    }

    fn track<'t>(&self, tracks: &'t [Counts], j: usize) -> Track<'t> {
        tracks[j].track(self.profile.period_s)
    }

    fn start_counts(&self) -> [i64; JOINTS] {
        self.samples.counts[0]
    }

    /// Every joint's pulse vectors along the path ([`Budget`]).
    fn budget(&self) -> Budget {
        Budget::new(self.robot, &self.samples.values)
    }

    /// The path deviation with every pulse landing exactly on time (the pulse grid's floor).
    /// It does not depend on the tolerance: played at most once per plan ([`Sizing`]), from
    /// every joint's on-time pulses merged in time order (each joint's are already in order).
    fn play_floor_mm(&self, tracks: &[Counts]) -> f64 {
        let start = self.start_counts();
        let channels = (0..JOINTS).map(|j| {
            self.track(tracks, j)
                .on_time(start[j])
                .map(move |(t_s, count)| PulseEvent {
                    t_s,
                    table: j,
                    count,
                })
        });
        crate::sim::path_deviation_mm(
            self.robot,
            &start,
            crate::sim::Merged::new(channels),
            self.course.tool_path(),
        )
    }

    /// Every channel's table for windows `deltas` pulses wide.
    fn tables(
        &self,
        tracks: &[Counts],
        deltas: &[f64; JOINTS],
        off_window: usize,
    ) -> Vec<ChannelTable> {
        let start = self.start_counts();
        BOUNDS.with(|bounds| {
            let tables = (0..JOINTS)
                .map(|j| {
                    let windows = self.track(tracks, j).windows(start[j], deltas[j]);
                    self.table(j, &windows.runs(), off_window, bounds)
                })
                .collect();
            if bounds.borrow().capacity() > BOUNDS_KEPT {
                *bounds.borrow_mut() = Bounds::default();
            }
            tables
        })
    }

    /// Joint `j`'s table playing `runs` from the start counts.
    fn table(
        &self,
        j: usize,
        runs: &[Run<Stretch>],
        off_window: usize,
        bounds: &RefCell<Bounds>,
    ) -> ChannelTable {
        let start = self.start_counts()[j];
        let joint = &self.robot.joints[j];
        let channel = Channel {
            joint,
            model: self.motion.frequency_model,
            off_window,
            bounds,
        };
        let (mut t_s, mut count, mut segments) = (0.0, start, Vec::new());
        for (i, run) in runs.iter().enumerate() {
            let left = crate::table::MAX_SEGMENTS
                .saturating_sub(segments.len() + runs.len() - i - 1)
                .max(1);
            let (segs, end) = channel.run(run, t_s, count, left);
            let n = run.pulses.len();
            if n > 0 {
                count = run.pulses.count(n - 1);
            }
            t_s = end;
            segments.extend(segs);
        }
        ChannelTable {
            channel: joint.channel,
            start,
            segments,
        }
    }

    fn sizing<'t>(&self, tracks: &'t [Counts]) -> Sizing<'t> {
        Sizing {
            budget: self.budget(),
            tracks,
            floor_mm: std::cell::OnceCell::new(),
        }
    }

    fn floor_mm(&self, sizing: &Sizing) -> f64 {
        *sizing
            .floor_mm
            .get_or_init(|| self.play_floor_mm(sizing.tracks))
    }

    /// Plans at `tolerance_mm`, narrowing the windows until the execution model agrees. A
    /// tolerance no try meets is refused with the pulse grid's floor and no suggestion: a path's
    /// part cut again at a later point never shows it, and finding one plans the move again up
    /// to six times ([`Self::works_mm`] finds it for a refusal that reaches the user).
    pub(super) fn plan(&self, tolerance_mm: f64) -> Result<Verified, PlanError> {
        let tracks = self.tracks();
        let sizing = self.sizing(&tracks);
        match self.try_plan(&sizing, tolerance_mm)? {
            Some(v) => Ok(v),
            None => Err(PlanError::ToleranceTooSmall {
                tolerance_mm,
                floor_mm: self.floor_mm(&sizing),
                creep: None,
                works_mm: None,
            }),
        }
    }

    /// The tries in order, every one judged by the execution model ([`Self::verify`]): the
    /// first two ([`Sizing::first_two`]), then, past the pulse grid's floor (a tolerance at or
    /// below it is refused without them), the narrowing search ([`Sizing::narrowing`]). The
    /// first accepted (`None` if none).
    ///
    /// A try whose rows a joint's drive could not follow ([`super::dynamics::judge`]) is
    /// refused like one off the tolerance, and the windows of the joint the drive refused are
    /// halved, a few times, from that try's (the rows then follow the motion more closely):
    /// at once for the first of the first two the drive refuses, and when the tries end for
    /// the last the drive refused, if another. Then every pulse is made on time (windows of
    /// half a pulse: the rows follow the motion within a pulse of rounding). If the drive
    /// cannot follow those either, its refusal is the error.
    fn try_plan(&self, sizing: &Sizing, tolerance_mm: f64) -> Result<Option<Verified>, PlanError> {
        let mut drive: Option<DriveRefusal> = None;
        // The first try the execution model accepted and a drive refused: the refused joint's
        // windows are narrowed from it at once, before the wider tries of the narrowing search
        // (which the drive would refuse as well, most often). Its windows, once narrowed.
        let mut narrowed_from: Option<[f64; JOINTS]> = None;
        for off_window in OFF_WINDOW_TRIES {
            for deltas in sizing.first_two(tolerance_mm).flatten() {
                if let Some(v) =
                    self.verify(sizing.tracks, &deltas, off_window, tolerance_mm, &mut drive)?
                {
                    return Ok(Some(v));
                }
                if narrowed_from.is_none()
                    && let Some(refused) = drive.as_mut()
                {
                    narrowed_from = Some(refused.deltas);
                    if let Some(v) = self.drive_narrowed(sizing, tolerance_mm, refused)? {
                        return Ok(Some(v));
                    }
                }
            }
            let floor_mm = self.floor_mm(sizing);
            if floor_mm >= tolerance_mm {
                break;
            }
            for deltas in sizing.narrowing(tolerance_mm, floor_mm) {
                if let Some(v) =
                    self.verify(sizing.tracks, &deltas, off_window, tolerance_mm, &mut drive)?
                {
                    return Ok(Some(v));
                }
            }
        }
        let Some(mut refused) = drive else {
            return Ok(None);
        };
        if narrowed_from != Some(refused.deltas)
            && let Some(v) = self.drive_narrowed(sizing, tolerance_mm, &mut refused)?
        {
            return Ok(Some(v));
        }
        let mut again = None;
        match self.verify(sizing.tracks, &[0.0; JOINTS], 0, tolerance_mm, &mut again)? {
            Some(v) => Ok(Some(v)),
            None => Err(again.map_or(refused.error, |r| r.error)),
        }
    }

    /// The windows of the joint `refused` names halved from its try's, up to
    /// [`DRIVE_NARROWINGS`] times, each try's refusal naming the next joint; `refused` takes
    /// the last refusal.
    fn drive_narrowed(
        &self,
        sizing: &Sizing,
        tolerance_mm: f64,
        refused: &mut DriveRefusal,
    ) -> Result<Option<Verified>, PlanError> {
        let mut deltas = refused.deltas;
        for _ in 0..DRIVE_NARROWINGS {
            let Some(j) = self.joint_named(&refused.error) else {
                break;
            };
            deltas[j] *= 0.5;
            let mut again = None;
            if let Some(v) = self.verify(sizing.tracks, &deltas, 0, tolerance_mm, &mut again)? {
                return Ok(Some(v));
            }
            match again {
                Some(r) => refused.error = r.error,
                None => break,
            }
        }
        Ok(None)
    }

    /// The joint a drive refusal names.
    fn joint_named(&self, refusal: &PlanError) -> Option<usize> {
        let (PlanError::RowStep { joint, .. } | PlanError::RestRow { joint, .. }) = refusal else {
            return None;
        };
        self.robot.joints.iter().position(|j| j.name == *joint)
    }

    /// Which of the tries ([`Self::try_plan`]) the execution model accepts first, from 1
    /// (`None`: the tolerance is below the pulse grid's floor, or nothing is accepted).
    #[cfg(test)]
    pub(super) fn accepted_try(&self, tolerance_mm: f64) -> Result<Option<usize>, PlanError> {
        let tracks = self.tracks();
        let sizing = self.sizing(&tracks);
        let off_window = OFF_WINDOW_TRIES[0];
        for (k, deltas) in sizing.first_two(tolerance_mm).enumerate() {
            if let Some(deltas) = deltas
                && self
                    .verify(&tracks, &deltas, off_window, tolerance_mm, &mut None)?
                    .is_some()
            {
                return Ok(Some(k + 1));
            }
        }
        let mut tried = 2;
        let floor_mm = self.floor_mm(&sizing);
        if floor_mm >= tolerance_mm {
            return Ok(None);
        }
        for deltas in sizing.narrowing(tolerance_mm, floor_mm) {
            tried += 1;
            if self
                .verify(&tracks, &deltas, off_window, tolerance_mm, &mut None)?
                .is_some()
            {
                return Ok(Some(tried));
            }
        }
        Ok(None)
    }

    /// The fitted try's windows judged, made or not ([`Sizing::fitted`]): whether the gate
    /// ([`FITTED_BUSY`]) makes it, and whether the execution model accepts it (`None`: the
    /// grid's worst case leaves the fitted try no room).
    #[cfg(test)]
    pub(super) fn fitted_judged(
        &self,
        tolerance_mm: f64,
    ) -> Result<Option<(bool, bool)>, PlanError> {
        let tracks = self.tracks();
        let sizing = self.sizing(&tracks);
        let Some(deltas) = sizing.fitted_windows(tolerance_mm) else {
            return Ok(None);
        };
        let made = sizing.fitted_likely(&deltas, tolerance_mm);
        let accepted = self
            .verify(
                &tracks,
                &deltas,
                OFF_WINDOW_TRIES[0],
                tolerance_mm,
                &mut None,
            )?
            .is_some();
        Ok(Some((made, accepted)))
    }

    /// Rows for windows `deltas` pulses wide, if the execution model finds them within the
    /// tolerance (and the tracking error within twice it) and every joint's drive can follow
    /// them (else `drive` takes the drive's refusal and the windows).
    fn verify(
        &self,
        tracks: &[Counts],
        deltas: &[f64; JOINTS],
        off_window: usize,
        tolerance_mm: f64,
        drive: &mut Option<DriveRefusal>,
    ) -> Result<Option<Verified>, PlanError> {
        let tables = self.tables(tracks, deltas, off_window);
        check_tables(self.robot, &tables, self.motion.method)?;
        let run = simulate_within(
            self.robot,
            &tables,
            self.course,
            self.profile,
            self.window,
            self.motion,
            tolerance_mm,
        );
        let Some(figures) = run.filter(|f| f.tracking_error_mm <= 2.0 * tolerance_mm) else {
            return Ok(None);
        };
        if self.robot.has_dynamics()
            && let Err(refusal) = super::dynamics::judge(
                self.robot,
                &tables,
                self.samples,
                self.profile.period_s,
                self.window,
                settings(self.motion),
            )
        {
            *drive = Some(DriveRefusal {
                error: refusal,
                deltas: *deltas,
            });
            return Ok(None);
        }
        Ok(Some(Verified { tables, figures }))
    }

    /// The joint that runs furthest ahead of the path because it moves slower than the lowest
    /// frequency its channel plays, if one runs a pulse ahead or more (`None` otherwise).
    ///
    /// An F174 row cannot wait: a channel's next pulse lands at most a lowest-frequency period
    /// after the one before. Played so, a pulse due `gap` after the one before lands
    /// `early + gap - period` early, `early` the earliness before it (0 once the joint is fast
    /// enough to be on time again): the least any rows can do. It is a pulse ahead when it
    /// lands before the pulse before it was due.
    pub(super) fn creep(&self) -> Option<Creep> {
        let tracks = self.tracks();
        let start = self.start_counts();
        let low = FrequencyRange::Low;
        let lowest_hz = self.motion.frequency_model.actual_hz(low.min_set_hz(), low);
        let period_s = 1.0 / lowest_hz;
        (0..JOINTS)
            .filter_map(|j| {
                let (mut early_s, mut due_s, mut since) = (0.0_f64, 0.0, (0.0, 0_usize));
                let mut worst: Option<Creep> = None;
                for (k, (t_s, _)) in self.track(&tracks, j).on_time(start[j]).enumerate() {
                    let gap_s = t_s - due_s;
                    early_s = (early_s + gap_s - period_s).max(0.0);
                    if early_s <= 0.0 {
                        since = (t_s, k + 1);
                    } else if early_s > gap_s && worst.as_ref().is_none_or(|w| early_s > w.early_s)
                    {
                        let over_s = t_s - since.0;
                        worst = Some(Creep {
                            joint: self.robot.joints[j].name.clone(),
                            rate_hz: (k + 1 - since.1) as f64 / over_s,
                            over_s,
                            lowest_hz,
                            at_s: t_s,
                            early_s,
                        });
                    }
                    due_s = t_s;
                }
                worst
            })
            .max_by(|a, b| a.early_s.total_cmp(&b.early_s))
    }

    /// The smallest tolerance above `tolerance_mm` found to work on this move, from a few
    /// multiples of the pulse grid's floor (`None` if none of them does).
    pub(super) fn works_mm(&self, tolerance_mm: f64) -> Option<f64> {
        let tracks = self.tracks();
        let sizing = self.sizing(&tracks);
        let floor_mm = self.floor_mm(&sizing);
        [1.05, 1.1, 1.25, 1.5, 2.0, 3.0]
            .iter()
            .map(|k| (floor_mm * k * 1e4).ceil() / 1e4)
            .find(|&t| t > tolerance_mm && matches!(self.try_plan(&sizing, t), Ok(Some(_))))
    }
}
