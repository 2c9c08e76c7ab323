//! Parsers for values people type: poses, lengths, speeds and durations, one spelling on every
//! subcommand (`--tolerance 0.05mm`, `--speed 240mm/s`, `--period 50ms`, `--timeout 30s`). Raw
//! text in, typed values or an error naming the text and the limit out; the caller adds the
//! flag. Also the `--method` every subcommand shares.

use anyhow::{Context, anyhow, bail};
use clap::ValueEnum;

/// `--method`, on `plan` and `move`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// The seed's constant time period method.
    ConstantPeriod,
    /// Rows of any length, as few as keep the path within `--tolerance`.
    BoundedError,
}

impl MethodArg {
    /// Its name as typed, and as the API takes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::ConstantPeriod => "constant-period",
            Self::BoundedError => "bounded-error",
        }
    }
}

/// A pose as typed: x, y, z in mm and an optional tool angle in degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseArg {
    /// x, y, z, mm.
    pub xyz_mm: [f64; 3],
    /// Tool angle, degrees, if given.
    pub a_deg: Option<f64>,
}

/// Parses `X,Y,Z` or `X,Y,Z,A` (mm, mm, mm, degrees).
pub fn parse_pose(text: &str) -> anyhow::Result<PoseArg> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if !(3..=4).contains(&parts.len()) {
        bail!(
            "'{text}' has {} values; a pose is X,Y,Z or X,Y,Z,A (mm and degrees)",
            parts.len()
        );
    }
    let mut values = [0.0; 4];
    for (i, (part, name)) in parts.iter().zip(["x", "y", "z", "a"]).enumerate() {
        values[i] =
            parse_number(part).with_context(|| format!("pose '{text}', coordinate {name}"))?;
    }
    Ok(PoseArg {
        xyz_mm: [values[0], values[1], values[2]],
        a_deg: (parts.len() == 4).then_some(values[3]),
    })
}

/// Parses `DX,DY,DZ` or `DX,DY,DZ,DA` (mm, mm, mm, degrees): a jog's offset, as typed.
pub fn parse_offset(text: &str) -> anyhow::Result<Vec<f64>> {
    parse_list(
        text,
        3..=4,
        "an offset is DX,DY,DZ or DX,DY,DZ,DA (mm and degrees)",
        &["dx", "dy", "dz", "da"],
    )
}

/// Parses `J1,J2,J3,J4`: every joint's value in the joints' order (degrees or mm).
pub fn parse_joints(text: &str) -> anyhow::Result<[f64; 4]> {
    let values = parse_list(
        text,
        4..=4,
        "joints are J1,J2,J3,J4 in the joints' order (degrees or mm)",
        &["j1", "j2", "j3", "j4"],
    )?;
    Ok([values[0], values[1], values[2], values[3]])
}

/// Comma-separated finite numbers, as many as `count` allows, each named for errors.
fn parse_list(
    text: &str,
    count: std::ops::RangeInclusive<usize>,
    shape: &str,
    names: &[&str],
) -> anyhow::Result<Vec<f64>> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if !count.contains(&parts.len()) {
        bail!("'{text}' has {} values; {shape}", parts.len());
    }
    parts
        .iter()
        .zip(names)
        .map(|(part, name)| parse_number(part).with_context(|| format!("'{text}', value {name}")))
        .collect()
}

/// Parses a finite number.
pub fn parse_number(text: &str) -> anyhow::Result<f64> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| anyhow!("'{text}' is not a number"))?;
    if !value.is_finite() {
        bail!("'{text}' is not a finite number");
    }
    Ok(value)
}

/// A number followed by an optional `unit` (blanks allowed between): the number, finite.
fn number_in(text: &str, unit: &str) -> anyhow::Result<f64> {
    let value =
        crate::config::number_in(text, unit).map_err(|n| anyhow!("'{n}' is not a number"))?;
    if !value.is_finite() {
        let trimmed = text.trim();
        bail!(
            "'{}' is not a finite number",
            trimmed.strip_suffix(unit).unwrap_or(trimmed).trim()
        );
    }
    Ok(value)
}

/// A length in mm, written `0.05mm` or `0.05`; above 0.
pub fn parse_length_mm(text: &str) -> anyhow::Result<f64> {
    let value = number_in(text, "mm")?;
    if value <= 0.0 {
        bail!("'{text}' must be above 0 mm");
    }
    Ok(value)
}

/// A speed in mm/s, written `240mm/s` or `240` (the planner or the daemon checks its limits).
pub fn parse_speed_mm_s(text: &str) -> anyhow::Result<f64> {
    number_in(text, "mm/s")
}

