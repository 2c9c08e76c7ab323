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

use crate::daemon::{MoveReport, RobotPhase, RobotState, Stage};

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
    pub(super) fn report(&mut self, report: &MoveReport, now: Instant) {
        let deadline = report
            .deadline_s
            .and_then(|s| Duration::try_from_secs_f64(s).ok());
        if deadline.is_some() && deadline != self.given {
            self.given = deadline;
            self.turn = self.turn.max(now);
        }
    }

    /// The robot's state, read at `now`: another move running ahead of move `id` holds the clock.
    pub(super) fn state(&mut self, state: &RobotState, id: u64, now: Instant) {
        if state.current_move.is_some_and(|c| c != id) {
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

/// Whether the robot's state (`None` if never read) says its PLC link is down.
pub(super) fn link_down(state: Option<&RobotState>) -> bool {
    state.is_some_and(|s| !s.link.connected || s.phase == RobotPhase::LinkDown)
}

/// What move `report` (`None` before its first) is waiting for, given its robot's `state`
/// (`None` if never read).
pub(super) fn waiting_for(report: Option<&MoveReport>, state: Option<&RobotState>) -> String {
    let robot = report.map_or("the robot", |r| r.robot.as_str());
    if link_down(state) {
        let why = state
            .and_then(|s| s.link.error.as_ref())
            .map(|e| format!("; last error: {e}"))
            .unwrap_or_default();
        return format!(
            "the PLC link of {robot} to come back (the daemon reconnects by itself{why})"
        );
    }
    if state.is_some_and(|s| s.phase == RobotPhase::Stalled) {
        return format!(
            "the PLC of {robot} to scan again (its heartbeat stands still: stalled or in PROG mode)"
        );
    }
    let Some(report) = report else {
        return "its end (it is ?)".to_owned();
    };
    let ahead = state
        .and_then(|s| s.current_move)
        .filter(|c| *c != report.id);
    match (report.stage, ahead) {
        (Stage::Queued | Stage::Waiting, Some(c)) => format!("move {c} ahead of it to end"),
        (Stage::Queued, None) => match state.and_then(|s| s.refuses.as_ref()) {
            Some(why) => format!("its turn ({why})"),
            None => "its turn".to_owned(),
        },
        (Stage::Uploading, _) => "its upload to the PLC to finish".to_owned(),
        (Stage::Prepared, _) => "its cycle to reach its step (it is uploaded, held)".to_owned(),
        (Stage::Waiting, None) => "the PLC to start it".to_owned(),
        (Stage::Running, _) => format!(
            "the PLC to report its end ({:.0}% of its planned time gone)",
            report.progress * 100.0
        ),
        (stage, _) => format!("its end (it is {})", stage.name()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::client::Received;
    use serde_json::{Value, json};

    /// `base` with `fields` set over it.
    fn with(mut base: Value, fields: Value) -> Value {
        if let Value::Object(fields) = fields {
            for (key, value) in fields {
                base[key] = value;
            }
        }
        base
    }

    /// A queued report of move 7 of press-loader, with `fields`.
    fn report(fields: Value) -> MoveReport {
        let base = json!({"id": 7, "robot": "press-loader", "stage": "queued"});
        Received::read(with(base, fields), "a report")
            .unwrap()
            .value
    }

    /// press-loader's state, with `fields`.
    fn state(fields: Value) -> RobotState {
        let base = json!({"name": "press-loader"});
        Received::read(with(base, fields), "a state").unwrap().value
    }

    #[test]
    fn the_daemons_deadline_counts_from_the_report_that_gave_it() {
        let t0 = Instant::now();
        let mut d = Deadline::new(t0, None);
        assert_eq!(d.at(), t0 + UNPLANNED + MARGIN);
        let t1 = t0 + Duration::from_secs(1);
        d.report(
            &report(json!({"stage": "uploading", "deadline_s": 5.0})),
            t1,
        );
        assert_eq!(d.at(), t1 + Duration::from_secs(5) + MARGIN);
        // The same deadline again later does not move the clock.
        d.report(
            &report(json!({"stage": "running", "deadline_s": 5.0})),
            t1 + MARGIN,
        );
        assert_eq!(d.at(), t1 + Duration::from_secs(5) + MARGIN);
        assert!(d.describe().contains("the daemon's deadline for it, 5.0 s"));
    }

    #[test]
    fn a_move_running_ahead_holds_the_clock() {
        let t0 = Instant::now();
        let mut d = Deadline::new(t0, None);
        d.report(&report(json!({"deadline_s": 3.0})), t0);
        let later = t0 + Duration::from_secs(60);
        d.state(&state(json!({"current_move": 6})), 7, later);
        assert_eq!(d.at(), later + Duration::from_secs(3) + MARGIN);
        // Once it runs itself, the clock runs.
        d.state(&state(json!({"current_move": 7})), 7, later + MARGIN);
        assert_eq!(d.at(), later + Duration::from_secs(3) + MARGIN);
    }

    #[test]
    fn an_explicit_timeout_is_a_hard_bound_from_acceptance() {
        let t0 = Instant::now();
        let mut d = Deadline::new(t0, Some(Duration::from_millis(500)));
        d.report(&report(json!({"deadline_s": 30.0})), t0 + MARGIN);
        d.state(&state(json!({"current_move": 1})), 2, t0 + MARGIN);
        assert_eq!(d.at(), t0 + Duration::from_millis(500));
        assert_eq!(d.describe(), "0.5 s (--timeout)");
    }

    #[test]
    fn waiting_for_names_the_link_first_then_the_stage() {
        let running = report(json!({"stage": "running", "progress": 0.42}));
        let up = state(json!({"link": {"connected": true}, "phase": "running",
            "current_move": 7}));
        assert_eq!(
            waiting_for(Some(&running), Some(&up)),
            "the PLC to report its end (42% of its planned time gone)"
        );
        let down = state(
            json!({"link": {"connected": false, "error": "connection refused"},
            "phase": "link-down"}),
        );
        assert!(link_down(Some(&down)) && !link_down(Some(&up)) && !link_down(None));
        assert_eq!(
            waiting_for(Some(&running), Some(&down)),
            "the PLC link of press-loader to come back (the daemon reconnects by itself; \
             last error: connection refused)"
        );
        let queued = report(json!({"id": 8}));
        assert_eq!(
            waiting_for(Some(&queued), Some(&up)),
            "move 7 ahead of it to end"
        );
        let refusing = state(json!({"link": {"connected": true}, "phase": "unhomed",
            "refuses": "the robot is not homed"}));
        assert_eq!(
            waiting_for(Some(&queued), Some(&refusing)),
            "its turn (the robot is not homed)"
        );
        assert_eq!(
            waiting_for(Some(&queued), None),
            "its turn",
            "a state never read says nothing of the link"
        );
        let stalled = state(json!({"link": {"connected": true}, "phase": "stalled"}));
        assert_eq!(
            waiting_for(None, Some(&stalled)),
            "the PLC of the robot to scan again (its heartbeat stands still: stalled or in \
             PROG mode)"
        );
        assert_eq!(waiting_for(None, Some(&up)), "its end (it is ?)");
    }
}
