//! PURE. How a section's profile runs along its path: at the profile's own speed on lines, and
//! slower on an arc too tight for that speed under the path's centripetal limit (`v = sqrt(a r)`,
//! for that arc alone), slowing down before it and speeding up after it at the profile's own
//! acceleration. Stretches may be capped as well ([`SpeedCap`]: where a joint's channel would
//! pass its top frequency, under `slow-down`), and are slowed for in the same way.
//!
//! The profile (one trapezoid) runs over a distance σ; the pace maps σ to the distance `s` along
//! the path. Its ratio `w = ds/dσ` (the tool's speed over the profile's) is 1 where nothing is
//! tight and `sqrt(a r) / V` on a tight arc. Between the two, `w²` changes linearly with `s`, by
//! `2 a_t / V²` per mm: while the profile cruises at `V` that is a constant tangential
//! acceleration `a_t` (`v² = v0² + 2 a_t s`). The limits meet as the lower envelope of every
//! arc's: a short line between two tight arcs is run at what both allow.
//!
//! On a stretch where `w²` is linear in `s`, `w` is linear in σ (`dw/dσ = c / 2` for
//! `w² = w0² + c (s - s0)`), so both ways are closed forms:
//! `σ - σ0 = 2 (s - s0) / (w0 + w)`, and `s - s0 = (σ - σ0) (w0 + w) / 2`.

use super::Path;

/// The steepest change of `w²` per mm: a speed that steps (no ramp) does so within a nanometre.
const MAX_SLOPE_PER_MM: f64 = 1e6;

/// A stretch of a path the tool must not run faster than `speed_mm_s` along (where a joint's
/// channel would pass its top frequency, say).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeedCap {
    /// Where it begins along the path, mm.
    pub from_mm: f64,
    /// Where it ends, mm.
    pub to_mm: f64,
    /// The fastest the tool may go there, mm/s.
    pub speed_mm_s: f64,
}

/// `path` cut where a piece or a cap begins or ends: every stretch `(from, to, limit on w²)`,
/// back to back from 0 to the path's length, its limit the lower of its piece's (an arc's
/// centripetal speed over `v2`) and its cap's (`caps` in order along the path, none
/// overlapping).
fn stretches(
    path: &Path,
    v2: f64,
    centripetal_mm_s2: f64,
    caps: &[SpeedCap],
) -> Vec<(f64, f64, f64)> {
    let length_mm = path.length_mm();
    let pieces = path.pieces();
    let mut cuts: Vec<f64> = pieces
        .iter()
        .map(|p| p.start_mm)
        .chain(caps.iter().flat_map(|c| [c.from_mm, c.to_mm]))
        .chain([length_mm])
        .filter(|s| s.is_finite())
        .map(|s| s.clamp(0.0, length_mm))
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let piece_limit = |m: f64| {
        let i = pieces
            .partition_point(|p| p.start_mm <= m)
            .saturating_sub(1);
        let k = pieces[i].primitive.curvature_per_mm();
        if k > 0.0 {
            (centripetal_mm_s2 / k / v2).min(1.0)
        } else {
            1.0
        }
    };
    cuts.windows(2)
        .filter(|w| w[1] > w[0])
        .map(|w| {
            let m = f64::midpoint(w[0], w[1]);
            let c = caps.partition_point(|c| c.from_mm <= m).checked_sub(1);
            let capped = c
                .map(|c| caps[c])
                .filter(|c| m < c.to_mm)
                .map_or(1.0, |c| (c.speed_mm_s * c.speed_mm_s / v2).min(1.0));
            (w[0], w[1], piece_limit(m).min(capped))
        })
        .collect()
}

/// `knots` without those between two of the very same ratio (no corner: a flat stretch).
#[allow(clippy::float_cmp)] // the same value, not a near one
fn without_flat_knots(knots: &[Knot]) -> Vec<Knot> {
    let mut kept: Vec<Knot> = Vec::with_capacity(knots.len());
    for (i, k) in knots.iter().enumerate() {
        let flat = i > 0 && i + 1 < knots.len() && knots[i - 1].w == k.w && knots[i + 1].w == k.w;
        if !flat {
            kept.push(*k);
        }
    }
    kept
}

