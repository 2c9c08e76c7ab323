//! PURE. A course sampled for one motion: the profile its method samples it on, the joints'
//! values and counts at every point, checked against the joints' position limits and the
//! channels' top frequencies; under `slow-down`, at the fastest speed every channel fits. The
//! samples say where a start is cut: a part's window and samples, and where a joint reverses
//! while another moves.

use crate::geometry::{Pace, Profile, ProfileRequest};
use crate::kinematics::{JOINTS, Joints};
use crate::robot::{Motion, OverSpeed, Ramp, Robot};

use super::bounded;
use super::course::Course;
use super::error::PlanError;
use super::limits;
use super::planned::Window;
use super::samples::Samples;
use super::start::Start;

/// The most times `slow-down` lowers the speed before giving up.
const SLOW_DOWN_ATTEMPTS: usize = 24;

/// A slowed motion that fits every channel, its profile and samples.
struct Slowed {
    motion: Motion,
    profile: Profile,
    samples: Samples,
}

/// The grid `motion`'s method samples a course on: bounded-error's fine samples
/// ([`bounded::SAMPLE_S`]), or the period.
pub(super) fn grid_s(motion: &Motion) -> f64 {
    if motion.method.tolerance_mm().is_some() {
        bounded::SAMPLE_S
    } else {
        motion.period_s
    }
}

/// `course` sampled from `start` for `motion` as it would be planned: its duration and the speed
/// factor the sampled check leaves it (`None` if it cannot be sampled).
pub(super) fn probe(
    robot: &Robot,
    course: &Course,
    start: &Start,
    motion: Motion,
) -> Option<(f64, f64)> {
    let sampled = Sampled::new(robot, course, start, motion).ok()?;
    Some((sampled.profile.duration_s(), sampled.speed_factor))
}

/// A course sampled for one motion: the profile and the samples every start along it is planned
/// from (one start over the whole of it, or a path section cut into parts).
pub(super) struct Sampled<'a> {
    pub(super) robot: &'a Robot,
    pub(super) course: &'a Course,
    /// The motion used (speed lowered by `slow-down` if it had to).
    pub(super) motion: Motion,
    /// Its speed over the speed asked (below 1 where `slow-down` lowered it).
    pub(super) speed_factor: f64,
    pub(super) profile: Profile,
    pub(super) samples: Samples,
}

impl<'a> Sampled<'a> {
    /// `course` sampled for `asked` from `start`.
    pub(super) fn new(
        robot: &'a Robot,
        course: &'a Course,
        start: &Start,
        asked: Motion,
    ) -> Result<Self, PlanError> {
        let mut motion = asked;
        let bounded = motion.method.tolerance_mm();
        let grid_s = grid_s(&motion);
        let sampler = Sampler {
            robot,
            course,
            grid_s,
            continuous: bounded.is_some(),
            start_values: &start.values,
            start_counts: start.counts,
        };
        let (profile, samples) = sampler.fast_enough(&mut motion)?;
        Ok(Self {
            robot,
            course,
            speed_factor: motion.speed_mm_s / asked.speed_mm_s,
            motion,
            profile,
            samples,
        })
    }

    /// The index of the last sample point (the course's end).
    pub(super) fn last_point(&self) -> usize {
        self.samples.counts.len() - 1
    }

    /// Whether a start is cut where a channel would need a later segment (a reversal, a run
    /// no one range plays): the PLC begins that segment up to a scan late while the other
    /// channels run on, which the execution model does not play. Every plan meant for a PLC;
    /// not the paper as printed.
    pub(super) fn cut_for_segments(&self) -> bool {
        !self.motion.method.is_seed_exact()
    }

    /// The bounded-error tolerance, mm (`None`: a constant-period method).
    pub(super) fn bounded(&self) -> Option<f64> {
        self.motion.method.tolerance_mm()
    }

