//! What `linterpd move` is waiting for while it follows a move, and until when. Pure: reports and
//! robot states in (the API's JSON), the time as an argument.
//!
//! Without `--timeout` the bound is the daemon's own: the report's `deadline_s` (the move's
//! planned duration, upload and margins, counted from when the report gave it) plus
//! [`MARGIN`], so the daemon's verdict on a move it gives up arrives first; before the report
//! gives one (the move is still queued), [`UNPLANNED`]. Either clock starts again whenever the
//! robot's state shows another move running ahead of this one: as for the daemon's own
//! `start_within`, the time a move ahead runs does not count. `--timeout` is a hard bound from
//! acceptance.

use std::time::{Duration, Instant};

use serde_json::Value;

/// Waited beyond the daemon's deadline for a move before giving up on it.
pub(super) const MARGIN: Duration = Duration::from_secs(2);
/// The bound while a move has no deadline yet (queued), counted from its turn.
pub(super) const UNPLANNED: Duration = Duration::from_secs(30);

/// Until when to wait for a move's end.
#[derive(Debug, Clone, Copy)]
pub(super) struct Deadline {
    /// `--timeout`, from acceptance.
    asked: Option<(Instant, Duration)>,
    /// When the move's own wait began: its acceptance, then the later of the report that gave
    /// its deadline and the last time another move was seen running ahead of it.
    turn: Instant,
    /// The report's `deadline_s`.
    given: Option<Duration>,
}

impl Deadline {
    /// A deadline for a move accepted at `accepted`, with `--timeout` if given.
    pub(super) fn new(accepted: Instant, timeout: Option<Duration>) -> Self {
        Self {
            asked: timeout.map(|t| (accepted, t)),
            turn: accepted,
            given: None,
        }
    }

    /// A report of the move, received at `now`: a new `deadline_s` starts the clock again.
    pub(super) fn report(&mut self, report: &Value, now: Instant) {
        let deadline = report["deadline_s"]
            .as_f64()
            .and_then(|s| Duration::try_from_secs_f64(s).ok());
        if deadline.is_some() && deadline != self.given {
            self.given = deadline;
            self.turn = self.turn.max(now);
        }
    }

    /// The robot's state, read at `now`: another move running ahead of move `id` holds the clock.
    pub(super) fn state(&mut self, state: &Value, id: u64, now: Instant) {
        if state["current_move"].as_u64().is_some_and(|c| c != id) {
            self.turn = self.turn.max(now);
        }
    }

    /// When to give up.
    pub(super) fn at(&self) -> Instant {
        match self.asked {
            Some((accepted, timeout)) => accepted + timeout,
            None => self.turn + self.given.unwrap_or(UNPLANNED) + MARGIN,
        }
    }

    /// The bound in words, for the message when it runs out.
    pub(super) fn describe(&self) -> String {
        match (self.asked, self.given) {
            (Some((_, t)), _) => format!("{} s (--timeout)", secs(t)),
            (None, Some(d)) => format!(
                "{} s (the daemon's deadline for it, {} s, plus {} s)",
                secs(d + MARGIN),
                secs(d),
                secs(MARGIN)
            ),
            (None, None) => format!(
                "{} s (it was given no deadline yet; --timeout sets one)",
                secs(UNPLANNED + MARGIN)
            ),
        }
    }
}

fn secs(d: Duration) -> String {
    format!("{:.1}", d.as_secs_f64())
}

/// Whether the robot's state says its PLC link is down.
pub(super) fn link_down(state: &Value) -> bool {
    state["link"]["connected"].as_bool() == Some(false) || state["phase"] == "link-down"
}

