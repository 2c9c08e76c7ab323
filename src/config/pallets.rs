//! `[robots.NAME.frames.NAME]` and `[robots.NAME.pallets.NAME]` -> [`RobotPallets`]
//! (`crate::pallet` checks every value), each error placed on its line with its key path; every
//! pallet whose frame needs no taught position is laid out and checked against the robot's reach
//! and joint limits here, so a slot out of reach fails the config. A pallet on taught points is
//! laid out when the positions are known (`Config::patterns`). Also `[robots.NAME.tool]`.

use std::collections::BTreeMap;
use std::ops::Range;

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::locate::line_of;
use super::raw::{RawRobot, RawTool};
use crate::pallet::{PalletError, RobotPallets};
use crate::robot::Robot;

/// The robot's frames and pallets, checked; `None` when it has neither table.
pub(super) fn pallets(
    text: &str,
    robot: &Robot,
    raw: &RawRobot,
) -> Result<Option<RobotPallets>, ConfigError> {
    if raw.frames.is_none() && raw.pallets.is_none() {
        return Ok(None);
    }
    let at = At::new(text, "robots").child(&robot.name);
    let mut set = RobotPallets::default();
    for (name, doc) in raw.frames.iter().flatten() {
        let place = Place {
            text,
            at: at.child("frames").child(name),
            span: doc.span(),
        };
        set.add_frame(name, doc.get_ref())
            .map_err(|e| place.error(e))?;
    }
    let none = BTreeMap::new();
    for (name, doc) in raw.pallets.iter().flatten() {
        let place = Place {
            text,
            at: at.child("pallets").child(name),
            span: doc.span(),
        };
        set.add_pallet(name, doc.get_ref())
            .map_err(|e| place.error(e))?;
        if !set.needs_taught(name) {
            set.pattern(name, robot, &none)
                .map_err(|e| place.error(e))?;
        }
    }
    Ok(Some(set))
}

/// A pallet's or frame's table in the text.
struct Place<'t> {
    text: &'t str,
    at: At<'t>,
    span: Range<usize>,
}

impl Place<'_> {
    /// `error` on the line of its key (else of the table), with the key's full path.
    fn error(&self, error: PalletError) -> ConfigError {
        let Some(key) = error.key().map(str::to_owned) else {
            return ConfigError::Pallet {
                line: self.line(None),
                key: self.at.key().to_owned(),
                error: Box::new(error),
            };
        };
        let line = self.line(Some(&key));
        let path = self.at.child(&key).key().to_owned();
        match error {
            PalletError::Value { value, reason, .. } => ConfigError::Invalid {
                line,
                key: path,
                value,
                reason,
            },
            PalletError::Missing { reason, .. } => ConfigError::Missing {
                line,
                key: path,
                reason,
            },
            other => ConfigError::Pallet {
                line,
                key: path,
                error: Box::new(other),
            },
        }
    }

    /// The line of `key`'s last part (`rows`, `turn_deg` of `kinds.B.turn_deg`) at or after the
    /// table's start, else of the table.
    fn line(&self, key: Option<&str>) -> usize {
        let start = self.span.start.min(self.text.len());
        let found = key.and_then(|key| {
            let last = key.rsplit('.').next()?.split('[').next()?;
            let rest = &self.text[start..];
            let mut from = 0;
            while let Some(i) = rest[from..].find(last) {
                let at = from + i;
                let before = rest[..at].chars().next_back();
                let after = rest[at + last.len()..].trim_start_matches([' ', '\t']);
                if !before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_')
                    && after.starts_with('=')
                {
                    return Some(start + at);
                }
                from = at + last.len();
            }
            None
        });
        line_of(self.text, found.unwrap_or(start))
    }
}

/// `[robots.NAME.tool]`: the tool centre from the flange, mm (every part finite, within
/// [`crate::robot::MAX_TOOL_OFFSET_MM`]).
pub(super) fn tool(at: &At, raw: Option<&Spanned<RawTool>>) -> Result<[f64; 3], ConfigError> {
    let Some(tool) = raw else {
        return Ok([0.0; 3]);
    };
    let max = crate::robot::MAX_TOOL_OFFSET_MM;
    let mut offset = [0.0; 3];
    for (i, v) in tool.get_ref().offset.get_ref().iter().enumerate() {
        let x = at.child("offset").index(i).finite(v)?;
        if x.abs() > max {
            return Err(at
                .child("offset")
                .index(i)
                .invalid(v, format!("must be within -{max}..={max} mm")));
        }
        offset[i] = x;
    }
    Ok(offset)
}