    /// The profile's time at sample point `i`, s.
    pub(super) fn time_s(&self, i: usize) -> f64 {
        if i == self.last_point() {
            self.profile.duration_s()
        } else {
            i as f64 * self.profile.period_s
        }
    }

    /// The window and samples of the start from sample point `first` to `last`, from
    /// `counts`.
    pub(super) fn part(
        &self,
        first: usize,
        last: usize,
        counts: [i64; JOINTS],
    ) -> (Window, Samples) {
        let window = Window {
            from_s: self.time_s(first),
            to_s: self.time_s(last),
            ends_at_speed: last != self.last_point(),
        };
        let mut samples = Samples {
            counts: self.samples.counts[first..=last].to_vec(),
            values: self.samples.values[first..=last].to_vec(),
        };
        samples.counts[0] = counts;
        (window, samples)
    }

    /// Where to cut the course between sample points `from` and `to` so that no joint reverses
    /// inside a part while another joint moves: at the first such reversal (the last point at
    /// the joint's extreme count), wherever it falls between them. A reversal needs a new F174
    /// segment, which the PLC starts in the scan after the one before ends: up to a scan late,
    /// while the other channels run on, which leaves the path for the rest of the joint's run
    /// (near a part's start as much as in its middle). At a cut every channel stops and
    /// restarts together in the scan after the part ends: a pause on the path, no deviation.
    pub(super) fn reversal_cut(&self, from: usize, to: usize) -> Option<usize> {
        self.reversal(from, to).map(|(cut, _)| cut)
    }

    /// [`Self::reversal_cut`] with the joint that reverses there.
    pub(super) fn reversal(&self, from: usize, to: usize) -> Option<(usize, usize)> {
        let counts = &self.samples.counts;
        let others_move = |j: usize, i: usize| {
            (0..JOINTS)
                .any(|k| k != j && counts[i.saturating_sub(1)][k] != counts[(i + 1).min(to)][k])
        };
        // Every joint's way so far (0 before it moves), the joints read side by side: the first
        // reversal met, the earliest joint's at a point, is every joint's first one's least.
        let mut direction = [0_i64; JOINTS];
        for i in from + 1..=to {
            for j in 0..JOINTS {
                let step = (counts[i][j] - counts[i - 1][j]).signum();
                if step == 0 {
                    continue;
                }
                let reverses = direction[j] != 0 && step != direction[j];
                direction[j] = step;
                // Point i - 1 is the last at the extreme count.
                if reverses && others_move(j, i - 1) {
                    return Some((i - 1, j));
                }
            }
        }
        None
    }
}

/// Samples the course for one motion: the profile, the samples, and the fastest channel's load.
pub(super) struct Sampler<'a> {
    pub(super) robot: &'a Robot,
    pub(super) course: &'a Course,
    /// The grid's spacing, s ([`grid_s`]).
    pub(super) grid_s: f64,
    /// Whether the samples are read as a continuous motion (bounded-error's fine grid).
    pub(super) continuous: bool,
    pub(super) start_values: &'a Joints,
    pub(super) start_counts: [i64; JOINTS],
}