/// A pace's knots in time (its profile cruising at one speed): the time-optimal motion as
/// stretches of constant acceleration, with its position's integral at every knot.
struct TimedKnots {
    /// Every knot's time, s.
    t_s: Vec<f64>,
    /// Every knot's distance along the path, mm.
    s_mm: Vec<f64>,
    /// Every knot's speed, mm/s.
    v_mm_s: Vec<f64>,
    /// The acceleration from every knot to the next, mm/s^2.
    a_mm_s2: Vec<f64>,
    /// The position's integral from 0 to every knot, mm s.
    integral: Vec<f64>,
}

impl TimedKnots {
    fn new(knots: &[Knot], speed_mm_s: f64) -> Self {
        let t_s: Vec<f64> = knots.iter().map(|k| k.sigma_mm / speed_mm_s).collect();
        let s_mm: Vec<f64> = knots.iter().map(|k| k.s_mm).collect();
        let v_mm_s: Vec<f64> = knots.iter().map(|k| k.w * speed_mm_s).collect();
        let a_mm_s2: Vec<f64> = (0..knots.len() - 1)
            .map(|k| {
                let dt = t_s[k + 1] - t_s[k];
                if dt > 0.0 {
                    (v_mm_s[k + 1] - v_mm_s[k]) / dt
                } else {
                    0.0
                }
            })
            .collect();
        let mut integral = Vec::with_capacity(knots.len());
        integral.push(0.0);
        for k in 0..knots.len() - 1 {
            let tau = t_s[k + 1] - t_s[k];
            integral.push(integral[k] + Self::cubic(s_mm[k], v_mm_s[k], a_mm_s2[k], tau));
        }
        Self {
            t_s,
            s_mm,
            v_mm_s,
            a_mm_s2,
            integral,
        }
    }

    /// `∫ (s + v τ + a τ²/2) dτ` from 0 to `tau`.
    fn cubic(s: f64, v: f64, a: f64, tau: f64) -> f64 {
        tau * (s + tau * (v / 2.0 + tau * a / 6.0))
    }

    fn duration_s(&self) -> f64 {
        self.t_s[self.t_s.len() - 1]
    }

    /// The stretch holding time `t_s` (its first knot), and the time into it.
    fn stretch(&self, t_s: f64) -> (usize, f64) {
        let k = self
            .t_s
            .partition_point(|&t| t <= t_s)
            .clamp(1, self.t_s.len() - 1)
            - 1;
        (k, t_s - self.t_s[k])
    }

    /// Where the motion is at `t_s` (at its start before 0, at its end after its end), mm.
    fn position_mm(&self, t_s: f64) -> f64 {
        if t_s <= 0.0 {
            return 0.0;
        }
        if t_s >= self.duration_s() {
            return self.s_mm[self.s_mm.len() - 1];
        }
        let (k, tau) = self.stretch(t_s);
        self.s_mm[k] + tau * (self.v_mm_s[k] + tau * self.a_mm_s2[k] / 2.0)
    }

    /// The position's integral from 0 to `t_s` (0 before 0; at the end's position after its
    /// end), mm s.
    fn integral(&self, t_s: f64) -> f64 {
        if t_s <= 0.0 {
            return 0.0;
        }
        let end = self.t_s.len() - 1;
        if t_s >= self.duration_s() {
            return self.integral[end] + self.s_mm[end] * (t_s - self.t_s[end]);
        }
        let (k, tau) = self.stretch(t_s);
        self.integral[k] + Self::cubic(self.s_mm[k], self.v_mm_s[k], self.a_mm_s2[k], tau)
    }

    /// The acceleration at `t_s` (0 before the start and after the end), mm/s^2.
    fn accel(&self, t_s: f64) -> f64 {
        if t_s < 0.0 || t_s >= self.duration_s() {
            return 0.0;
        }
        self.a_mm_s2[self.stretch(t_s).0]
    }

    /// The largest change of the acceleration over `window_s`: `|a(t) - a(t - window_s)|` at
    /// its largest, read where either side steps (at every knot, and a window after it).
    fn largest_change_over(&self, window_s: f64) -> f64 {
        self.t_s
            .iter()
            .flat_map(|&t| [t, t + window_s])
            .map(|t| (self.accel(t) - self.accel(t - window_s)).abs())
            .fold(0.0, f64::max)
    }

    /// The lowest and the highest acceleration, mm/s^2.
    fn accel_range(&self) -> (f64, f64) {
        self.a_mm_s2
            .iter()
            .fold((0.0_f64, 0.0_f64), |(lo, hi), &a| (lo.min(a), hi.max(a)))
    }
}

