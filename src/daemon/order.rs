//! A move as the cell's software asks for it (API, CLI), and its check into a planner request.
//! A bad order is refused here, naming the field and the limit, before anything is queued.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::config::parse_duration_s;
use crate::geometry::Pose;
use crate::robot::{Method, Motion};

/// A move order: a target pose and optional motion overrides (the robot's defaults otherwise).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct MoveOrder {
    /// Target `[x, y, z]` in mm, or `[x, y, z, a]` with the tool angle in degrees (without it the
    /// tool keeps its angle).
    pub to: Vec<f64>,
    /// Speed along the line, mm/s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mm_s: Option<f64>,
    /// Acceleration time, e.g. `"200ms"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub accel_time: Option<String>,
    /// `"constant-period"` or `"bounded-error"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub method: Option<String>,
    /// Interpolation period, e.g. `"50ms"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period: Option<String>,
    /// Path tolerance of a bounded-error move, mm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance_mm: Option<f64>,
}

/// Why an order is refused: the field, the value and what it must be.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{field} = {value}: {reason}")]
pub struct OrderError {
    /// The offending field.
    pub field: &'static str,
    /// Its value as sent.
    pub value: String,
    /// What it must be.
    pub reason: String,
}

fn refuse(field: &'static str, value: &impl ToString, reason: impl Into<String>) -> OrderError {
    OrderError {
        field,
        value: value.to_string(),
        reason: reason.into(),
    }
}

fn positive(field: &'static str, value: f64) -> Result<f64, OrderError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(refuse(field, &value, "must be a number above 0"))
    }
}

fn duration(field: &'static str, text: &str, allow_zero: bool) -> Result<f64, OrderError> {
    let s =
        parse_duration_s(text).map_err(|e| refuse(field, &format!("{text:?}"), e.to_string()))?;
    if s > 0.0 || (allow_zero && s == 0.0) {
        Ok(s)
    } else {
        Err(refuse(
            field,
            &format!("{text:?}"),
            "must be longer than 0 s",
        ))
    }
}

/// A checked order: the target (its tool angle if given) and the motion to plan with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckedOrder {
    /// Target position; the tool angle is filled in from the start when `a_given` is false.
    pub to: Pose,
    /// Whether the order gave a tool angle.
    pub a_given: bool,
    /// The motion.
    pub motion: Motion,
}

impl MoveOrder {
    /// Checks every field against `defaults`, the robot's motion defaults.
    pub fn check(&self, defaults: Motion) -> Result<CheckedOrder, OrderError> {
        if !(3..=4).contains(&self.to.len()) {
            return Err(refuse(
                "to",
                &format!("{:?}", self.to),
                "must be [x, y, z] or [x, y, z, a] (mm, degrees)",
            ));
        }
        for (v, name) in self
            .to
            .iter()
            .zip(["to[0] (x)", "to[1] (y)", "to[2] (z)", "to[3] (a)"])
        {
            if !v.is_finite() {
                return Err(refuse(name, v, "must be a finite number"));
            }
        }
        let a_deg = self.to.get(3).copied();
        let to = Pose::from_mm_deg(self.to[0], self.to[1], self.to[2], a_deg.unwrap_or(0.0));
        Ok(CheckedOrder {
            to,
            a_given: a_deg.is_some(),
            motion: self.motion(defaults)?,
        })
    }

    fn motion(&self, defaults: Motion) -> Result<Motion, OrderError> {
        let mut m = defaults;
        if let Some(v) = self.speed_mm_s {
            m.speed_mm_s = positive("speed_mm_s", v)?;
        }
        if let Some(t) = &self.accel_time {
            m.accel_s = duration("accel_time", t, true)?;
        }
        if let Some(t) = &self.period {
            m.period_s = duration("period", t, false)?;
        }
        let tolerance = self
            .tolerance_mm
            .map(|t| positive("tolerance_mm", t))
            .transpose()?;
        m.method = match (self.method.as_deref(), tolerance, defaults.method) {
            (Some("constant-period"), None, _) => Method::ConstantPeriod,
            (Some("bounded-error") | None, Some(tolerance_mm), _)
            | (Some("bounded-error"), None, Method::BoundedError { tolerance_mm }) => {
                Method::BoundedError { tolerance_mm }
            }
            (Some("bounded-error"), None, Method::ConstantPeriod) => {
                return Err(refuse(
                    "tolerance_mm",
                    &"null",
                    "method bounded-error needs a tolerance above 0 mm",
                ));
            }
            (Some("constant-period"), Some(t), _) => {
                return Err(refuse(
                    "tolerance_mm",
                    &t,
                    "only method bounded-error takes a tolerance",
                ));
            }
            (Some(other), _, _) => {
                return Err(refuse(
                    "method",
                    &format!("{other:?}"),
                    "must be \"constant-period\" or \"bounded-error\"",
                ));
            }
            (None, None, method) => method,
        };
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::seed_robot;

    fn order(to: Vec<f64>) -> MoveOrder {
        MoveOrder {
            to,
            ..MoveOrder::default()
        }
    }

    #[test]
    fn target_without_angle_keeps_the_default_motion() {
        let c = order(vec![1.0, 2.0, 3.0])
            .check(seed_robot().motion)
            .unwrap();
        assert!(!c.a_given);
        assert_eq!(c.motion, seed_robot().motion);
    }

    #[test]
    fn bad_fields_are_named_with_value_and_limit() {
        let m = seed_robot().motion;
        assert_eq!(order(vec![1.0, 2.0]).check(m).unwrap_err().field, "to");
        assert_eq!(
            order(vec![1.0, f64::NAN, 3.0])
                .check(m)
                .unwrap_err()
                .to_string(),
            "to[1] (y) = NaN: must be a finite number"
        );
        let slow = MoveOrder {
            speed_mm_s: Some(0.0),
            ..order(vec![1.0, 2.0, 3.0])
        };
        assert_eq!(
            slow.check(m).unwrap_err().to_string(),
            "speed_mm_s = 0: must be a number above 0"
        );
        let bad = MoveOrder {
            period: Some("0ms".into()),
            ..order(vec![1.0, 2.0, 3.0])
        };
        assert_eq!(bad.check(m).unwrap_err().field, "period");
        let weird = MoveOrder {
            method: Some("spline".into()),
            ..order(vec![1.0, 2.0, 3.0])
        };
        assert!(
            weird
                .check(m)
                .unwrap_err()
                .reason
                .contains("constant-period")
        );
    }

    #[test]
    fn tolerance_makes_a_bounded_error_move() {
        let o = MoveOrder {
            tolerance_mm: Some(0.05),
            ..order(vec![1.0, 2.0, 3.0, 10.0])
        };
        let c = o.check(seed_robot().motion).unwrap();
        assert_eq!(c.motion.method, Method::BoundedError { tolerance_mm: 0.05 });
        assert!(c.a_given);
    }
}
