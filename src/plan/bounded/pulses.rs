//! Every pulse a joint must make along the planned trajectory, when it would ideally land, and
//! the window of times in which it may land while the joint stays within its error budget.
//!
//! With `u(t)` the joint's fractional count, the count `c` is ideal when `|u - c| <= 1/2`: the
//! pulse from `c` to `c + 1` ideally lands when `u` crosses `c + 1/2`. Allowing `delta` pulses of
//! error, it may land from when `u` reaches `c + 1/2 - delta` until it reaches `c + 1/2 + delta`
//! (or the joint turns): then `|u - count| <= 1/2 + delta` at every instant.

use crate::table::Direction;

/// One pulse to make.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Pulse {
    /// The count after the pulse.
    pub count: i64,
    /// When the trajectory crosses the half count, s.
    pub ideal_s: f64,
    /// Earliest allowed landing, s.
    pub lo_s: f64,
    /// Latest allowed landing, s.
    pub hi_s: f64,
}

/// Pulses in one direction, back to back ([`super::windows::Windows::runs`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Run<P> {
    /// Their direction.
    pub direction: Direction,
    /// The pulses, in order.
    pub pulses: P,
}

/// A joint's pulses made one by one ([`Track::pulses_into`]) cut where the direction changes.
#[cfg(test)]
pub(super) fn runs<'a>(
    pulses: &'a [Pulse],
    starts: &[(usize, Direction)],
) -> Vec<Run<&'a [Pulse]>> {
    starts
        .iter()
        .enumerate()
        .map(|(k, &(from, direction))| Run {
            direction,
            pulses: &pulses[from..starts.get(k + 1).map_or(pulses.len(), |s| s.0)],
        })
        .collect()
}

/// A joint's fractional count at every sample, with every interval's reciprocal change (0
/// where it holds): made once per plan, so that finding when the count passes a level is a
/// product, not a division.
pub(super) struct Counts {
    u: Vec<f64>,
    per_count: Vec<f64>,
}

impl Counts {
    /// The counts `u`, one per sample.
    pub(super) fn new(u: Vec<f64>) -> Self {
        let per_count = u
            .windows(2)
            .map(|w| {
                let du = w[1] - w[0];
                if du.abs() <= f64::MIN_POSITIVE {
                    0.0
                } else {
                    1.0 / du
                }
            })
            .collect();
        Self { u, per_count }
    }

    /// The counts as a track sampled every `dt_s` from t = 0.
    pub(super) fn track(&self, dt_s: f64) -> Track<'_> {
        Track {
            u: &self.u,
            per_count: &self.per_count,
            dt_s,
        }
    }
}

/// A joint's fractional count sampled every `dt_s` from t = 0 ([`Counts::track`]).
#[derive(Clone, Copy)]
pub(super) struct Track<'a> {
    /// `u[i]` at `i * dt_s`.
    u: &'a [f64],
    /// Every interval's `1 / (u[i + 1] - u[i])`.
    per_count: &'a [f64],
    /// Sample spacing, s.
    dt_s: f64,
}

