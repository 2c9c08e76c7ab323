//! The trapezoidal motion profile s(t) along a path, on the constant-period grid.
//!
//! The seed's equations 2-6 with its non-integer step counts decided:
//! - `Na = ceil(Ta / dT)` ramp periods: the ramp lasts a whole number of periods (never shorter
//!   than asked);
//! - `N0 = ceil(L / (V dT))`: the speed is lowered to `V' = L / (N0 dT)` so the line still ends
//!   exactly on P2 at `t = (N0 + Na) dT`;
//! - a move too short to reach V (`L < V Ta`) gets a triangular profile at the configured
//!   acceleration `a = V / Ta`: ramp time `sqrt(L / a)`, rounded up to whole periods, and the peak
//!   speed lowered to match;
//! - the ramp's acceleration is `V' / (Na dT)`, never above the configured `V / Ta`.

use thiserror::Error;

/// What a profile is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProfileRequest {
    /// Path length, mm.
    pub length_mm: f64,
    /// Cruise speed asked for, mm/s.
    pub speed_mm_s: f64,
    /// Acceleration (and deceleration) time asked for, s.
    pub accel_s: f64,
    /// Interpolation period, s.
    pub period_s: f64,
}

/// Why no profile can be made.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProfileError {
    /// A value that must be finite and above zero is not.
    #[error("{what} is {value}; it must be a number above 0")]
    NotPositive {
        /// Which value.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A value that must be finite and at least zero is not.
    #[error("{what} is {value}; it must be a number of at least 0")]
    Negative {
        /// Which value.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// More periods than any table could hold.
    #[error(
        "the move needs {} periods of {period_s} s; at most {max} are allowed",
        super::shown(*.periods, 0)
    )]
    TooManyPeriods {
        /// Periods needed.
        periods: f64,
        /// The period.
        period_s: f64,
        /// The most allowed.
        max: u32,
    },
}

/// A trapezoidal (or triangular) profile with whole-period phases.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    /// Path length, mm.
    pub length_mm: f64,
    /// Cruise (or peak) speed actually used, mm/s.
    pub speed_mm_s: f64,
    /// Acceleration actually used, mm/s^2 (an S-curve's: its peak).
    pub accel_mm_s2: f64,
    /// Ramp time, s (`ramp_periods * period_s`).
    pub accel_s: f64,
    /// Interpolation period, s.
    pub period_s: f64,
    /// Periods in each ramp (Na).
    pub ramp_periods: u32,
    /// Periods from the start to the start of the deceleration (N0).
    pub cruise_end_periods: u32,
    /// The last period's length, s: `period_s`, but for a profile at one speed along a pace
    /// that starts and ends at rest ([`Profile::paced`]), between half a period and a period
    /// and a half, so the profile keeps its speed.
    pub last_period_s: f64,
    /// An S-curve's jerk phase at each end of a ramp, s (0: the trapezoid's ramps, the
    /// acceleration a step); see [`Profile::s_curve`].
    pub jerk_s: f64,
}

/// The most periods one move may have (far beyond any table area).
pub(crate) const MAX_PERIODS: u32 = 1_000_000;

fn positive(what: &'static str, value: f64) -> Result<f64, ProfileError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ProfileError::NotPositive { what, value })
    }
}

/// The whole periods of `period_s` that `x` periods take (at least one), within
/// [`MAX_PERIODS`]. A hair of tolerance so 0.2 / 0.05 = 4.000000000000001 stays 4.
fn whole_periods(x: f64, period_s: f64) -> Result<u32, ProfileError> {
    let n = (x - 1e-9).ceil().max(1.0);
    if n > f64::from(MAX_PERIODS) {
        Err(ProfileError::TooManyPeriods {
            periods: n,
            period_s,
            max: MAX_PERIODS,
        })
    } else {
        Ok(n as u32)
    }
}