/// `--profile` (`plan`, `move`, `run`): `trapezoid`, or `s-curve:JERK` in mm/s^3.
///
/// # Errors
/// Anything else, naming what is taken.
pub fn parse_ramp(text: &str) -> anyhow::Result<crate::robot::Ramp> {
    use crate::robot::Ramp;
    if text == "trapezoid" {
        return Ok(Ramp::Trapezoid);
    }
    let Some(jerk) = text.strip_prefix("s-curve:") else {
        anyhow::bail!(
            "{text:?}: must be \"trapezoid\" or \"s-curve:JERK\" with the path's jerk in mm/s^3, \
             e.g. s-curve:20000"
        );
    };
    match jerk.trim().parse::<f64>() {
        Ok(j) if j.is_finite() && j > 0.0 => Ok(Ramp::SCurve { jerk_mm_s3: j }),
        _ => anyhow::bail!("{text:?}: the jerk {jerk:?} must be a number of mm/s^3 above 0"),
    }
}

/// A duration, written `50ms`, `0.2s` or `250us` (a unit is required, as in the config).
pub fn parse_duration(text: &str) -> anyhow::Result<std::time::Duration> {
    let seconds = crate::config::parse_duration_s(text)?;
    std::time::Duration::try_from_secs_f64(seconds)
        .map_err(|_| anyhow!("'{text}' is too long a duration"))
}

#[cfg(test)]
#[allow(clippy::float_cmp)] // parsed values are exact
mod tests {
    use super::*;

    #[test]
    fn pose_with_and_without_angle() {
        let p = parse_pose("-926.57,535.03,50").unwrap();
        assert_eq!(p.xyz_mm, [-926.57, 535.03, 50.0]);
        assert_eq!(p.a_deg, None);
        assert_eq!(parse_pose("1, 2, 3, 45").unwrap().a_deg, Some(45.0));
    }

    #[test]
    fn offsets_and_joints_take_their_count_of_numbers() {
        assert_eq!(parse_offset("0,5,-2").unwrap(), [0.0, 5.0, -2.0]);
        assert_eq!(parse_offset("1,2,3,90").unwrap(), [1.0, 2.0, 3.0, 90.0]);
        let e = format!("{:#}", parse_offset("1,2").unwrap_err());
        assert!(
            e.contains("'1,2' has 2 values; an offset is DX,DY,DZ"),
            "{e}"
        );
        assert_eq!(
            parse_joints("10, 20, 30, -5").unwrap(),
            [10.0, 20.0, 30.0, -5.0]
        );
        let e = format!("{:#}", parse_joints("10,20,x,0").unwrap_err());
        assert!(
            e.contains("value j3") && e.contains("'x' is not a number"),
            "{e}"
        );
        assert!(parse_joints("1,2,3").is_err());
    }

    #[test]
    fn garbage_pose_is_refused_naming_the_text() {
        let err = format!("{:#}", parse_pose("1,2,abc").unwrap_err());
        assert!(
            err.contains("coordinate z") && err.contains("'abc' is not a number"),
            "{err}"
        );
        assert!(parse_pose("1,2").is_err());
        assert!(parse_pose("1,2,3,4,5").is_err());
        assert!(
            format!("{:#}", parse_pose("1,NaN,3").unwrap_err()).contains("not a finite number")
        );
    }

    #[test]
    fn lengths_and_speeds_take_their_unit_or_none() {
        assert_eq!(parse_length_mm("0.05mm").unwrap(), 0.05);
        assert_eq!(parse_length_mm(" 0.05 mm").unwrap(), 0.05);
        assert_eq!(parse_length_mm("0.05").unwrap(), 0.05);
        let e = format!("{:#}", parse_length_mm("0mm").unwrap_err());
        assert!(e.contains("'0mm' must be above 0 mm"), "{e}");
        assert!(format!("{:#}", parse_length_mm("5in").unwrap_err()).contains("'5in'"));
        assert_eq!(parse_speed_mm_s("240mm/s").unwrap(), 240.0);
        assert_eq!(parse_speed_mm_s("240").unwrap(), 240.0);
        assert!(parse_speed_mm_s("fast").is_err());
    }

    #[test]
    fn durations_need_a_unit() {
        assert_eq!(
            parse_duration("250ms").unwrap(),
            std::time::Duration::from_millis(250)
        );
        let e = format!("{:#}", parse_duration("3").unwrap_err());
        assert!(e.contains("no unit"), "{e}");
    }

    #[test]
    fn method_names_are_the_ones_clap_takes() {
        for m in MethodArg::value_variants() {
            assert_eq!(m.to_possible_value().unwrap().get_name(), m.name());
        }
    }
}
