//! Clocks for whatever drives the mock: the core itself only ever takes `now_s` as an argument.
//! A [`VirtualClock`] is stepped by tests; a [`RealClock`] reads monotonic time since it was made
//! (for the standalone mock PLC).

use std::time::Instant;

/// Seconds since the mock started.
pub trait Clock {
    /// The time now, s since the clock started.
    fn now_s(&self) -> f64;
}

/// A clock that only moves when told to.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VirtualClock {
    now_s: f64,
}

impl VirtualClock {
    /// A clock at 0 s.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Moves the clock on by `dt_s` (negative or non-finite steps are ignored) and returns the
    /// new time.
    pub fn advance(&mut self, dt_s: f64) -> f64 {
        if dt_s.is_finite() && dt_s > 0.0 {
            self.now_s += dt_s;
        }
        self.now_s
    }
}

impl Clock for VirtualClock {
    fn now_s(&self) -> f64 {
        self.now_s
    }
}

/// Monotonic wall time since the clock was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RealClock {
    started: Instant,
}

impl RealClock {
    /// A clock starting now.
    #[must_use]
    pub fn new() -> Self {
        Self {
            started: Instant::now(),
        }
    }
}

impl Default for RealClock {
    fn default() -> Self {
        Self::new()
    }
}

impl Clock for RealClock {
    fn now_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn virtual_clock_moves_only_forward_when_stepped() {
        let mut c = VirtualClock::new();
        assert!(c.now_s().abs() < 1e-12);
        c.advance(0.25);
        c.advance(-1.0);
        c.advance(f64::NAN);
        assert!((c.now_s() - 0.25).abs() < 1e-12);
    }

    #[test]
    fn real_clock_is_monotonic() {
        let c = RealClock::new();
        let a = c.now_s();
        assert!(c.now_s() >= a);
    }
}