impl Profile {
    /// Plans the profile; see the module docs for how non-integer step counts are decided.
    pub fn new(req: ProfileRequest) -> Result<Self, ProfileError> {
        let length_mm = positive("length_mm", req.length_mm)?;
        let speed = positive("speed_mm_s", req.speed_mm_s)?;
        let period_s = positive("period_s", req.period_s)?;
        if !req.accel_s.is_finite() || req.accel_s < 0.0 {
            return Err(ProfileError::Negative {
                what: "accel_s",
                value: req.accel_s,
            });
        }
        let whole = |x: f64| whole_periods(x, period_s);
        if req.accel_s == 0.0 {
            // No ramp asked for: a constant speed for the whole line.
            let n0 = whole(length_mm / (speed * period_s))?;
            return Ok(Self::constant(length_mm, n0, period_s));
        }
        let accel = speed / req.accel_s;
        let (na, n0) = if length_mm >= speed * req.accel_s {
            let na = whole(req.accel_s / period_s)?;
            let n0 = whole(length_mm / (speed * period_s))?.max(na);
            (na, n0)
        } else {
            let na = whole((length_mm / accel).sqrt() / period_s)?;
            (na, na)
        };
        let speed_mm_s = length_mm / (f64::from(n0) * period_s);
        let accel_s = f64::from(na) * period_s;
        Ok(Self {
            length_mm,
            speed_mm_s,
            accel_mm_s2: speed_mm_s / accel_s,
            accel_s,
            period_s,
            ramp_periods: na,
            cruise_end_periods: n0,
            last_period_s: period_s,
            jerk_s: 0.0,
        })
    }

    /// A constant speed along `length_mm` for `periods` of `period_s`: no ramp.
    fn constant(length_mm: f64, periods: u32, period_s: f64) -> Self {
        Self {
            length_mm,
            speed_mm_s: length_mm / (f64::from(periods) * period_s),
            accel_mm_s2: f64::INFINITY,
            accel_s: 0.0,
            period_s,
            ramp_periods: 0,
            cruise_end_periods: periods,
            last_period_s: period_s,
            jerk_s: 0.0,
        }
    }

    /// The jerk-limited (S-curve) profile of `req` under `jerk_mm_s3`: every ramp's acceleration
    /// rises at that jerk to at most the trapezoid's (`speed / accel_s`), holds, and falls at
    /// that jerk (seven phases over the move). The ramps are whole periods as the trapezoid's,
    /// each lengthened by the jerk's time `a / j` (and, where the peak acceleration or the jerk
    /// would still pass its limit, by 5 % and a period more until neither does: a short move's
    /// triangle), so the S-curve never accelerates harder than the trapezoid and takes longer
    /// by about `a / j` per move.
    pub fn s_curve(req: ProfileRequest, jerk_mm_s3: f64) -> Result<Self, ProfileError> {
        let jerk = positive("jerk_mm_s3", jerk_mm_s3)?;
        let accel = positive("accel_s", req.accel_s).map(|ta| req.speed_mm_s / ta)?;
        let mut ramp_s = req.accel_s + accel / jerk;
        loop {
            let base = Self::new(ProfileRequest {
                accel_s: ramp_s,
                ..req
            })?;
            let tr = base.accel_s;
            let jerk_s = (accel / jerk).min(tr / 2.0);
            let peak = base.speed_mm_s / (tr - jerk_s);
            if (peak <= accel * (1.0 + 1e-9) && peak / jerk_s <= jerk * (1.0 + 1e-9))
                || base.ramp_periods >= MAX_PERIODS
            {
                return Ok(Self {
                    accel_mm_s2: peak,
                    jerk_s,
                    ..base
                });
            }
            // Longer ramps, growing: a short move's triangle takes a ramp of about the square
            // root of the time asked, so a step of one period alone need not end.
            ramp_s = ramp_s.max(tr) * 1.05 + req.period_s;
        }
    }

