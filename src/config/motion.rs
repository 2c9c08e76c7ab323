//! `[robots.NAME.motion]` -> [`Motion`]: the robot's motion defaults, durations parsed.

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{RawMethod, RawMotion, RawRamp};
use super::units::parse_duration_s;
use crate::robot::{DEFAULT_MAX_SPEED_MM_S, Method, Motion, OverSpeed, Ramp};

/// The motion defaults a motion table describes.
pub(super) fn motion(at: &At, raw: &RawMotion) -> Result<Motion, ConfigError> {
    let period_s = duration_s(&at.child("period"), &raw.period)?;
    if period_s <= 0.0 {
        return Err(at
            .child("period")
            .invalid(&raw.period, "must be longer than 0 s"));
    }
    Ok(Motion {
        method: method(at, raw)?,
        period_s,
        speed_mm_s: at.child("speed_mm_s").positive(&raw.speed_mm_s)?,
        accel_s: duration_s(&at.child("accel_time"), &raw.accel_time)?,
        frequency_model: raw.frequency_model.unwrap_or_default(),
        over_speed: raw.over_speed.map_or(OverSpeed::default(), OverSpeed::from),
        ramp: ramp(at, raw)?,
    })
}

/// The ramps' shape; `s-curve` needs `jerk_mm_s3`, which the trapezoid does not take.
fn ramp(at: &At, raw: &RawMotion) -> Result<Ramp, ConfigError> {
    let jerk = at.child("jerk_mm_s3");
    let profile = raw.profile.as_ref().map(|p| (*p.get_ref(), p.span()));
    match (profile, &raw.jerk_mm_s3) {
        (Some((RawRamp::SCurve, _)), Some(j)) => Ok(Ramp::SCurve {
            jerk_mm_s3: jerk.positive(j)?,
        }),
        (Some((RawRamp::SCurve, span)), None) => Err(jerk.missing(
            &span,
            "profile \"s-curve\" needs the path's jerk, e.g. jerk_mm_s3 = 20000",
        )),
        (_, Some(j)) => Err(jerk.invalid(j, "only profile \"s-curve\" takes a jerk")),
        (_, None) => Ok(Ramp::Trapezoid),
    }
}

/// The fastest an order may ask for (default [`DEFAULT_MAX_SPEED_MM_S`]): above 0 and at least
/// the default speed.
pub(super) fn max_speed(at: &At, raw: &RawMotion, motion: &Motion) -> Result<f64, ConfigError> {
    let Some(max) = &raw.max_speed_mm_s else {
        return Ok(DEFAULT_MAX_SPEED_MM_S.max(motion.speed_mm_s));
    };
    let at = at.child("max_speed_mm_s");
    let value = at.positive(max)?;
    if value < motion.speed_mm_s {
        return Err(at.invalid(
            max,
            format!(
                "must be at least speed_mm_s ({} mm/s), the robot's default speed",
                motion.speed_mm_s
            ),
        ));
    }
    Ok(value)
}

/// The method; `bounded-error` needs `tolerance_mm`, which no other method takes.
fn method(at: &At, raw: &RawMotion) -> Result<Method, ConfigError> {
    let tolerance = at.child("tolerance_mm");
    let method = raw.method.as_ref().map(|m| (*m.get_ref(), m.span()));
    match (method, &raw.tolerance_mm) {
        (Some((RawMethod::BoundedError, _)), Some(t)) => {
            Ok(Method::BoundedError { tolerance_mm: tolerance.positive(t)? })
        }
        (Some((RawMethod::BoundedError, span)), None) => Err(tolerance.missing(
            &span,
            "method \"bounded-error\" needs the largest path deviation allowed, e.g. tolerance_mm = 0.05",
        )),
        (_, Some(t)) => Err(tolerance.invalid(t, "only method \"bounded-error\" takes a tolerance")),
        (_, None) => Ok(Method::ConstantPeriod),
    }
}

fn duration_s(at: &At, text: &Spanned<String>) -> Result<f64, ConfigError> {
    parse_duration_s(text.get_ref()).map_err(|e| at.invalid(text, e.problem))
}

#[cfg(test)]
mod tests {
    use super::super::fixture::Says::{EndsWith, Is, StartsWith};
    use super::super::fixture::{assert_refusals, edited, message};