/// The envelope of `w²` at every boundary between `stretches` (`(s0, s1, limit)`, in order): the
/// lowest of every stretch's limit plus `slope` times the distance to it, from the left and from
/// the right; 1 where nothing lowers it.
fn boundary_envelope(stretches: &[(f64, f64, f64)], slope: f64) -> Vec<f64> {
    let n = stretches.len();
    let mut at = vec![1.0_f64; n + 1];
    let mut left = f64::INFINITY;
    for j in 1..=n {
        let (s0, s1, limit) = stretches[j - 1];
        left = (left + slope * (s1 - s0)).min(limit);
        at[j] = at[j].min(left);
    }
    let mut right = f64::INFINITY;
    for j in (0..n).rev() {
        let (s0, s1, limit) = stretches[j];
        right = (right + slope * (s1 - s0)).min(limit);
        at[j] = at[j].min(right);
    }
    at
}

/// The corners `(s_mm, w²)` of the envelope from the path's start: inside a stretch the envelope
/// is its own limit, or the slope from one of its ends (`at`, from [`boundary_envelope`]).
fn envelope_corners(stretches: &[(f64, f64, f64)], at: &[f64], slope: f64) -> Vec<(f64, f64)> {
    let mut corners: Vec<(f64, f64)> = vec![(0.0, at[0])];
    for (i, &(s0, s1, limit)) in stretches.iter().enumerate() {
        let (u0, u1) = (at[i], at[i + 1]);
        let rise = s0 + (limit - u0) / slope;
        let fall = s1 - (limit - u1) / slope;
        if rise <= fall {
            corners.push((rise, limit));
            corners.push((fall, limit));
        } else {
            let meet = ((u1 - u0) / slope + s0 + s1) / 2.0;
            corners.push((meet.clamp(s0, s1), u0 + slope * (meet - s0).max(0.0)));
        }
        corners.push((s1, u1));
    }
    corners
}

/// The knots through `corners` (the first at the path's start), each corner clamped onto the
/// path of `length_mm` and the profile distance summed between them.
fn knots_through(corners: &[(f64, f64)], length_mm: f64) -> Vec<Knot> {
    let mut knots = vec![Knot {
        s_mm: 0.0,
        sigma_mm: 0.0,
        w: corners[0].1.sqrt(),
    }];
    for &(s_mm, u) in &corners[1..] {
        let last = knots[knots.len() - 1];
        let s_mm = s_mm.clamp(last.s_mm, length_mm);
        if s_mm <= last.s_mm {
            continue;
        }
        let w = u.sqrt();
        knots.push(Knot {
            s_mm,
            sigma_mm: last.sigma_mm + 2.0 * (s_mm - last.s_mm) / (last.w + w),
            w,
        });
    }
    knots
}

/// One corner of the piecewise-linear `w²(s)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Knot {
    /// Distance along the path, mm.
    s_mm: f64,
    /// Distance along the profile, mm.
    sigma_mm: f64,
    /// The speed ratio `w` here.
    w: f64,
}

/// Where a section's profile distance falls on its path (see the module's docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Pace {
    /// At least two; `s_mm` and `sigma_mm` ascending, the first at 0, the last at the ends.
    knots: Vec<Knot>,
}

impl Pace {
    /// The profile run along a path of `length_mm` as it is (every ratio 1).
    #[must_use]
    pub fn uniform(length_mm: f64) -> Self {
        Self {
            knots: vec![
                Knot {
                    s_mm: 0.0,
                    sigma_mm: 0.0,
                    w: 1.0,
                },
                Knot {
                    s_mm: length_mm,
                    sigma_mm: length_mm,
                    w: 1.0,
                },
            ],
        }
    }

