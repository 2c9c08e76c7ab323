//! IO. One [`MockPlc`] shared by every server and connection, with the clock that drives it.
//!
//! ```text
//!  SharedMock (Clone)  = Arc<Mutex<MockPlc>> + MockClock
//!    MockClock::Tokio    tokio time since the mock started (real time, or paused time in tests)
//!    MockClock::Stepped  a virtual clock only `step` moves (tests)
//!  run_scans()         the driver: advance_to(now) once a scan period, in real time
//!  with(op)            every server access: advance to the clock's now, then op on the mock
//! ```
//! Scans are also caught up lazily on every access, so a server never sees a stale status
//! block even when the driver lags.

use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use tokio::time::{Instant, MissedTickBehavior};

use super::MockPlc;

/// Where a shared mock's time comes from.
#[derive(Debug, Clone)]
enum MockClock {
    /// Tokio time since `started` (follows paused time in tests).
    Tokio {
        /// The instant of mock time 0.
        started: Instant,
    },
    /// Virtual seconds, moved only by [`SharedMock::step`].
    Stepped(Arc<Mutex<f64>>),
}

/// A mock PLC shared by servers, with its clock.
#[derive(Debug, Clone)]
pub struct SharedMock {
    mock: Arc<Mutex<MockPlc>>,
    clock: MockClock,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl SharedMock {
    /// A mock on tokio's clock: mock time `mock.now_s()` is now. Real time in a daemon, paused
    /// time in tests.
    #[must_use]
    pub fn new(mock: MockPlc) -> Self {
        let offset = Duration::from_secs_f64(mock.now_s().max(0.0));
        let now = Instant::now();
        let started = now.checked_sub(offset).unwrap_or(now);
        Self {
            mock: Arc::new(Mutex::new(mock)),
            clock: MockClock::Tokio { started },
        }
    }

    /// A mock on a virtual clock that only [`Self::step`] moves.
    #[must_use]
    pub fn stepped(mock: MockPlc) -> Self {
        let now_s = mock.now_s();
        Self {
            mock: Arc::new(Mutex::new(mock)),
            clock: MockClock::Stepped(Arc::new(Mutex::new(now_s))),
        }
    }

    /// The mock itself (for an [`super::InProcess`] handle or a test's inspection).
    #[must_use]
    pub fn mock(&self) -> Arc<Mutex<MockPlc>> {
        Arc::clone(&self.mock)
    }

    /// The clock's time, s since the mock started.
    #[must_use]
    pub fn now_s(&self) -> f64 {
        match &self.clock {
            MockClock::Tokio { started } => started.elapsed().as_secs_f64(),
            MockClock::Stepped(now_s) => *lock(now_s),
        }
    }

    /// Moves a stepped clock on by `dt_s` and the mock with it; a tokio clock ignores this.
    pub fn step(&self, dt_s: f64) {
        if let MockClock::Stepped(now_s) = &self.clock
            && dt_s.is_finite()
            && dt_s > 0.0
        {
            *lock(now_s) += dt_s;
        }
        self.with(|_| ());
    }

    /// Advances the mock to the clock's time, then runs `op` on it (under the lock).
    pub fn with<T>(&self, op: impl FnOnce(&mut MockPlc) -> T) -> T {
        let now_s = self.now_s();
        let mut mock = lock(&self.mock);
        mock.advance_to(now_s);
        op(&mut mock)
    }

    /// The scan time, s.
    #[must_use]
    pub fn scan_s(&self) -> f64 {
        lock(&self.mock).config().scan_s
    }

    /// The first scan boundary strictly after `at_s`: when the scan running at `at_s` ends.
    #[must_use]
    pub fn scan_end_after_s(&self, at_s: f64) -> f64 {
        let scan_s = self.scan_s();
        ((at_s / scan_s).floor() + 1.0) * scan_s
    }

    /// Waits until the clock reads `at_s` (a stepped clock does not wait).
    pub async fn sleep_until_s(&self, at_s: f64) {
        if let MockClock::Tokio { started } = &self.clock
            && at_s.is_finite()
            && at_s > 0.0
        {
            tokio::time::sleep_until(*started + Duration::from_secs_f64(at_s)).await;
        }
    }

    /// Waits for the end of the scan running now (the PLC answers at the end of a scan) and
    /// returns that time, s.
    pub async fn wait_scan_end(&self) -> f64 {
        let end_s = self.scan_end_after_s(self.now_s());
        self.sleep_until_s(end_s).await;
        end_s
    }

    /// The driver: advances the mock once a scan period, forever (spawn it; abort to stop).
    /// Late ticks are skipped; the next access catches every missed scan up anyway.
    pub async fn run_scans(self) {
        let period = Duration::from_secs_f64(self.scan_s());
        let mut ticks = tokio::time::interval(period);
        ticks.set_missed_tick_behavior(MissedTickBehavior::Skip);
        loop {
            ticks.tick().await;
            self.with(|_| ());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mock::MockConfig;

    fn mock() -> MockPlc {
        MockPlc::new(MockConfig::default()).unwrap()
    }

    #[test]
    fn stepped_clock_moves_the_mock_only_when_stepped() {
        let shared = SharedMock::stepped(mock());
        let scans = shared.with(|m| m.scans());
        shared.step(0.010);
        assert!((shared.now_s() - 0.010).abs() < 1e-12);
        assert_eq!(shared.with(|m| m.scans()), scans + 5);
    }

    #[tokio::test(start_paused = true)]
    async fn driver_runs_scans_in_tokio_time() {
        let shared = SharedMock::new(mock());
        let driver = tokio::spawn(shared.clone().run_scans());
        tokio::time::sleep(Duration::from_millis(100)).await;
        let scans = lock(&shared.mock).scans();
        assert!((50..=52).contains(&scans), "{scans} scans in 100 ms");
        driver.abort();
    }

    #[tokio::test(start_paused = true)]
    async fn scan_end_is_the_next_boundary() {
        let shared = SharedMock::new(mock());
        tokio::time::sleep(Duration::from_micros(4_500)).await;
        let end_s = shared.wait_scan_end().await;
        assert!((end_s - 0.006).abs() < 1e-9, "{end_s}");
        assert!(shared.now_s() >= 0.006 - 1e-9);
    }
}