    /// A profile at `speed_mm_s` for the whole of `length_mm`, with no ramp of its own (the
    /// pace it runs along starts and ends at rest: a time-optimal motion), its periods whole
    /// but the last, which is between half a period and a period and a half long: the speed is
    /// kept, where [`Profile::new`] lowers it to end on a whole period (up to a period longer).
    pub fn paced(length_mm: f64, speed_mm_s: f64, period_s: f64) -> Result<Self, ProfileError> {
        let length_mm = positive("length_mm", length_mm)?;
        let speed_mm_s = positive("speed_mm_s", speed_mm_s)?;
        let period_s = positive("period_s", period_s)?;
        let total_s = length_mm / speed_mm_s;
        let periods = (total_s / period_s).round().max(1.0);
        if periods > f64::from(MAX_PERIODS) {
            return Err(ProfileError::TooManyPeriods {
                periods,
                period_s,
                max: MAX_PERIODS,
            });
        }
        Ok(Self {
            length_mm,
            speed_mm_s,
            accel_mm_s2: f64::INFINITY,
            accel_s: 0.0,
            period_s,
            ramp_periods: 0,
            cruise_end_periods: periods as u32,
            last_period_s: total_s - (periods - 1.0) * period_s,
            jerk_s: 0.0,
        })
    }

    /// Periods in the whole move (N = N0 + Na).
    #[must_use]
    pub fn periods(&self) -> u32 {
        self.cruise_end_periods + self.ramp_periods
    }

    /// Duration of the move, s.
    #[must_use]
    #[allow(clippy::float_cmp)] // a whole last period, bit for bit as ever
    pub fn duration_s(&self) -> f64 {
        if self.last_period_s == self.period_s {
            f64::from(self.periods()) * self.period_s
        } else {
            f64::from(self.periods() - 1) * self.period_s + self.last_period_s
        }
    }

    /// Distance from P1 at time `t_s` (eq. 6, in continuous time), mm.
    #[must_use]
    pub fn distance_mm(&self, t_s: f64) -> f64 {
        let total = self.duration_s();
        let t = t_s.clamp(0.0, total);
        let ta = self.accel_s;
        if ta == 0.0 {
            return self.speed_mm_s * t;
        }
        if t <= ta {
            self.ramp_mm(t)
        } else if t <= total - ta {
            self.ramp_mm(ta) + self.speed_mm_s * (t - ta)
        } else {
            self.length_mm - self.ramp_mm(total - t)
        }
    }

    /// The distance a ramp covers from rest in `t_s` (at most its length), mm: `a t^2 / 2` for
    /// the trapezoid; for an S-curve its jerk phase, constant acceleration and jerk phase again.
    fn ramp_mm(&self, t_s: f64) -> f64 {
        let a = self.accel_mm_s2;
        let tj = self.jerk_s;
        if tj == 0.0 {
            return 0.5 * a * t_s * t_s;
        }
        let tr = self.accel_s;
        if t_s <= tj {
            a * t_s.powi(3) / (6.0 * tj)
        } else if t_s <= tr - tj {
            a * tj * tj / 6.0 + a * ((t_s - tj / 2.0).powi(2) - tj * tj / 4.0) / 2.0
        } else {
            let r = tr - t_s;
            self.speed_mm_s * tr / 2.0 - (self.speed_mm_s * r - a * r.powi(3) / (6.0 * tj))
        }
    }

    /// The speed a ramp reaches from rest in `t_s`, mm/s.
    fn ramp_speed_mm_s(&self, t_s: f64) -> f64 {
        let a = self.accel_mm_s2;
        let tj = self.jerk_s;
        if tj == 0.0 {
            return a * t_s;
        }
        let tr = self.accel_s;
        if t_s <= tj {
            a * t_s * t_s / (2.0 * tj)
        } else if t_s <= tr - tj {
            a * (t_s - tj / 2.0)
        } else {
            let r = tr - t_s;
            self.speed_mm_s - a * r * r / (2.0 * tj)
        }
    }