#[cfg(test)]
mod tests {
    use super::super::Config;
    use super::super::fixture::{MINIMAL, message};

    const EXAMPLE: &str = include_str!("../../config/examples/palletiser.toml");

    const PALLET: &str = "[robots.r.pallets.out]\norigin_mm = [700, 0, 100]\nrows = 2\ncolumns = 3\n\
                          pitch_mm = [300, 200]\nlayer_height_mm = 80\nlayers = 2\n";

    /// `MINIMAL` (40 lines) with `extra` after it.
    fn with(extra: &str) -> String {
        format!("{MINIMAL}{extra}")
    }

    #[test]
    fn the_example_describes_96_interlocked_slots_and_the_robot_gets_them() {
        let config = Config::from_toml(EXAMPLE).unwrap();
        let robot = config.robot(None).unwrap();
        assert_eq!(
            robot.kinematics.tool_mm,
            nalgebra::Vector3::new(40.0, 0.0, -60.0)
        );
        let patterns = config
            .patterns(robot, &std::collections::BTreeMap::new())
            .unwrap();
        let out = &patterns["out"];
        assert_eq!((out.len(), out.layers()), (96, 4));
        assert_eq!(out.between_layers.as_deref(), Some("slip-sheet"));
        // Layer 2 (kind B) turned half a turn and moved 90 mm: its first slot sits where layer
        // 1's last of row 1 would, 90 mm further along x, 90 mm up.
        let (a, b) = (out.slot(3).unwrap(), out.slot(24).unwrap());
        let d = b.pose.position_mm - a.pose.position_mm;
        assert!(
            (d.x - 90.0).abs() < 1e-9 && d.y.abs() > 600.0 && (d.z - 90.0).abs() < 1e-9,
            "{d}"
        );
    }

    #[test]
    fn a_bad_pallet_value_names_its_line_key_value_and_limit() {
        let text = with(&PALLET.replace("rows = 2", "rows = 0"));
        assert_eq!(
            message(&text),
            "config line 43: robots.r.pallets.out.rows = 0: must be within 1..=100"
        );
        let text = with(&format!("{PALLET}kinds.B = {{ turn_deg = 45 }}\n"));
        assert!(
            message(&text).starts_with(
                "config line 48: robots.r.pallets.out.kinds.B.turn_deg = 45: must be a quarter turn"
            ),
            "{}",
            message(&text)
        );
        let text = with(&format!("{PALLET}colour = 1\n"));
        assert!(
            message(&text)
                .starts_with("config line 48: robots.r.pallets.out.colour: unknown field `colour`"),
            "{}",
            message(&text)
        );
        let text = with("[robots.r.frames.f]\norigin = [0, 0, 0]\nx_point = [100, 0, 0]\n");
        assert_eq!(
            message(&text),
            "config line 41: robots.r.frames.f.xy_point is missing: a frame is taught from three points: origin, x_point and xy_point"
        );
    }

    #[test]
    fn a_slot_out_of_reach_fails_the_config_naming_the_slot() {
        let text = with(&PALLET.replace("[700, 0, 100]", "[1000, 0, 100]"));
        let e = message(&text);
        assert!(
            e.starts_with("config line 41: robots.r.pallets.out: pallet \"out\", slot 2 (layer 0, row 0, column 2), the slot: joint d3"),
            "{e}"
        );
        // On taught points it waits for them: the config is fine, the daemon lays it out.
        let text = with(&format!(
            "[robots.r.frames.f]\norigin = \"@p0\"\nx_point = \"@p1\"\nxy_point = \"@p2\"\n{}frame = \"f\"\n",
            PALLET.replace("[700, 0, 100]", "[1000, 0, 100]")
        ));
        let config = Config::from_toml(&text).unwrap();
        let e = config
            .patterns(&config.robots[0], &std::collections::BTreeMap::new())
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "frame \"f\": origin = \"@p0\": no position \"p0\" is taught"
        );
    }

    #[test]
    fn a_tool_offset_out_of_limits_is_refused() {
        let e = message(&with("[robots.r.tool]\noffset = [0, 3000, 0]\n"));
        assert_eq!(
            e,
            "config line 42: robots.r.tool.offset[1] = 3000: must be within -2000..=2000 mm"
        );
    }
}