impl Sampler<'_> {
    fn at(&self, motion: &Motion) -> Result<(Profile, Samples, limits::Peak), PlanError> {
        // A time-optimal pace starts and ends at rest itself: its profile has no ramp, and
        // under constant-period keeps its speed with a last period of its own length.
        let ramp = !self.course.pace().is_some_and(Pace::from_rest);
        let request = ProfileRequest {
            length_mm: self.course.length_mm(),
            speed_mm_s: motion.speed_mm_s,
            accel_s: if ramp { motion.accel_s } else { 0.0 },
            period_s: self.grid_s,
        };
        let profile = match (ramp, motion.ramp) {
            (true, Ramp::SCurve { jerk_mm_s3 }) => Profile::s_curve(request, jerk_mm_s3)?,
            (false, Ramp::SCurve { .. }) => return Err(PlanError::SCurveUnderDriveLimits),
            (true, Ramp::Trapezoid) => Profile::new(request)?,
            (false, Ramp::Trapezoid) if self.continuous => Profile::new(request)?,
            (false, Ramp::Trapezoid) => {
                Profile::paced(self.course.length_mm(), motion.speed_mm_s, self.grid_s)?
            }
        };
        let samples =
            self.course
                .sample(self.robot, &profile, self.start_values, self.start_counts)?;
        limits::check_positions(self.robot, &samples.counts, profile.period_s)?;
        let peak = limits::peak(self.robot, &samples, &profile, self.continuous);
        Ok((profile, samples, peak))
    }

    /// The profile and samples of `motion`, or under `slow-down` of the fastest speed (within
    /// 1 %) at which every channel fits; `motion` is set to the motion used. Speed and
    /// acceleration scale together (the ramp time stays); where that changes nothing (a line too
    /// short to reach its speed runs its two ramps whatever the speed asked), the ramps are
    /// stretched as the speed is cut.
    pub(super) fn fast_enough(&self, motion: &mut Motion) -> Result<(Profile, Samples), PlanError> {
        let (profile, samples, peak) = self.at(motion)?;
        if peak.load <= 1.0 {
            return Ok((profile, samples));
        }
        if motion.over_speed == OverSpeed::Reject {
            return Err(limits::over_speed(self.robot, &peak));
        }
        let asked = *motion;
        let found = match self.slowed(asked, peak.clone(), false)? {
            Ok(found) => found,
            Err(_) => self
                .slowed(asked, peak, true)?
                .map_err(|peak| limits::over_speed(self.robot, &peak))?,
        };
        *motion = found.motion;
        Ok((found.profile, found.samples))
    }

    /// The fastest cut of `asked`'s speed (within 1 %) at which every channel fits, its ramps
    /// `stretched` as the speed is cut or not; `Err` with the last peak when none is found.
    #[allow(clippy::type_complexity)]
    fn slowed(
        &self,
        asked: Motion,
        peak: limits::Peak,
        stretched: bool,
    ) -> Result<Result<Slowed, limits::Peak>, PlanError> {
        let scaled = |f: f64| Motion {
            speed_mm_s: asked.speed_mm_s * f,
            accel_s: if stretched {
                asked.accel_s / f
            } else {
                asked.accel_s
            },
            ..asked
        };
        // Find a factor that fits. A triangular profile's peak speed goes with the square root of
        // its acceleration, and counts round to whole pulses: cut by the square of the overload,
        // and by at least `least` (1 % at first). A cut that leaves the load where it was (a
        // short S-curve's whole periods, its peak set by the jerk, not the speed) squares
        // `least`: 1, 2, 4, 8, 15, 28 % ...
        let (mut bad, mut factor, mut peak) = (1.0, 1.0, peak);
        let mut least = 0.99_f64;
        let mut good = None;
        for _ in 0..SLOW_DOWN_ATTEMPTS {
            factor *= (0.999 / peak.load).powi(2).min(least);
            let (p, s, pk) = self.at(&scaled(factor))?;
            if pk.load <= 1.0 {
                good = Some((factor, p, s));
                break;
            }
            if pk.load >= peak.load {
                least *= least;
            }
            (bad, peak) = (factor, pk);
        }
        let Some((mut fits, mut profile, mut samples)) = good else {
            return Ok(Err(peak));
        };
        // Then the fastest that fits, to within 1 %.
        while bad / fits > 1.01 {
            let mid = (fits * bad).sqrt();
            let (p, s, pk) = self.at(&scaled(mid))?;
            if pk.load <= 1.0 {
                (fits, profile, samples) = (mid, p, s);
            } else {
                bad = mid;
            }
        }
        Ok(Ok(Slowed {
            motion: scaled(fits),
            profile,
            samples,
        }))
    }
}
