//! The F174 control code: output method and direction, absolute targets, range, duty.
//!
//! Source: Panasonic FP-X user's manual, F174 (SP0H), control code (`docs/PLC.md` §3):
//! ```text
//! digit 3   digit 2   digit 1    digit 0
//! duty      range     0=inc      output method + counting direction
//! 0=1/2     0,1,2     1=abs      up: 0 CW, 2 pulse+sign (fwd = sign OFF), 4 pulse+sign (fwd = sign ON)
//! 1=1/4                          down: 1 CCW, 3 pulse+sign (sign OFF), 5 pulse+sign (sign ON)
//! ```

use serde::{Deserialize, Serialize};

use super::FrequencyRange;

/// How a channel is wired to its drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OutputMethod {
    /// Separate CW and CCW pulse lines.
    CwCcw,
    /// Pulse + sign, forward while the sign output is OFF.
    PulseSign,
    /// Pulse + sign, forward while the sign output is ON.
    PulseSignInverted,
}

impl OutputMethod {
    /// The name used in config and reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::CwCcw => "cw-ccw",
            Self::PulseSign => "pulse-sign",
            Self::PulseSignInverted => "pulse-sign-inverted",
        }
    }
}

/// The direction the count moves in a segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Counting up.
    Up,
    /// Counting down.
    Down,
}

impl Direction {
    /// +1 or -1.
    #[must_use]
    pub fn sign(self) -> i64 {
        match self {
            Self::Up => 1,
            Self::Down => -1,
        }
    }

    /// The direction of a nonzero count change.
    #[must_use]
    pub fn of(delta: i64) -> Option<Self> {
        match delta.signum() {
            1 => Some(Self::Up),
            -1 => Some(Self::Down),
            _ => None,
        }
    }
}

/// Pulse duty (control code digit 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Duty {
    /// 1/2, the default.
    Half,
    /// 1/4, required at high frequencies (see [`quarter_duty_from_hz`]).
    Quarter,
}

/// The frequency from which a channel of an FP-X C14T/C30T/C60T needs duty 1/4: 50 kHz on
/// channels 0-1, 10 kHz on channels 2-3 (PLC.md §3, control code digit 3).
#[must_use]
pub fn quarter_duty_from_hz(channel: u8) -> u32 {
    if channel >= 2 { 10_000 } else { 50_000 }
}

/// A decoded F174 control code. linterpd always writes absolute targets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ControlCode {
    /// Output wiring.
    pub output: OutputMethod,
    /// Counting direction of the whole table.
    pub direction: Direction,
    /// Absolute (true) or incremental targets.
    pub absolute: bool,
    /// Frequency range of the whole table.
    pub range: FrequencyRange,
    /// Pulse duty.
    pub duty: Duty,
}

impl ControlCode {
    /// The 32-bit value written at the start of the table.
    #[must_use]
    pub fn value(self) -> u32 {
        let up = self.direction == Direction::Up;
        let d0 = match (self.output, up) {
            (OutputMethod::CwCcw, true) => 0,
            (OutputMethod::CwCcw, false) => 1,
            (OutputMethod::PulseSign, true) => 2,
            (OutputMethod::PulseSign, false) => 3,
            (OutputMethod::PulseSignInverted, true) => 4,
            (OutputMethod::PulseSignInverted, false) => 5,
        };
        let d1 = u32::from(self.absolute);
        let d3 = u32::from(self.duty == Duty::Quarter);
        d0 | (d1 << 4) | (self.range.digit() << 8) | (d3 << 12)
    }

    /// Decodes a control code; `None` for a digit outside the documented values.
    #[must_use]
    pub fn from_value(value: u32) -> Option<Self> {
        if value >> 16 != 0 {
            return None;
        }
        let (output, direction) = match value & 0xF {
            0 => (OutputMethod::CwCcw, Direction::Up),
            1 => (OutputMethod::CwCcw, Direction::Down),
            2 => (OutputMethod::PulseSign, Direction::Up),
            3 => (OutputMethod::PulseSign, Direction::Down),
            4 => (OutputMethod::PulseSignInverted, Direction::Up),
            5 => (OutputMethod::PulseSignInverted, Direction::Down),
            _ => return None,
        };
        let absolute = match (value >> 4) & 0xF {
            0 => false,
            1 => true,
            _ => return None,
        };
        let range = FrequencyRange::from_digit((value >> 8) & 0xF)?;
        let duty = match (value >> 12) & 0xF {
            0 => Duty::Half,
            1 => Duty::Quarter,
            _ => return None,
        };
        Some(Self {
            output,
            direction,
            absolute,
            range,
            duty,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plc_md_example_code_is_cw_incremental_range_one() {
        let code = ControlCode::from_value(0x0000_0100).unwrap();
        assert_eq!(code.output, OutputMethod::CwCcw);
        assert_eq!(code.direction, Direction::Up);
        assert!(!code.absolute);
        assert_eq!(code.range, FrequencyRange::Mid);
        assert_eq!(code.duty, Duty::Half);
    }

    #[test]
    fn every_code_round_trips() {
        for output in [
            OutputMethod::CwCcw,
            OutputMethod::PulseSign,
            OutputMethod::PulseSignInverted,
        ] {
            for direction in [Direction::Up, Direction::Down] {
                for range in FrequencyRange::FINEST_FIRST {
                    for duty in [Duty::Half, Duty::Quarter] {
                        let code = ControlCode {
                            output,
                            direction,
                            absolute: true,
                            range,
                            duty,
                        };
                        assert_eq!(ControlCode::from_value(code.value()), Some(code));
                    }
                }
            }
        }
    }

    #[test]
    fn pulse_sign_down_absolute_range_two_quarter_duty() {
        let code = ControlCode {
            output: OutputMethod::PulseSign,
            direction: Direction::Down,
            absolute: true,
            range: FrequencyRange::High,
            duty: Duty::Quarter,
        };
        assert_eq!(code.value(), 0x1213);
    }

    #[test]
    fn undocumented_digits_are_refused() {
        assert_eq!(ControlCode::from_value(0x0006), None);
        assert_eq!(ControlCode::from_value(0x0300), None);
        assert_eq!(ControlCode::from_value(0x1_0000), None);
    }
}
