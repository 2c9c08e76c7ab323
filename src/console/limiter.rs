//! PURE. Failed logins, rate-limited per client address and per user name: after
//! [`MAX_FAILURES`] failures within [`WINDOW`], further attempts from that address or for that
//! user are refused (without checking the password) until the oldest failure leaves the window.
//! A success clears the user's count (not the address's: one user's success does not lift a
//! guessing client's block). `now` is an argument; the map is bounded ([`MAX_KEYS`]).

use std::collections::{BTreeMap, VecDeque};
use std::net::IpAddr;
use std::time::{Duration, Instant};

/// Failures allowed within [`WINDOW`].
pub const MAX_FAILURES: usize = 5;
/// The window failures are counted over.
pub const WINDOW: Duration = Duration::from_secs(60);
/// The most addresses and users tracked; the one whose newest failure is oldest goes first.
pub const MAX_KEYS: usize = 10_000;

/// Whom failures are counted against.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub enum Key {
    /// A client address.
    Client(IpAddr),
    /// A user name as typed.
    User(String),
}

/// Failed logins by client and by user.
#[derive(Debug, Clone, Default)]
pub struct LoginLimiter {
    failures: BTreeMap<Key, VecDeque<Instant>>,
}

/// A login refused before its password was checked.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "too many failed logins {whom}: {MAX_FAILURES} within {} s; try again in {} s",
    WINDOW.as_secs(),
    retry_after.as_secs().max(1)
)]
pub struct Limited {
    /// `from 10.0.0.5` or `for user "ann"`.
    pub whom: String,
    /// When the next attempt will be taken.
    pub retry_after: Duration,
}

impl LoginLimiter {
    /// Whether a login from `client` for `user` may be checked now.
    pub fn check(&mut self, client: IpAddr, user: &str, now: Instant) -> Result<(), Limited> {
        for key in [Key::Client(client), Key::User(user.to_owned())] {
            let Some(times) = self.failures.get_mut(&key) else {
                continue;
            };
            while times
                .front()
                .is_some_and(|t| now.duration_since(*t) >= WINDOW)
            {
                times.pop_front();
            }
            if times.len() >= MAX_FAILURES {
                let oldest = times[0];
                return Err(Limited {
                    whom: match &key {
                        Key::Client(ip) => format!("from {ip}"),
                        Key::User(u) => format!("for user {u:?}"),
                    },
                    retry_after: (oldest + WINDOW).saturating_duration_since(now),
                });
            }
        }
        Ok(())
    }

    /// A login from `client` for `user` failed at `now`.
    pub fn failed(&mut self, client: IpAddr, user: &str, now: Instant) {
        for key in [Key::Client(client), Key::User(user.to_owned())] {
            let times = self.failures.entry(key).or_default();
            times.push_back(now);
            while times.len() > MAX_FAILURES {
                times.pop_front();
            }
        }
        while self.failures.len() > MAX_KEYS {
            let stalest = self
                .failures
                .iter()
                .min_by_key(|(_, t)| t.back().copied())
                .map(|(k, _)| k.clone());
            if let Some(key) = stalest {
                self.failures.remove(&key);
            }
        }
    }

    /// A login for `user` succeeded.
    pub fn succeeded(&mut self, user: &str) {
        self.failures.remove(&Key::User(user.to_owned()));
    }

    /// How many addresses and users are tracked.
    #[must_use]
    pub fn tracked(&self) -> usize {
        self.failures.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ip(n: u8) -> IpAddr {
        IpAddr::from([10, 0, 0, n])
    }

    #[test]
    fn five_failures_within_a_minute_block_the_address_until_the_first_leaves_the_window() {
        let t0 = Instant::now();
        let mut l = LoginLimiter::default();
        for k in 0..5 {
            let at = t0 + Duration::from_secs(k);
            assert!(l.check(ip(5), &format!("user{k}"), at).is_ok());
            l.failed(ip(5), &format!("user{k}"), at);
        }
        let e = l
            .check(ip(5), "other", t0 + Duration::from_secs(10))
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "too many failed logins from 10.0.0.5: 5 within 60 s; try again in 50 s"
        );
        // Another client is not blocked.
        assert!(
            l.check(ip(6), "other", t0 + Duration::from_secs(10))
                .is_ok()
        );
        // The first failure leaves the window at 60 s.
        assert!(
            l.check(ip(5), "other", t0 + Duration::from_secs(60))
                .is_ok()
        );
    }

    #[test]
    fn a_user_guessed_from_many_addresses_is_blocked_too() {
        let t0 = Instant::now();
        let mut l = LoginLimiter::default();
        for k in 0..5 {
            l.failed(ip(k), "ann", t0);
        }
        let e = l.check(ip(99), "ann", t0).unwrap_err();
        assert!(e.to_string().contains("for user \"ann\""), "{e}");
        l.succeeded("ann");
        assert!(l.check(ip(99), "ann", t0).is_ok());
    }

    #[test]
    fn the_map_is_bounded() {
        let t0 = Instant::now();
        let mut l = LoginLimiter::default();
        for k in 0..(MAX_KEYS as u32 + 50) {
            l.failed(
                IpAddr::from(k.to_be_bytes()),
                "x",
                t0 + Duration::from_millis(k.into()),
            );
        }
        assert!(l.tracked() <= MAX_KEYS);
    }
}