impl<'a> Track<'a> {
    /// The counts, one per sample.
    pub(super) fn counts(&self) -> &'a [f64] {
        self.u
    }

    /// Every interval's reciprocal change of count (0 where it holds).
    pub(super) fn rates(&self) -> &'a [f64] {
        self.per_count
    }

    /// The time of sample `i`.
    pub(super) fn t(&self, i: usize) -> f64 {
        i as f64 * self.dt_s
    }

    /// Time in sample interval `i` at which `u` passes `level` (linear between samples).
    pub(super) fn at(&self, i: usize, level: f64) -> f64 {
        let f = ((level - self.u[i]) * self.per_count[i]).clamp(0.0, 1.0);
        self.t(i) + f * self.dt_s
    }

    /// Moving in direction `d` (+1/-1) between samples `i` and `i + 1`.
    pub(super) fn moves(&self, i: usize, d: f64) -> bool {
        (self.u[i + 1] - self.u[i]) * d > 0.0
    }

    /// Earliest time, searching back from interval `i`, since which `u` is past `level`.
    #[cfg(test)]
    fn since(&self, mut i: usize, level: f64, d: f64) -> f64 {
        loop {
            if (self.u[i] - level) * d <= 0.0 {
                return self.at(i, level);
            }
            if i == 0 || !self.moves(i - 1, d) {
                return self.t(i);
            }
            i -= 1;
        }
    }

    /// Latest time, searching on from interval `i`, before which `u` has not reached `level`.
    #[cfg(test)]
    fn until(&self, mut i: usize, level: f64, d: f64) -> f64 {
        loop {
            if (self.u[i + 1] - level) * d >= 0.0 {
                return self.at(i, level);
            }
            if i + 2 >= self.u.len() || !self.moves(i + 1, d) {
                return self.t(i + 1);
            }
            i += 1;
        }
    }

    /// Every half count the trajectory crosses from count `start`, in time order, made as they
    /// are read.
    pub(super) fn crossings(&self, start: i64) -> Crossings<'a> {
        Crossings {
            u: self.u,
            i: 0,
            count: start,
        }
    }

    /// When each of the joint's pulses from count `start` lands exactly on time (the trajectory
    /// crosses the half count), and the count after it, in time order, made as they are read.
    pub(super) fn on_time(self, start: i64) -> impl Iterator<Item = (f64, i64)> + 'a {
        self.crossings(start)
            .map(move |c| (self.at(c.interval, c.half), c.count))
    }

    /// The joint's pulses from count `start`, with windows `delta` pulses wide each side,
    /// made one by one and written over `pulses`; returns where each run of one direction
    /// starts ([`runs`] cuts them). What [`Track::windows`] reads is checked against it.
    #[cfg(test)]
    pub(super) fn pulses_into(
        &self,
        start: i64,
        delta: f64,
        pulses: &mut Vec<Pulse>,
    ) -> Vec<(usize, Direction)> {
        pulses.clear();
        let mut starts: Vec<(usize, Direction)> = Vec::new();
        for c in self.crossings(start) {
            let (i, h, df) = (c.interval, c.half, c.direction);
            let pulse = Pulse {
                count: c.count,
                ideal_s: self.at(i, h),
                lo_s: self.since(i, h - df * delta, df),
                hi_s: self.until(i, h + df * delta, df),
            };
            let direction = if df > 0.0 {
                Direction::Up
            } else {
                Direction::Down
            };
            if starts.last().is_none_or(|s| s.1 != direction) {
                starts.push((pulses.len(), direction));
            }
            pulses.push(pulse);
        }
        starts
    }
}

/// A half count the trajectory crosses ([`Track::crossings`]).
pub(super) struct Crossing {
    /// The sample interval it is crossed in.
    pub interval: usize,
    /// The half count.
    pub half: f64,
    /// +1 counting up, -1 down.
    #[cfg(test)]
    pub direction: f64,
    /// The count after the pulse.
    pub count: i64,
}

/// The half counts a track crosses, from a start count: the count follows the trajectory,
/// a pulse each time it passes the half count above or below.
pub(super) struct Crossings<'a> {
    u: &'a [f64],
    /// The interval being crossed: `u[i]` to `u[i + 1]`.
    i: usize,
    count: i64,
}

impl Iterator for Crossings<'_> {
    type Item = Crossing;

    fn next(&mut self) -> Option<Crossing> {
        while self.i + 1 < self.u.len() {
            let b = self.u[self.i + 1];
            let d = if b > self.count as f64 + 0.5 {
                1
            } else if b < self.count as f64 - 0.5 {
                -1
            } else {
                self.i += 1;
                continue;
            };
            let half = self.count as f64 + 0.5 * f64::from(d);
            self.count += i64::from(d);
            return Some(Crossing {
                interval: self.i,
                half,
                #[cfg(test)]
                direction: f64::from(d),
                count: self.count,
            });
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steady_motion_gives_evenly_spaced_pulses_with_symmetric_windows() {
        // u = 10 t, sampled every 0.1 s: pulses cross 0.5, 1.5, ... at 0.05, 0.15, ...
        let u: Vec<f64> = (0..=10).map(f64::from).collect();
        let mut pulses = Vec::new();
        let starts = Counts::new(u).track(0.1).pulses_into(0, 0.25, &mut pulses);
        let runs = runs(&pulses, &starts);
        assert_eq!(runs.len(), 1);
        let p = &runs[0].pulses;
        assert_eq!(p.len(), 10);
        assert!((p[0].ideal_s - 0.05).abs() < 1e-12);
        assert!((p[3].lo_s - 0.325).abs() < 1e-12 && (p[3].hi_s - 0.375).abs() < 1e-12);
        assert_eq!(p[9].count, 10);
    }

    #[test]
    fn reversal_starts_a_new_run_and_bounds_the_window_at_the_turn() {
        let mut pulses = Vec::new();
        let starts = Counts::new(vec![0.0, 1.0, 2.0, 1.0, 0.0])
            .track(1.0)
            .pulses_into(0, 3.0, &mut pulses);
        let runs = runs(&pulses, &starts);
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0].direction, Direction::Up);
        assert_eq!(runs[1].pulses.last().unwrap().count, 0);
        // The last up pulse may land no later than the turn at t = 2.
        assert!((runs[0].pulses[1].hi_s - 2.0).abs() < 1e-12);
    }
}
