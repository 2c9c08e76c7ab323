//! `[robots.NAME.motion]` -> [`Motion`]: the robot's motion defaults, durations parsed.

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::duration::parse_duration_s;
use super::raw::RawMotion;
use crate::robot::{Method, Motion, OverSpeed};

/// The motion defaults a motion table describes.
pub(super) fn motion(at: &At, raw: &RawMotion) -> Result<Motion, ConfigError> {
    let period_s = duration_s(&at.child("period"), &raw.period)?;
    if period_s <= 0.0 {
        return Err(at
            .child("period")
            .invalid(&raw.period, "must be longer than 0 s"));
    }
    Ok(Motion {
        method: raw.method.map_or(Method::default(), Method::from),
        period_s,
        speed_mm_s: at.child("speed_mm_s").positive(&raw.speed_mm_s)?,
        accel_s: duration_s(&at.child("accel_time"), &raw.accel_time)?,
        frequency_model: raw.frequency_model.unwrap_or_default(),
        over_speed: raw.over_speed.map_or(OverSpeed::default(), OverSpeed::from),
    })
}

fn duration_s(at: &At, text: &Spanned<String>) -> Result<f64, ConfigError> {
    parse_duration_s(text.get_ref()).map_err(|e| at.invalid(text, e.problem))
}