    /// The pace of a profile cruising at `speed_mm_s` along `path`: every arc run at no more than
    /// `sqrt(centripetal_mm_s2 * r)`, every stretch of `caps` (in order along the path, none
    /// overlapping) at no more than its speed, slowing and speeding up at `tangential_mm_s2`.
    #[must_use]
    pub fn new(
        path: &Path,
        speed_mm_s: f64,
        centripetal_mm_s2: f64,
        tangential_mm_s2: f64,
        caps: &[SpeedCap],
    ) -> Self {
        let v2 = speed_mm_s * speed_mm_s;
        let stretches = stretches(path, v2, centripetal_mm_s2, caps);
        // Without a ramp (an acceleration time of 0) the speed steps at the arc's ends.
        let slope = (2.0 * tangential_mm_s2 / v2).min(MAX_SLOPE_PER_MM);
        if slope.is_nan()
            || slope <= 0.0
            || stretches.iter().all(|&(_, _, l)| l >= 1.0 || l.is_nan())
        {
            return Self::uniform(path.length_mm());
        }
        let at = boundary_envelope(&stretches, slope);
        let corners = envelope_corners(&stretches, &at, slope);
        let length_mm = path.length_mm();
        let knots = knots_through(&corners, length_mm);
        let kept = without_flat_knots(&knots);
        if kept.len() < 2 {
            return Self::uniform(length_mm);
        }
        Self { knots: kept }
    }

    /// The pace of a motion that runs at `speeds_mm_s[i]` at `s_mm[i]` along the path, its `v²`
    /// linear in `s` between two points (a constant acceleration), under a profile cruising at
    /// `speed_mm_s` (no speed above it): the time-optimal motion of [`super::topp`], from rest
    /// to rest when its ends are 0. `None` when the points do not rise from 0, or two points
    /// in a row stand still (no time along them).
    #[must_use]
    #[allow(clippy::float_cmp)] // the path's start is exactly 0
    pub fn from_speeds(s_mm: &[f64], speeds_mm_s: &[f64], speed_mm_s: f64) -> Option<Self> {
        if s_mm.len() < 2 || s_mm.len() != speeds_mm_s.len() || s_mm[0] != 0.0 {
            return None;
        }
        let mut knots = Vec::with_capacity(s_mm.len());
        let mut last: Option<Knot> = None;
        for (&s, &v) in s_mm.iter().zip(speeds_mm_s) {
            let w = (v / speed_mm_s).clamp(0.0, 1.0);
            let knot = match last {
                None => Knot {
                    s_mm: s,
                    sigma_mm: 0.0,
                    w,
                },
                Some(k) if s > k.s_mm && k.w + w > 0.0 => Knot {
                    s_mm: s,
                    sigma_mm: k.sigma_mm + 2.0 * (s - k.s_mm) / (k.w + w),
                    w,
                },
                Some(_) => return None,
            };
            knots.push(knot);
            last = Some(knot);
        }
        Some(Self {
            knots: without_flat_knots(&knots),
        })
    }

    /// A time-optimal pace's motion (its profile cruising at `speed_mm_s`, from rest to rest)
    /// averaged over a moving window of `window_s`: the tool is where the time-optimal motion
    /// was on average over the last `window_s`, at its average speed. Its speed and its
    /// acceleration stay within the range the motion's took, and its jerk is at most the
    /// acceleration's range over `window_s` (the average's acceleration is the change of the
    /// speed over the window); it ends `window_s` later. A trapezoid so averaged is the seven
    /// phases of an S-curve whose jerk phases last `window_s` (Biagiotti and Melchiorri's
    /// moving-average filter). `None` when the pace does not start at rest or the figures are
    /// not positive.
    ///
    /// The averaged motion is tabulated every `step_s` (its knots; the pace's constant
    /// acceleration between two of them stands in for the average's, which changes by at most
    /// the jerk times `step_s`), from the time-optimal motion's exact integral: its position is
    /// quadratic in time between two knots, so its integral is a cubic.
    #[must_use]
    pub fn smoothed(&self, speed_mm_s: f64, window_s: f64, step_s: f64) -> Option<Self> {
        if !(self.from_rest() && speed_mm_s > 0.0 && window_s > 0.0 && step_s > 0.0) {
            return None;
        }
        let motion = TimedKnots::new(&self.knots, speed_mm_s);
        let end_s = motion.duration_s() + window_s;
        let steps = (end_s / step_s).ceil().max(1.0) as usize;
        let mut s_mm: Vec<f64> = Vec::with_capacity(steps + 1);
        let mut speeds: Vec<f64> = Vec::with_capacity(steps + 1);
        for i in 0..=steps {
            let (s, v) = if i == steps {
                (self.path_length_mm(), 0.0)
            } else {
                let t_s = i as f64 * step_s;
                (
                    (motion.integral(t_s) - motion.integral(t_s - window_s)) / window_s,
                    ((motion.position_mm(t_s) - motion.position_mm(t_s - window_s)) / window_s)
                        .max(0.0),
                )
            };
            // A knot that does not rise is left out (the rounding of the first steps' tiny
            // distances), but the end's own knot takes the place of one that reached it.
            if let (Some(last_s), Some(last_v)) = (s_mm.last_mut(), speeds.last_mut())
                && s <= *last_s
            {
                if i == steps {
                    (*last_s, *last_v) = (s, v);
                }
                continue;
            }
            s_mm.push(s);
            speeds.push(v);
        }
        Self::from_speeds(&s_mm, &speeds, speed_mm_s)
    }

