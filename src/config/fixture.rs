//! Test fixture: a minimal valid config (one cylindrical robot `r`) whose line numbers tests
//! rely on, and helpers to edit it and read the error it gives.

use super::{Config, ConfigError};

/// A valid config. Line numbers: 1 robot, 2-4 kinematics, 5-8 motion, joints from 9, 17, 25
/// and 33 (name, channel, step, min, max, `max_freq_hz`, output).
pub(super) const MINIMAL: &str = r#"[robots.r]
[robots.r.kinematics]
type = "cylindrical"
l0_mm = 500.0
[robots.r.motion]
period = "50ms"
speed_mm_s = 240.0
accel_time = "200ms"
[[robots.r.joints]]
name = "theta1"
channel = 0
step_deg = 0.0025
min_deg = -170.0
max_deg = 170.0
max_freq_hz = 100000
output = "pulse-sign"
[[robots.r.joints]]
name = "d2"
channel = 1
step_mm = 0.025
min_mm = -50.0
max_mm = 400.0
max_freq_hz = 100000
output = "pulse-sign"
[[robots.r.joints]]
name = "d3"
channel = 2
step_mm = 0.013
min_mm = 0.0
max_mm = 1000.0
max_freq_hz = 20000
output = "pulse-sign"
[[robots.r.joints]]
name = "wrist"
channel = 3
step_deg = 0.0025
min_deg = -360.0
max_deg = 360.0
max_freq_hz = 20000
output = "pulse-sign"
"#;

/// `MINIMAL` with lines replaced: `(line, text)`, 1-based, `text` may hold several lines.
pub(super) fn edited(edits: &[(usize, &str)]) -> String {
    let mut lines: Vec<String> = MINIMAL.lines().map(str::to_owned).collect();
    for &(line, text) in edits {
        text.clone_into(&mut lines[line - 1]);
    }
    lines.join("\n") + "\n"
}

/// The error a text gives.
pub(super) fn error(text: &str) -> ConfigError {
    Config::from_toml(text).expect_err("the config should be refused")
}

/// The message of the error a text gives.
pub(super) fn message(text: &str) -> String {
    error(text).to_string()
}

/// What the message of a refused config must be: all of it, or its start, end or a part.
#[derive(Debug, Clone, Copy)]
pub(super) enum Says {
    Is(&'static str),
    StartsWith(&'static str),
    EndsWith(&'static str),
    Contains(&'static str),
}

/// Checks each row `(line, text, says)`: `MINIMAL` with that line replaced by `text` is refused
/// with a message as `says`. A failing row names its edit and the message it got.
pub(super) fn assert_refusals(rows: &[(usize, &str, Says)]) {
    for &(line, text, says) in rows {
        let got = message(&edited(&[(line, text)]));
        let ok = match says {
            Says::Is(m) => got == m,
            Says::StartsWith(m) => got.starts_with(m),
            Says::EndsWith(m) => got.ends_with(m),
            Says::Contains(m) => got.contains(m),
        };
        assert!(ok, "line {line} as {text:?}: got {got:?}, want {says:?}");
    }
}
