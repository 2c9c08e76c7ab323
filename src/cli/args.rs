//! Parsers for values people type: poses and durations. Raw text in, typed values or an error
//! naming the text out.

use anyhow::{Context, anyhow, bail};

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
}