    /// The shortest window over which a time-optimal pace (its profile cruising at
    /// `speed_mm_s`) averaged ([`Self::smoothed`]) keeps its jerk within `jerk_mm_s3`, s: the
    /// average's jerk at `t` is `(a(t) - a(t - T)) / T`, so the window `T` must hold every
    /// change of the acceleration over `T` within `jerk_mm_s3 * T`. From the least any window
    /// needs (the acceleration's largest size over the jerk: from rest it rises from 0),
    /// lengthened to the largest change over it until that fits; at most the acceleration's
    /// range over the jerk, which always fits.
    #[must_use]
    pub fn jerk_window_s(&self, speed_mm_s: f64, jerk_mm_s3: f64) -> f64 {
        let motion = TimedKnots::new(&self.knots, speed_mm_s);
        let (lo, hi) = motion.accel_range();
        let widest = (hi - lo) / jerk_mm_s3;
        let mut window = hi.max(-lo) / jerk_mm_s3;
        for _ in 0..16 {
            let change = motion.largest_change_over(window);
            if change <= jerk_mm_s3 * window * (1.0 + 1e-9) {
                return window;
            }
            window = (change / jerk_mm_s3).min(widest);
        }
        widest
    }

    /// Whether the pace itself starts and ends at rest (a time-optimal motion's): its profile
    /// then runs at one speed, with no ramp of its own.
    #[must_use]
    #[allow(clippy::float_cmp)] // at rest is exactly 0
    pub fn from_rest(&self) -> bool {
        self.knots[0].w == 0.0
    }

    /// The profile's length: the distance it runs to reach the path's end, mm.
    #[must_use]
    pub fn profile_length_mm(&self) -> f64 {
        self.knots[self.knots.len() - 1].sigma_mm
    }

    /// The path's length, mm.
    #[must_use]
    pub fn path_length_mm(&self) -> f64 {
        self.knots[self.knots.len() - 1].s_mm
    }

    /// Whether the profile runs along the path as it is.
    #[must_use]
    pub fn is_uniform(&self) -> bool {
        self.knots.iter().all(|k| k.w >= 1.0)
    }

    /// The stretch holding profile distance `sigma_mm` (its first knot's index).
    fn stretch_of_sigma(&self, sigma_mm: f64) -> usize {
        self.knots
            .partition_point(|k| k.sigma_mm <= sigma_mm)
            .clamp(1, self.knots.len() - 1)
            - 1
    }

    /// The stretch holding path distance `s_mm` (its first knot's index).
    fn stretch_of_s(&self, s_mm: f64) -> usize {
        self.knots
            .partition_point(|k| k.s_mm <= s_mm)
            .clamp(1, self.knots.len() - 1)
            - 1
    }

    /// The ratio `w` and the path distance at profile distance `sigma_mm` (clamped to the ends;
    /// the path's end exactly at the profile's).
    #[allow(clippy::float_cmp)] // the same ratio, not a near one
    fn at_sigma(&self, sigma_mm: f64) -> (f64, f64) {
        let last = self.knots[self.knots.len() - 1];
        if sigma_mm >= last.sigma_mm {
            return (last.s_mm, last.w);
        }
        let sigma_mm = sigma_mm.max(0.0);
        let i = self.stretch_of_sigma(sigma_mm);
        let (a, b) = (self.knots[i], self.knots[i + 1]);
        // A flat stretch (most of a path) keeps its ratio: what the division would give there,
        // `a.w + 0 * t`, without it.
        let w = if a.w == b.w && b.sigma_mm > a.sigma_mm {
            a.w
        } else {
            let t = (sigma_mm - a.sigma_mm) / (b.sigma_mm - a.sigma_mm);
            a.w + (b.w - a.w) * t
        };
        let s_mm = a.s_mm + (sigma_mm - a.sigma_mm) * (a.w + w) / 2.0;
        (s_mm.min(b.s_mm), w)
    }