    /// The time at which the profile reaches `s_mm` from P1 (clamped to the ends), s: the
    /// inverse of [`Self::distance_mm`], found by bisection (the distance never falls).
    #[must_use]
    pub fn time_at_mm(&self, s_mm: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, self.duration_s());
        if s_mm <= 0.0 {
            return lo;
        }
        if s_mm >= self.length_mm {
            return hi;
        }
        for _ in 0..60 {
            let mid = f64::midpoint(lo, hi);
            if self.distance_mm(mid) < s_mm {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        f64::midpoint(lo, hi)
    }

    /// Distance from P1 at interpolation point `i` (0..=N), mm. Point N is exactly the length.
    #[must_use]
    pub fn distance_at_point_mm(&self, i: u32) -> f64 {
        if i >= self.periods() {
            self.length_mm
        } else {
            self.distance_mm(f64::from(i) * self.period_s)
        }
    }

    /// Speed at time `t_s`, mm/s.
    #[must_use]
    pub fn speed_at_mm_s(&self, t_s: f64) -> f64 {
        let total = self.duration_s();
        if !(0.0..=total).contains(&t_s) {
            return 0.0;
        }
        let ta = self.accel_s;
        if ta == 0.0 {
            self.speed_mm_s
        } else if t_s <= ta {
            self.ramp_speed_mm_s(t_s)
        } else if t_s <= total - ta {
            self.speed_mm_s
        } else {
            self.ramp_speed_mm_s(total - t_s)
        }
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // the end point is exact by construction
mod tests {
    use super::*;

    fn seed() -> Profile {
        Profile::new(ProfileRequest {
            length_mm: 285.73,
            speed_mm_s: 240.0,
            accel_s: 0.2,
            period_s: 0.05,
        })
        .unwrap()
    }

    #[test]
    fn an_s_curve_keeps_its_acceleration_and_jerk_and_ends_where_the_trapezoid_does() {
        let req = ProfileRequest {
            length_mm: 285.73,
            speed_mm_s: 240.0,
            accel_s: 0.2,
            period_s: 0.05,
        };
        for jerk in [5_000.0, 20_000.0, 1e6] {
            let p = Profile::s_curve(req, jerk).unwrap();
            let accel = 240.0 / 0.2;
            assert!(p.accel_mm_s2 <= accel * (1.0 + 1e-9), "{p:?}");
            assert!(p.accel_mm_s2 / p.jerk_s <= jerk * (1.0 + 1e-9), "{p:?}");
            assert!(p.duration_s() >= seed().duration_s());
            assert!((p.distance_mm(p.duration_s()) - 285.73).abs() < 1e-9);
            // Speed from the distance, numerically, and its steps: no jump in the speed, no
            // acceleration beyond the limit, jerk within it (sampled every 0.1 ms).
            let h = 1e-4;
            let n = (p.duration_s() / h) as usize;
            let v: Vec<f64> = (0..n).map(|i| p.speed_at_mm_s(i as f64 * h)).collect();
            for i in 1..n {
                let d = (p.distance_mm(i as f64 * h) - p.distance_mm((i - 1) as f64 * h)) / h;
                let mid = f64::midpoint(v[i], v[i - 1]);
                assert!(
                    (d - mid).abs() < 1e-3,
                    "jerk {jerk}, t {}: {d} {mid}",
                    i as f64 * h
                );
                assert!((v[i] - v[i - 1]).abs() / h <= accel * (1.0 + 1e-6) + 1e-6);
            }
            for i in 2..n {
                let jerk_here = (v[i] - 2.0 * v[i - 1] + v[i - 2]).abs() / (h * h);
                assert!(jerk_here <= jerk * 1.01 + 1.0, "jerk {jerk}: {jerk_here}");
            }
        }
        // A very high jerk is the trapezoid's shape plus a period at most.
        let p = Profile::s_curve(req, 1e9).unwrap();
        assert!(p.duration_s() <= seed().duration_s() + 0.05 + 1e-12);
    }

    #[test]
    fn a_short_s_curve_move_ends_its_search_within_its_limits() {
        // A 2 mm move on a 1 ms grid: its ramps are triangles, and a search lengthening them by
        // a period went round for ever.
        for (length_mm, jerk) in [(2.0, 2_000.0), (0.5, 150_000.0), (40.0, 3_000.0)] {
            let req = ProfileRequest {
                length_mm,
                speed_mm_s: 500.0,
                accel_s: 0.05,
                period_s: 0.001,
            };
            let p = Profile::s_curve(req, jerk).unwrap();
            assert!(p.accel_mm_s2 <= 10_000.0 * (1.0 + 1e-9), "{p:?}");
            assert!(p.accel_mm_s2 / p.jerk_s <= jerk * (1.0 + 1e-9), "{p:?}");
            assert!((p.distance_mm(p.duration_s()) - length_mm).abs() < 1e-9);
        }
    }

    #[test]
    fn seed_move_rounds_n0_up_and_lowers_the_speed() {
        let p = seed();
        // N0 = 285.73 / (240 * 0.05) = 23.81 -> 24; Na = 4.
        assert_eq!(
            (p.cruise_end_periods, p.ramp_periods, p.periods()),
            (24, 4, 28)
        );
        assert!((p.speed_mm_s - 285.73 / 1.2).abs() < 1e-9);
        assert!(p.speed_mm_s <= 240.0);
        assert!((p.duration_s() - 1.4).abs() < 1e-12);
    }

    #[test]
    fn profile_ends_exactly_on_the_length_and_is_continuous() {
        let p = seed();
        assert_eq!(p.distance_at_point_mm(p.periods()), 285.73);
        assert!((p.distance_mm(p.duration_s()) - 285.73).abs() < 1e-9);
        for t in [p.accel_s, p.duration_s() - p.accel_s] {
            let (a, b) = (p.distance_mm(t - 1e-9), p.distance_mm(t + 1e-9));
            assert!((a - b).abs() < 1e-6, "jump at {t}: {a} vs {b}");
        }
    }

    #[test]
    fn short_move_gets_a_triangular_profile_at_the_configured_acceleration() {
        // a = 240 / 0.2 = 1200 mm/s^2; L = 12 mm: sqrt(12 / 1200) = 0.1 s ramp = 2 periods.
        let p = Profile::new(ProfileRequest {
            length_mm: 12.0,
            speed_mm_s: 240.0,
            accel_s: 0.2,
            period_s: 0.05,
        })
        .unwrap();
        assert_eq!((p.ramp_periods, p.cruise_end_periods), (2, 2));
        assert!(p.accel_mm_s2 <= 1200.0 + 1e-9);
        assert!((p.distance_mm(p.duration_s()) - 12.0).abs() < 1e-9);
        assert!((p.distance_mm(0.1) - 6.0).abs() < 1e-9);
    }

    #[test]
    fn time_at_a_distance_inverts_the_distance_at_a_time() {
        let p = seed();
        for t in [0.0, 0.05, 0.2, 0.7, p.duration_s() - 0.1, p.duration_s()] {
            let back = p.time_at_mm(p.distance_mm(t));
            assert!((back - t).abs() < 1e-9, "{t} s -> {back} s");
        }
        assert!(p.time_at_mm(-1.0).abs() < 1e-12);
        assert!((p.time_at_mm(1e6) - p.duration_s()).abs() < 1e-12);
    }

    #[test]
    fn zero_or_negative_inputs_are_refused_with_their_value() {
        let bad = ProfileRequest {
            length_mm: 10.0,
            speed_mm_s: 0.0,
            accel_s: 0.2,
            period_s: 0.05,
        };
        let err = Profile::new(bad).unwrap_err();
        assert_eq!(
            err.to_string(),
            "speed_mm_s is 0; it must be a number above 0"
        );
        let nan = ProfileRequest {
            period_s: f64::NAN,
            ..bad
        };
        assert!(Profile::new(nan).is_err());
    }
}