/// What move `report` is waiting for, given its robot's `state` (`Null` if never read).
pub(super) fn waiting_for(report: &Value, state: &Value) -> String {
    let robot = report["robot"].as_str().unwrap_or("the robot");
    if link_down(state) {
        let why = state["link"]["error"]
            .as_str()
            .map(|e| format!("; last error: {e}"))
            .unwrap_or_default();
        return format!(
            "the PLC link of {robot} to come back (the daemon reconnects by itself{why})"
        );
    }
    if state["phase"] == "stalled" {
        return format!(
            "the PLC of {robot} to scan again (its heartbeat stands still: stalled or in PROG mode)"
        );
    }
    let ahead = state["current_move"]
        .as_u64()
        .filter(|c| Some(*c) != report["id"].as_u64());
    match (report["stage"].as_str().unwrap_or("?"), ahead) {
        ("queued" | "waiting", Some(c)) => format!("move {c} ahead of it to end"),
        ("queued", None) => match state["refuses"].as_str() {
            Some(why) => format!("its turn ({why})"),
            None => "its turn".to_owned(),
        },
        ("uploading", _) => "its upload to the PLC to finish".to_owned(),
        ("waiting", None) => "the PLC to start it".to_owned(),
        ("running", _) => format!(
            "the PLC to report its end ({:.0}% of its planned time gone)",
            report["progress"].as_f64().unwrap_or(0.0) * 100.0
        ),
        (stage, _) => format!("its end (it is {stage})"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn the_daemons_deadline_counts_from_the_report_that_gave_it() {
        let t0 = Instant::now();
        let mut d = Deadline::new(t0, None);
        assert_eq!(d.at(), t0 + UNPLANNED + MARGIN);
        let t1 = t0 + Duration::from_secs(1);
        d.report(&json!({"stage": "uploading", "deadline_s": 5.0}), t1);
        assert_eq!(d.at(), t1 + Duration::from_secs(5) + MARGIN);
        // The same deadline again later does not move the clock.
        d.report(&json!({"stage": "running", "deadline_s": 5.0}), t1 + MARGIN);
        assert_eq!(d.at(), t1 + Duration::from_secs(5) + MARGIN);
        assert!(d.describe().contains("the daemon's deadline for it, 5.0 s"));
    }

    #[test]
    fn a_move_running_ahead_holds_the_clock() {
        let t0 = Instant::now();
        let mut d = Deadline::new(t0, None);
        d.report(&json!({"deadline_s": 3.0}), t0);
        let later = t0 + Duration::from_secs(60);
        d.state(&json!({"current_move": 6}), 7, later);
        assert_eq!(d.at(), later + Duration::from_secs(3) + MARGIN);
        // Once it runs itself, the clock runs.
        d.state(&json!({"current_move": 7}), 7, later + MARGIN);
        assert_eq!(d.at(), later + Duration::from_secs(3) + MARGIN);
    }

    #[test]
    fn an_explicit_timeout_is_a_hard_bound_from_acceptance() {
        let t0 = Instant::now();
        let mut d = Deadline::new(t0, Some(Duration::from_millis(500)));
        d.report(&json!({"deadline_s": 30.0}), t0 + MARGIN);
        d.state(&json!({"current_move": 1}), 2, t0 + MARGIN);
        assert_eq!(d.at(), t0 + Duration::from_millis(500));
        assert_eq!(d.describe(), "0.5 s (--timeout)");
    }

    #[test]
    fn waiting_for_names_the_link_first_then_the_stage() {
        let running = json!({"id": 7, "robot": "press-loader", "stage": "running",
            "progress": 0.42});
        let up = json!({"link": {"connected": true}, "phase": "running", "current_move": 7});
        assert_eq!(
            waiting_for(&running, &up),
            "the PLC to report its end (42% of its planned time gone)"
        );
        let down = json!({"link": {"connected": false, "error": "connection refused"},
            "phase": "link-down"});
        assert!(link_down(&down) && !link_down(&up) && !link_down(&Value::Null));
        assert_eq!(
            waiting_for(&running, &down),
            "the PLC link of press-loader to come back (the daemon reconnects by itself; \
             last error: connection refused)"
        );
        let queued = json!({"id": 8, "robot": "press-loader", "stage": "queued"});
        assert_eq!(waiting_for(&queued, &up), "move 7 ahead of it to end");
        let refusing = json!({"link": {"connected": true}, "phase": "unhomed",
            "refuses": "the robot is not homed"});
        assert_eq!(
            waiting_for(&queued, &refusing),
            "its turn (the robot is not homed)"
        );
        assert_eq!(
            waiting_for(&queued, &Value::Null),
            "its turn",
            "a state never read says nothing of the link"
        );
    }
}
