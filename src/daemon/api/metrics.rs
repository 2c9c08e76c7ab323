//! `GET /metrics`: the daemon's [`Metrics`] in the `OpenMetrics` text format (Prometheus reads it),
//! after setting the gauges that restate each robot's state (link up, fault code, heartbeat age).
//! The counters and histograms are lifetime state, fed as things happen
//! ([`crate::daemon::metrics`]); docs/API.md lists every metric.
//!
//! ```text
//! # TYPE linterpd_moves counter
//! linterpd_moves_total{robot="press-loader",outcome="done"} 3
//! # TYPE linterpd_upload_seconds histogram
//! linterpd_upload_seconds_sum{robot="press-loader"} 0.84
//! linterpd_upload_seconds_count{robot="press-loader"} 3
//! ...
//! # EOF
//! ```

use crate::daemon::RobotState;
use crate::daemon::metrics::Metrics;

/// The content type of the `OpenMetrics` text format.
pub const CONTENT_TYPE: &str = "application/openmetrics-text; version=1.0.0; charset=utf-8";

/// The whole exposition: `metrics` with each of `robots`' state gauges set.
#[must_use]
pub fn render(metrics: &Metrics, robots: &[RobotState]) -> String {
    for state in robots {
        metrics.set_state(
            &state.name,
            state.link.connected,
            state.fault.unwrap_or(0),
            state.heartbeat_age_ms.map(|ms| ms as f64 / 1000.0),
        );
    }
    metrics.encode()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_gauges_come_from_each_robot_state() {
        let metrics = Metrics::new();
        let _a = metrics.robot("a");
        let mut state = RobotState {
            name: "a".into(),
            heartbeat_age_ms: Some(20),
            fault: Some(3),
            ..RobotState::default()
        };
        state.link.connected = true;
        let text = render(&metrics, &[state]);
        for line in [
            "linterpd_link_up{robot=\"a\"} 1",
            "linterpd_plc_fault{robot=\"a\"} 3",
            "linterpd_heartbeat_age_seconds{robot=\"a\"} 0.02",
            "linterpd_moves_total{robot=\"a\",outcome=\"done\"} 0",
        ] {
            assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
        }
    }
}