    /// The distance along the path at profile distance `sigma_mm`, mm.
    #[must_use]
    pub fn path_mm(&self, sigma_mm: f64) -> f64 {
        self.at_sigma(sigma_mm).0
    }

    /// The profile distance at which it reaches `s_mm` along the path, mm.
    #[must_use]
    pub fn profile_mm(&self, s_mm: f64) -> f64 {
        let last = self.knots[self.knots.len() - 1];
        if s_mm >= last.s_mm {
            return last.sigma_mm;
        }
        let s_mm = s_mm.max(0.0);
        let i = self.stretch_of_s(s_mm);
        let (a, b) = (self.knots[i], self.knots[i + 1]);
        let u = a.w * a.w + (b.w * b.w - a.w * a.w) * (s_mm - a.s_mm) / (b.s_mm - a.s_mm);
        let w = u.max(0.0).sqrt();
        (a.sigma_mm + 2.0 * (s_mm - a.s_mm) / (a.w + w)).min(b.sigma_mm)
    }

    /// The tool's speed over the profile's at `s_mm` along the path.
    #[must_use]
    pub fn ratio_at(&self, s_mm: f64) -> f64 {
        self.at_sigma(self.profile_mm(s_mm)).1
    }

    /// The lowest ratio between `from_mm` and `to_mm` along the path.
    #[must_use]
    pub fn slowest(&self, from_mm: f64, to_mm: f64) -> f64 {
        self.knots
            .iter()
            .filter(|k| k.s_mm > from_mm && k.s_mm < to_mm)
            .map(|k| k.w)
            .fold(self.ratio_at(from_mm).min(self.ratio_at(to_mm)), f64::min)
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // a uniform pace is the identity, bit for bit
mod tests {
    use super::*;
    use crate::geometry::{Corner, Element, PathSpec, Pose};

    /// 200 mm along x, a blend of `blend_mm`, 200 mm along y.
    fn corner(blend_mm: f64) -> Path {
        let to = |x, y| Element::Line {
            to: Pose::from_mm_deg(x, y, 0.0, 0.0),
        };
        Path::build(&PathSpec {
            start: Pose::from_mm_deg(0.0, 0.0, 0.0, 0.0),
            elements: vec![
                (to(200.0, 0.0), Corner::Blend(blend_mm)),
                (to(200.0, 200.0), Corner::Stop),
            ],
        })
        .unwrap()
    }

    #[test]
    fn lines_alone_or_wide_arcs_leave_the_profile_on_the_path() {
        let path = corner(20.0);
        let pace = Pace::new(&path, 100.0, 1e9, 1_000.0, &[]);
        assert!(pace.is_uniform());
        for s in [0.0, 1.5, 100.0, 333.3] {
            assert_eq!(pace.path_mm(s), s);
            assert_eq!(pace.profile_mm(s), s);
        }
        assert_eq!(pace.profile_length_mm(), path.length_mm());
    }

    #[test]
    fn a_tight_blend_is_run_at_its_centripetal_speed_and_reached_at_the_tangential_acceleration() {
        let path = corner(20.0);
        let arc = path.pieces()[1];
        let r = 1.0 / arc.primitive.curvature_per_mm();
        let (v, a_c, a_t) = (240.0, 1_000.0, 1_200.0);
        let pace = Pace::new(&path, v, a_c, a_t, &[]);
        let on_arc = (a_c * r).sqrt() / v;
        assert!(on_arc < 1.0);
        // Across the whole arc, the arc's speed.
        let (a0, a1) = (arc.start_mm, arc.start_mm + arc.primitive.length_mm());
        for f in [0.0, 0.3, 1.0] {
            let w = pace.ratio_at(a0 + f * (a1 - a0));
            assert!((w - on_arc).abs() < 1e-12, "{f}: {w}");
        }
        assert!((pace.slowest(0.0, path.length_mm()) - on_arc).abs() < 1e-12);
        // Full speed again (v² - v_arc²) / (2 a_t) from the arc.
        let reach = v * v * (1.0 - on_arc * on_arc) / (2.0 * a_t);
        assert!((pace.ratio_at(a1 + reach) - 1.0).abs() < 1e-12);
        assert!(pace.ratio_at(a1 + reach * 0.9) < 1.0);
        assert!((pace.ratio_at(a0 - reach) - 1.0).abs() < 1e-12);
        // Half-way in, v² half-way between.
        let w2 = pace.ratio_at(a1 + reach / 2.0).powi(2);
        assert!(
            (w2 - f64::midpoint(1.0, on_arc * on_arc)).abs() < 1e-12,
            "{w2}"
        );
        // Longer in time than the path: the profile runs farther than the path is long.
        assert!(pace.profile_length_mm() > path.length_mm());
        assert_eq!(pace.path_mm(pace.profile_length_mm()), path.length_mm());
    }

    #[test]
    fn a_capped_stretch_of_a_line_is_run_at_its_cap_and_left_at_the_tangential_acceleration() {
        let path = corner(20.0);
        let cap = SpeedCap {
            from_mm: 100.0,
            to_mm: 150.0,
            speed_mm_s: 120.0,
        };
        let (v, a_t) = (240.0, 1_200.0);
        let pace = Pace::new(&path, v, 1e9, a_t, &[cap]);
        for s in [100.0, 125.0, 149.999] {
            assert!((pace.ratio_at(s) - 0.5).abs() < 1e-12, "{s}");
        }
        // (240^2 - 120^2) / (2 * 1200) = 18 mm either side.
        assert!((pace.ratio_at(150.0 + 18.0) - 1.0).abs() < 1e-12);
        assert!((pace.ratio_at(100.0 - 18.0) - 1.0).abs() < 1e-12);
        assert!(pace.ratio_at(150.0 + 17.0) < 1.0);
        assert!(pace.ratio_at(100.0 - 17.0) < 1.0);
        // The blend's arc is wide enough under 1e9 mm/s^2: full speed there.
        let arc = path.pieces()[1];
        assert!((pace.ratio_at(arc.start_mm + 1.0) - 1.0).abs() < 1e-12);
        assert_eq!(pace.path_mm(pace.profile_length_mm()), path.length_mm());
    }

    #[test]
    fn without_a_ramp_the_speed_steps_at_the_arc_and_still_honours_it() {
        let path = corner(20.0);
        let arc = path.pieces()[1];
        let r = 1.0 / arc.primitive.curvature_per_mm();
        let pace = Pace::new(&path, 240.0, 1_000.0, f64::INFINITY, &[]);
        let on_arc = (1_000.0 * r).sqrt() / 240.0;
        let (a0, a1) = (arc.start_mm, arc.start_mm + arc.primitive.length_mm());
        assert!((pace.ratio_at(f64::midpoint(a0, a1)) - on_arc).abs() < 1e-12);
        assert!((pace.ratio_at(a0 - 0.01) - 1.0).abs() < 1e-12);
        assert!((pace.ratio_at(a1 + 0.01) - 1.0).abs() < 1e-12);
        assert_eq!(pace.path_mm(pace.profile_length_mm()), path.length_mm());
    }

    #[test]
    fn profile_and_path_distances_map_both_ways_and_match_the_ratio() {
        let path = corner(30.0);
        let pace = Pace::new(&path, 300.0, 500.0, 800.0, &[]);
        let total = pace.profile_length_mm();
        let mut last = 0.0;
        for i in 0..=2_000 {
            let sigma = total * f64::from(i) / 2_000.0;
            let s = pace.path_mm(sigma);
            assert!(s >= last, "path distance goes back at {sigma}");
            assert!((pace.profile_mm(s) - sigma).abs() < 1e-9, "{sigma}");
            // ds/dσ is the ratio (numerically).
            let h = 1e-4;
            if sigma > h && sigma < total - h {
                let slope = (pace.path_mm(sigma + h) - pace.path_mm(sigma - h)) / (2.0 * h);
                assert!((slope - pace.ratio_at(s)).abs() < 1e-6, "{sigma}: {slope}");
            }
            last = s;
        }
    }

    #[test]
    fn two_tight_arcs_close_together_share_one_slow_stretch() {
        // Two blends 20 mm apart: the line between them is too short to reach full speed.
        let to = |x, y| Element::Line {
            to: Pose::from_mm_deg(x, y, 0.0, 0.0),
        };
        let path = Path::build(&PathSpec {
            start: Pose::from_mm_deg(0.0, 0.0, 0.0, 0.0),
            elements: vec![
                (to(200.0, 0.0), Corner::Blend(10.0)),
                (to(200.0, 40.0), Corner::Blend(10.0)),
                (to(0.0, 40.0), Corner::Stop),
            ],
        })
        .unwrap();
        let pace = Pace::new(&path, 240.0, 1_000.0, 1_200.0, &[]);
        let between = path.pieces()[2];
        let mid = between.start_mm + between.primitive.length_mm() / 2.0;
        assert!(pace.ratio_at(mid) < 1.0);
        // Never faster than any arc's limit plus the slope from it.
        let slope = 2.0 * 1_200.0 / (240.0 * 240.0);
        for i in 0..=400 {
            let s = path.length_mm() * f64::from(i) / 400.0;
            let w2 = pace.ratio_at(s).powi(2);
            for p in path.pieces() {
                let k = p.primitive.curvature_per_mm();
                if k > 0.0 {
                    let limit = (1_000.0 / k / (240.0 * 240.0)).min(1.0);
                    let end = p.start_mm + p.primitive.length_mm();
                    let dist = (p.start_mm - s).max(s - end).max(0.0);
                    assert!(w2 <= limit + slope * dist + 1e-12, "at {s}: {w2}");
                }
            }
        }
    }

    /// A trapezoid (1000 mm/s^2 up to 200 mm/s over 20 mm, cruise, down over 20 mm of 200 mm)
    /// as a time-optimal pace, averaged over 50 ms: the seven phases of an S-curve. It ends
    /// 50 ms later, at the path's end; its speed and acceleration stay within the trapezoid's;
    /// its jerk, read by third differences, is the acceleration over the window; and where the
    /// trapezoid cruises long enough it is at the trapezoid's position 25 ms earlier's speed.
    #[test]
    fn a_trapezoid_averaged_over_a_window_is_an_s_curve() {
        let (a, v, l) = (1_000.0_f64, 200.0_f64, 200.0_f64);
        let ramp_mm = v * v / (2.0 * a);
        let s: Vec<f64> = (0..=40).map(|i| l * f64::from(i) / 40.0).collect();
        let speeds: Vec<f64> = s
            .iter()
            .map(|&x| (2.0 * a * x.min(l - x)).sqrt().min(v))
            .collect();
        assert!(ramp_mm < l / 2.0);
        let pace = Pace::from_speeds(&s, &speeds, v).unwrap();
        let trapezoid = TimedKnots::new(&pace.knots, v);
        let window_s = 0.05;
        let smooth = pace.smoothed(v, window_s, 0.001).unwrap();
        let averaged = TimedKnots::new(&smooth.knots, v);
        assert!(
            (averaged.duration_s() - trapezoid.duration_s() - window_s).abs() < 2e-3,
            "{} against {}",
            averaged.duration_s(),
            trapezoid.duration_s()
        );
        assert_eq!(smooth.path_length_mm(), l);
        assert!(smooth.from_rest());
        let (lo, hi) = averaged.accel_range();
        assert!(
            lo >= -a * (1.0 + 1e-6) && hi <= a * (1.0 + 1e-6),
            "{lo} {hi}"
        );
        assert!(averaged.v_mm_s.iter().all(|&x| x <= v * (1.0 + 1e-9)));
        // The jerk over 10 ms, by third differences of the position: a / window at most, and
        // reached in the jerk phases.
        let tau = 0.01;
        let mut peak = 0.0_f64;
        let mut t = 0.0;
        while t + 3.0 * tau <= averaged.duration_s() {
            let p = |k: f64| averaged.position_mm(t + k * tau);
            let third = p(3.0) - 3.0 * p(2.0) + 3.0 * p(1.0) - p(0.0);
            peak = peak.max(third.abs() / tau.powi(3));
            t += 0.001;
        }
        let jerk = a / window_s;
        assert!(
            peak <= jerk * 1.05 && peak >= jerk * 0.9,
            "{peak} against {jerk}"
        );
        // Mid-cruise the average is the cruise itself, half a window behind, to within a
        // step's time: the knots' constant acceleration stands in for the average's from rest
        // (the first step, a cubic, is read as a parabola: two thirds of its time).
        let mid_s = trapezoid.duration_s() / 2.0;
        let behind = trapezoid.position_mm(mid_s - window_s / 2.0);
        let off_mm = averaged.position_mm(mid_s) - behind;
        assert!(off_mm.abs() < v * 0.001, "{off_mm} mm");
    }
}