    #[test]
    fn an_s_curve_takes_its_jerk_and_the_trapezoid_none() {
        let text = edited(&[(
            8,
            "accel_time = \"200ms\"\nprofile = \"s-curve\"\njerk_mm_s3 = 20000.0",
        )]);
        let config = super::super::Config::from_toml(&text).unwrap();
        assert_eq!(
            config.robot(Some("r")).unwrap().motion.ramp,
            crate::robot::Ramp::SCurve {
                jerk_mm_s3: 20_000.0
            }
        );
        let without = edited(&[(8, "accel_time = \"200ms\"\nprofile = \"s-curve\"")]);
        assert_eq!(
            message(&without),
            "config line 9: robots.r.motion.jerk_mm_s3 is missing: profile \"s-curve\" needs the \
             path's jerk, e.g. jerk_mm_s3 = 20000"
        );
        let stray = edited(&[(8, "accel_time = \"200ms\"\njerk_mm_s3 = 20000.0")]);
        assert_eq!(
            message(&stray),
            "config line 9: robots.r.motion.jerk_mm_s3 = 20000: only profile \"s-curve\" takes a \
             jerk"
        );
        let zero = edited(&[(
            8,
            "accel_time = \"200ms\"\nprofile = \"s-curve\"\njerk_mm_s3 = 0.0",
        )]);
        assert!(
            message(&zero).contains("jerk_mm_s3 = 0"),
            "{}",
            message(&zero)
        );
    }

    #[test]
    fn each_bad_motion_key_is_refused_naming_its_line_value_and_limit() {
        assert_refusals(&[
            (
                6,
                "period = \"50\"",
                Is(
                    "config line 6: robots.r.motion.period = \"50\": no unit; write s, ms or us \
                     after the number, as in 50ms",
                ),
            ),
            (
                6,
                "period = \"0ms\"",
                EndsWith("period = \"0ms\": must be longer than 0 s"),
            ),
            (
                8,
                "accel_time = \"-1ms\"",
                EndsWith("accel_time = \"-1ms\": must not be negative"),
            ),
            (
                7,
                "speed_mm_s = 0",
                EndsWith("speed_mm_s = 0: must be above 0"),
            ),
            (
                8,
                "accel_time = \"200ms\"\nmethod = \"bounded-error\"",
                StartsWith("config line 9: robots.r.motion.tolerance_mm is missing"),
            ),
            (
                8,
                "accel_time = \"200ms\"\ntolerance_mm = 0.05",
                EndsWith("only method \"bounded-error\" takes a tolerance"),
            ),
        ]);
    }

    #[test]
    fn zero_accel_time_is_allowed() {
        let text = edited(&[(8, "accel_time = \"0s\"")]);
        let config = super::super::Config::from_toml(&text).unwrap();
        assert!(config.robots[0].motion.accel_s.abs() < f64::EPSILON);
    }

    #[test]
    fn max_speed_below_the_default_speed_is_refused_naming_both() {
        let text = edited(&[(7, "speed_mm_s = 240.0\nmax_speed_mm_s = 100.0")]);
        assert_eq!(
            message(&text),
            "config line 8: robots.r.motion.max_speed_mm_s = 100: must be at least speed_mm_s \
             (240 mm/s), the robot's default speed"
        );
        let text = edited(&[(7, "speed_mm_s = 240.0\nmax_speed_mm_s = 500.0")]);
        let config = super::super::Config::from_toml(&text).unwrap();
        assert!((config.robots[0].max_speed_mm_s - 500.0).abs() < f64::EPSILON);
    }

    #[test]
    fn bounded_error_reads_its_tolerance() {
        let text = edited(&[(
            8,
            "accel_time = \"200ms\"\nmethod = \"bounded-error\"\ntolerance_mm = 0.05",
        )]);
        let m = super::super::Config::from_toml(&text).unwrap().robots[0].motion;
        assert_eq!(
            m.method,
            crate::robot::Method::BoundedError { tolerance_mm: 0.05 }
        );
    }

    #[test]
    fn slow_down_and_ideal_are_read() {
        let text = edited(&[(
            8,
            "accel_time = \"200ms\"\nover_speed = \"slow-down\"\nfrequency_model = \"ideal\"",
        )]);
        let m = super::super::Config::from_toml(&text).unwrap().robots[0].motion;
        assert_eq!(m.over_speed, crate::robot::OverSpeed::SlowDown);
        assert_eq!(m.frequency_model, crate::table::FrequencyModel::Ideal);
    }
}
