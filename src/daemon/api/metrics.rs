//! `GET /metrics`: the Prometheus text exposition format (version 0.0.4), written by hand from
//! each robot's state and kept move reports.
//!
//! ```text
//! # TYPE linterpd_moves_total counter
//! linterpd_moves_total{robot="press-loader",outcome="done"} 3
//! # TYPE linterpd_upload_seconds summary
//! linterpd_upload_seconds_sum{robot="press-loader"} 0.84
//! linterpd_upload_seconds_count{robot="press-loader"} 3
//! ```
//! Move counts and durations cover the reports the daemon keeps (the latest 500 per robot).

use std::fmt::Write as _;

use crate::daemon::{MoveReport, RobotState, Stage};

/// The content type of the text format.
pub const CONTENT_TYPE: &str = "text/plain; version=0.0.4; charset=utf-8";

/// What one robot contributes.
#[derive(Debug, Clone)]
pub struct RobotSample {
    /// Its state.
    pub state: RobotState,
    /// Its kept reports.
    pub reports: Vec<MoveReport>,
}

/// The final stages counted, with their `outcome` label.
const OUTCOMES: [(Stage, &str); 4] = [
    (Stage::Done, "done"),
    (Stage::Stopped, "stopped"),
    (Stage::Failed, "failed"),
    (Stage::Cancelled, "cancelled"),
];

/// The whole exposition.
#[must_use]
pub fn render(robots: &[RobotSample]) -> String {
    let mut out = String::new();
    moves_total(&mut out, robots);
    summary(
        &mut out,
        robots,
        "linterpd_upload_seconds",
        "Time to write and verify a move's bank.",
        |r| r.upload_s,
    );
    summary(
        &mut out,
        robots,
        "linterpd_motion_seconds",
        "Time from a move's start to its end on the PLC.",
        |r| r.motion_s,
    );
    header(
        &mut out,
        "linterpd_link_reconnects_total",
        "counter",
        "PLC link reconnections since the daemon started.",
    );
    for r in robots {
        sample(
            &mut out,
            "linterpd_link_reconnects_total",
            &r.state.name,
            None,
            r.state.link.reconnects as f64,
        );
    }
    header(
        &mut out,
        "linterpd_link_up",
        "gauge",
        "1 while the PLC link is up and the contract answers.",
    );
    for r in robots {
        sample(
            &mut out,
            "linterpd_link_up",
            &r.state.name,
            None,
            f64::from(u8::from(r.state.link.connected)),
        );
    }
    header(
        &mut out,
        "linterpd_heartbeat_age_seconds",
        "gauge",
        "Time since the PLC program's heartbeat last changed.",
    );
    for r in robots {
        if let Some(ms) = r.state.heartbeat_age_ms {
            sample(
                &mut out,
                "linterpd_heartbeat_age_seconds",
                &r.state.name,
                None,
                ms as f64 / 1000.0,
            );
        }
    }
    out
}

fn moves_total(out: &mut String, robots: &[RobotSample]) {
    header(
        out,
        "linterpd_moves_total",
        "counter",
        "Moves that ended, by outcome.",
    );
    for r in robots {
        for (stage, outcome) in OUTCOMES {
            let n = r.reports.iter().filter(|m| m.stage == stage).count();
            sample(
                out,
                "linterpd_moves_total",
                &r.state.name,
                Some(outcome),
                n as f64,
            );
        }
    }
}

fn summary(
    out: &mut String,
    robots: &[RobotSample],
    name: &str,
    help: &str,
    value: impl Fn(&MoveReport) -> Option<f64>,
) {
    header(out, name, "summary", help);
    for r in robots {
        let values: Vec<f64> = r.reports.iter().filter_map(&value).collect();
        let sum: f64 = values.iter().sum();
        sample(out, &format!("{name}_sum"), &r.state.name, None, sum);
        sample(
            out,
            &format!("{name}_count"),
            &r.state.name,
            None,
            values.len() as f64,
        );
    }
}

fn header(out: &mut String, name: &str, kind: &str, help: &str) {
    let _ = writeln!(out, "# HELP {name} {help}");
    let _ = writeln!(out, "# TYPE {name} {kind}");
}

fn sample(out: &mut String, name: &str, robot: &str, outcome: Option<&str>, value: f64) {
    let robot = escape(robot);
    let _ = match outcome {
        Some(outcome) => writeln!(
            out,
            "{name}{{robot=\"{robot}\",outcome=\"{outcome}\"}} {value}"
        ),
        None => writeln!(out, "{name}{{robot=\"{robot}\"}} {value}"),
    };
}

/// A label value as the text format quotes it.
fn escape(value: &str) -> String {
    value
        .replace('\\', r"\\")
        .replace('"', "\\\"")
        .replace('\n', r"\n")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::daemon::MoveOrder;

    fn report(id: u64, stage: Stage, upload_s: Option<f64>) -> MoveReport {
        MoveReport {
            stage,
            upload_s,
            motion_s: upload_s.map(|s| s * 10.0),
            ..MoveReport::new(id, "a", MoveOrder::default())
        }
    }

    fn robot() -> RobotSample {
        let mut state = RobotState {
            name: "a".into(),
            heartbeat_age_ms: Some(20),
            ..RobotState::default()
        };
        state.link.connected = true;
        state.link.reconnects = 2;
        RobotSample {
            state,
            reports: vec![
                report(1, Stage::Done, Some(0.25)),
                report(2, Stage::Done, Some(0.5)),
                report(3, Stage::Stopped, None),
                report(4, Stage::Running, None),
            ],
        }
    }

    #[test]
    fn counts_outcomes_and_sums_durations_per_robot() {
        let text = render(&[robot()]);
        for line in [
            "linterpd_moves_total{robot=\"a\",outcome=\"done\"} 2",
            "linterpd_moves_total{robot=\"a\",outcome=\"stopped\"} 1",
            "linterpd_moves_total{robot=\"a\",outcome=\"failed\"} 0",
            "linterpd_upload_seconds_sum{robot=\"a\"} 0.75",
            "linterpd_upload_seconds_count{robot=\"a\"} 2",
            "linterpd_motion_seconds_sum{robot=\"a\"} 7.5",
            "linterpd_link_reconnects_total{robot=\"a\"} 2",
            "linterpd_link_up{robot=\"a\"} 1",
            "linterpd_heartbeat_age_seconds{robot=\"a\"} 0.02",
            "# TYPE linterpd_upload_seconds summary",
        ] {
            assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
        }
    }

    #[test]
    fn label_values_are_escaped() {
        assert_eq!(escape("a\"b\\c\nd"), "a\\\"b\\\\c\\nd");
    }
}
