//! Path files: a path through waypoints as TOML (or the same document as JSON, for the API),
//! read into a [`PathDoc`] and resolved into the planner's elements.
//!
//! ```toml
//! linterpd_path = 1
//! start = [-926.57, 535.03, 50.0]   # optional: x, y, z[, a] or "@name"; else where the robot is
//! path_accel = "5000mm/s2"          # optional: the largest acceleration across the path
//!
//! [[element]]
//! line = [-1144.43, 659.60, 286.60]  # x, y, z[, a] in mm and degrees, or "@name"
//! blend = "20mm"                     # round the corner here (or `stop = true`, the default)
//!
//! [[element]]
//! arc = [-1144.43, 759.60, 286.60]  # an arc to here ...
//! via = [-1094.43, 709.60, 286.60]  # ... through this point, or
//! # centre = [x, y, z], direction = "cw" | "ccw", axis = [0, 0, 1] (default: z)
//! ```
//!
//! A waypoint without an angle keeps the tool angle of the one before it. Every key is checked:
//! an unknown key, a missing or doubled one, or a value out of its range is an error naming
//! the element and the key.

use nalgebra::Vector3;
use serde::Deserialize;
use thiserror::Error;

use crate::geometry::{ArcBy, Corner, Element, Pose};

/// The path file format's version.
pub const PATH_FORMAT: u32 = 1;

/// A number, or a number with its unit written after it (`"20mm"`).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(untagged)]
enum Quantity {
    Number(f64),
    Text(String),
}

/// A quantity's text that is not a number of its unit.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("'{text}' is not a number of {unit}")]
struct NotANumberOf {
    text: String,
    unit: &'static str,
}

impl Quantity {
    fn value(&self, unit: &'static str) -> Result<f64, NotANumberOf> {
        match self {
            Self::Number(v) => Ok(*v),
            Self::Text(text) => super::units::number_in(text, unit).map_err(|_| NotANumberOf {
                text: text.clone(),
                unit,
            }),
        }
    }
}

/// A waypoint as written: coordinates or a taught position's name.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(untagged)]
enum RawPose {
    Coordinates(Vec<f64>),
    Name(String),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawElement {
    line: Option<RawPose>,
    arc: Option<RawPose>,
    via: Option<Vec<f64>>,
    centre: Option<Vec<f64>>,
    direction: Option<String>,
    axis: Option<Vec<f64>>,
    blend: Option<Quantity>,
    stop: Option<bool>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPath {
    linterpd_path: Option<u32>,
    start: Option<RawPose>,
    path_accel: Option<Quantity>,
    #[serde(default)]
    element: Vec<RawElement>,
}

/// A waypoint: coordinates (mm, and degrees if the angle is given) or a taught position.
#[derive(Debug, Clone, PartialEq)]
pub enum Waypoint {
    /// x, y, z in mm, and the tool angle in degrees if given.
    At {
        /// x, y, z, mm.
        xyz_mm: [f64; 3],
        /// Tool angle, degrees.
        a_deg: Option<f64>,
    },
    /// A taught position (`@name` in the file, the name without the `@` here).
    Named(String),
}

/// How an arc element is given, as written.
#[derive(Debug, Clone, PartialEq)]
pub enum ArcDoc {
    /// Through a point, mm.
    Via([f64; 3]),
    /// About a centre.
    Centre {
        /// The centre, mm.
        centre_mm: [f64; 3],
        /// The plane's normal.
        axis: [f64; 3],
        /// Clockwise seen from the axis' tip.
        clockwise: bool,
    },
}

/// One element as written.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementDoc {
    /// Where it ends.
    pub to: Waypoint,
    /// `None` for a line, else how the arc is given.
    pub arc: Option<ArcDoc>,
    /// The corner at its end.
    pub corner: Corner,
}

/// A path file, read and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct PathDoc {
    /// Where it starts (`None`: where the robot is).
    pub start: Option<Waypoint>,
    /// The largest acceleration across the path, mm/s^2 (`None`: the robot's default).
    pub path_accel_mm_s2: Option<f64>,
    /// The elements, in order.
    pub elements: Vec<ElementDoc>,
}

/// What is wrong with a path document.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PathFileError {
    /// Not TOML (or JSON), or keys that do not belong.
    #[error("{0}")]
    Syntax(String),
    /// A value out of its range or a missing or doubled key.
    #[error("{at}: {problem}")]
    Invalid {
        /// Where: `element 2: blend` or `path_accel`.
        at: String,
        /// What is wrong.
        problem: String,
    },
    /// A taught position that is not known.
    #[error("{at}: no taught position named '{name}'")]
    UnknownPosition {
        /// Where.
        at: String,
        /// The name.
        name: String,
    },
}

impl PathDoc {
    /// Reads a path file's TOML.
    ///
    /// # Errors
    /// [`PathFileError`] naming what is wrong and where.
    pub fn from_toml(text: &str) -> Result<Self, PathFileError> {
        let raw: RawPath =
            toml::from_str(text).map_err(|e| PathFileError::Syntax(e.message().to_owned()))?;
        Self::check(&raw)
    }

    /// Reads the same document as JSON.
    ///
    /// # Errors
    /// [`PathFileError`] naming what is wrong and where.
    pub fn from_json(value: serde_json::Value) -> Result<Self, PathFileError> {
        let raw: RawPath =
            serde_json::from_value(value).map_err(|e| PathFileError::Syntax(e.to_string()))?;
        Self::check(&raw)
    }

    fn check(raw: &RawPath) -> Result<Self, PathFileError> {
        if let Some(v) = raw.linterpd_path
            && v != PATH_FORMAT
        {
            return Err(invalid(
                "linterpd_path",
                format!("version {v} is not known; this linterpd reads version {PATH_FORMAT}"),
            ));
        }
        let start = raw
            .start
            .as_ref()
            .map(|p| waypoint("start", p))
            .transpose()?;
        let path_accel_mm_s2 = raw.path_accel.as_ref().map(path_accel).transpose()?;
        if raw.element.is_empty() {
            return Err(invalid(
                "element",
                "a path needs at least one [[element]]".into(),
            ));
        }
        let elements = raw
            .element
            .iter()
            .enumerate()
            .map(|(i, e)| element(i + 1, e))
            .collect::<Result<Vec<_>, _>>()?;
        last_ends_at_a_stop(&elements)?;
        Ok(Self {
            start,
            path_accel_mm_s2,
            elements,
        })
    }

    /// The planner's elements: taught positions looked up with `lookup`, and each waypoint
    /// without an angle keeping the one before it (from `start`).
    ///
    /// # Errors
    /// [`PathFileError::UnknownPosition`] for a name `lookup` does not know.
    pub fn resolve(
        &self,
        start: Pose,
        lookup: &dyn Fn(&str) -> Option<Pose>,
    ) -> Result<Vec<(Element, Corner)>, PathFileError> {
        let mut a_rad = start.a_rad;
        let mut out = Vec::with_capacity(self.elements.len());
        for (i, e) in self.elements.iter().enumerate() {
            let at = format!("element {}", i + 1);
            let to = resolve_waypoint(&at, &e.to, a_rad, lookup)?;
            a_rad = to.a_rad;
            let element = match &e.arc {
                None => Element::Line { to },
                Some(ArcDoc::Via(v)) => Element::Arc {
                    to,
                    by: ArcBy::Via(Vector3::from(*v)),
                },
                Some(ArcDoc::Centre {
                    centre_mm,
                    axis,
                    clockwise,
                }) => Element::Arc {
                    to,
                    by: ArcBy::Centre {
                        centre_mm: Vector3::from(*centre_mm),
                        axis: Vector3::from(*axis),
                        clockwise: *clockwise,
                    },
                },
            };
            out.push((element, e.corner));
        }
        Ok(out)
    }

    /// The start pose, if the document gives one (taught positions looked up with `lookup`);
    /// without an angle, `a_rad`.
    ///
    /// # Errors
    /// [`PathFileError::UnknownPosition`] for a name `lookup` does not know.
    pub fn start_pose(
        &self,
        a_rad: f64,
        lookup: &dyn Fn(&str) -> Option<Pose>,
    ) -> Result<Option<Pose>, PathFileError> {
        self.start
            .as_ref()
            .map(|w| resolve_waypoint("start", w, a_rad, lookup))
            .transpose()
    }
}

/// The path's acceleration, mm/s2: a number above 0.
fn path_accel(q: &Quantity) -> Result<f64, PathFileError> {
    let v = q
        .value("mm/s2")
        .map_err(|e| invalid("path_accel", e.to_string()))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(invalid(
            "path_accel",
            format!("{v} mm/s2 must be a number above 0"),
        ))
    }
}

/// A blend rounds the corner into the element after it: the last element has none, so its
/// `blend` is refused rather than dropped.
fn last_ends_at_a_stop(elements: &[ElementDoc]) -> Result<(), PathFileError> {
    let n = elements.len();
    match elements.last().map(|e| e.corner) {
        Some(Corner::Blend(r)) => Err(invalid(
            &format!("element {n}: blend"),
            format!(
                "{r} mm rounds the corner into the next element, and element {n} is the last; \
                 a path ends with a stop (leave out `blend`, or add an element after it)"
            ),
        )),
        _ => Ok(()),
    }
}

fn invalid(at: &str, problem: String) -> PathFileError {
    PathFileError::Invalid {
        at: at.to_owned(),
        problem,
    }
}

fn resolve_waypoint(
    at: &str,
    w: &Waypoint,
    a_rad: f64,
    lookup: &dyn Fn(&str) -> Option<Pose>,
) -> Result<Pose, PathFileError> {
    match w {
        Waypoint::At { xyz_mm, a_deg } => {
            let [x, y, z] = *xyz_mm;
            Ok(Pose {
                position_mm: Vector3::new(x, y, z),
                a_rad: a_deg.map_or(a_rad, f64::to_radians),
            })
        }
        Waypoint::Named(name) => lookup(name).ok_or_else(|| PathFileError::UnknownPosition {
            at: at.to_owned(),
            name: name.clone(),
        }),
    }
}

fn waypoint(at: &str, raw: &RawPose) -> Result<Waypoint, PathFileError> {
    match raw {
        RawPose::Name(text) => match text.strip_prefix('@') {
            Some(name) if !name.is_empty() => Ok(Waypoint::Named(name.to_owned())),
            _ => Err(invalid(
                at,
                format!("'{text}' is neither [x, y, z(, a)] nor a taught position '@name'"),
            )),
        },
        RawPose::Coordinates(v) => {
            let xyz = point(at, v, true)?;
            Ok(Waypoint::At {
                xyz_mm: xyz,
                a_deg: v.get(3).copied(),
            })
        }
    }
}

/// Three finite numbers (four allowed with `angle`).
fn point(at: &str, v: &[f64], angle: bool) -> Result<[f64; 3], PathFileError> {
    let most = if angle { 4 } else { 3 };
    if !(3..=most).contains(&v.len()) {
        let want = if angle {
            "[x, y, z] or [x, y, z, a]"
        } else {
            "[x, y, z]"
        };
        return Err(invalid(
            at,
            format!("{} numbers; it must be {want}", v.len()),
        ));
    }
    if let Some(bad) = v.iter().find(|x| !x.is_finite()) {
        return Err(invalid(at, format!("{bad} is not a finite number")));
    }
    Ok([v[0], v[1], v[2]])
}

fn element(n: usize, e: &RawElement) -> Result<ElementDoc, PathFileError> {
    let here = |key: &str| format!("element {n}: {key}");
    let (to, is_arc) = match (&e.line, &e.arc) {
        (Some(p), None) => (waypoint(&here("line"), p)?, false),
        (None, Some(p)) => (waypoint(&here("arc"), p)?, true),
        (Some(_), Some(_)) => {
            return Err(invalid(
                &format!("element {n}"),
                "give `line` or `arc`, not both".into(),
            ));
        }
        (None, None) => {
            return Err(invalid(
                &format!("element {n}"),
                "give `line = [x, y, z]` or `arc = [x, y, z]` with `via` or `centre`".into(),
            ));
        }
    };
    let arc = if is_arc {
        Some(arc_doc(n, e)?)
    } else {
        no_arc_keys(n, e)?;
        None
    };
    let corner = corner(n, e)?;
    Ok(ElementDoc { to, arc, corner })
}

/// A line element gives none of an arc's keys.
fn no_arc_keys(n: usize, e: &RawElement) -> Result<(), PathFileError> {
    for (key, given) in [
        ("via", e.via.is_some()),
        ("centre", e.centre.is_some()),
        ("direction", e.direction.is_some()),
        ("axis", e.axis.is_some()),
    ] {
        if given {
            return Err(invalid(
                &format!("element {n}: {key}"),
                "belongs to an arc, and this is a line".into(),
            ));
        }
    }
    Ok(())
}

/// How element `n` ends: a blend of a radius above 0, or a stop.
fn corner(n: usize, e: &RawElement) -> Result<Corner, PathFileError> {
    let here = format!("element {n}: blend");
    match (&e.blend, e.stop) {
        (Some(_), Some(true)) => Err(invalid(
            &format!("element {n}"),
            "give `blend` or `stop = true`, not both".into(),
        )),
        (Some(q), _) => {
            let r = q.value("mm").map_err(|p| invalid(&here, p.to_string()))?;
            if !(r.is_finite() && r > 0.0) {
                return Err(invalid(&here, format!("{r} mm must be above 0")));
            }
            Ok(Corner::Blend(r))
        }
        (None, _) => Ok(Corner::Stop),
    }
}

fn arc_doc(n: usize, e: &RawElement) -> Result<ArcDoc, PathFileError> {
    let here = |key: &str| format!("element {n}: {key}");
    match (&e.via, &e.centre) {
        (Some(v), None) => {
            for (key, given) in [
                ("direction", e.direction.is_some()),
                ("axis", e.axis.is_some()),
            ] {
                if given {
                    return Err(invalid(&here(key), "goes with `centre`, not `via`".into()));
                }
            }
            Ok(ArcDoc::Via(point(&here("via"), v, false)?))
        }
        (None, Some(c)) => Ok(ArcDoc::Centre {
            centre_mm: point(&here("centre"), c, false)?,
            axis: arc_axis(n, e)?,
            clockwise: arc_clockwise(n, e)?,
        }),
        (Some(_), Some(_)) => Err(invalid(
            &format!("element {n}"),
            "give `via` or `centre`, not both".into(),
        )),
        (None, None) => Err(invalid(
            &format!("element {n}"),
            "an arc needs `via = [x, y, z]` or `centre = [x, y, z]`".into(),
        )),
    }
}

/// The axis of an arc about a centre: not [0, 0, 0]; z up when not given.
fn arc_axis(n: usize, e: &RawElement) -> Result<[f64; 3], PathFileError> {
    let here = format!("element {n}: axis");
    let Some(a) = &e.axis else {
        return Ok([0.0, 0.0, 1.0]);
    };
    let a = point(&here, a, false)?;
    if Vector3::from(a).norm() < 1e-9 {
        return Err(invalid(&here, "must not be [0, 0, 0]".into()));
    }
    Ok(a)
}

/// Which way an arc about a centre turns: `direction` is "cw" or "ccw", and must be given.
fn arc_clockwise(n: usize, e: &RawElement) -> Result<bool, PathFileError> {
    let here = format!("element {n}: direction");
    match e.direction.as_deref() {
        Some("cw") => Ok(true),
        Some("ccw") => Ok(false),
        Some(other) => Err(invalid(
            &here,
            format!("'{other}' must be \"cw\" or \"ccw\""),
        )),
        None => Err(invalid(
            &here,
            "an arc about a centre needs `direction = \"cw\"` or `\"ccw\"`".into(),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CYCLE: &str = r#"
linterpd_path = 1
start = [-926.57, 535.03, 50.0]
path_accel = "5000mm/s2"

[[element]]
line = [-1144.43, 659.60, 286.60]
blend = "20mm"

[[element]]
line = "@place"
"#;

    #[test]
    fn a_cycle_reads_and_resolves_with_its_taught_position_and_kept_angle() {
        let doc = PathDoc::from_toml(CYCLE).unwrap();
        assert_eq!(doc.path_accel_mm_s2, Some(5000.0));
        assert_eq!(doc.elements[0].corner, Corner::Blend(20.0));
        assert_eq!(doc.elements[1].corner, Corner::Stop);
        let place = Pose::from_mm_deg(-1144.43, 659.60, 186.60, 30.0);
        let lookup = |name: &str| (name == "place").then_some(place);
        let start = doc.start_pose(0.5, &lookup).unwrap().unwrap();
        assert!((start.a_rad - 0.5).abs() < 1e-12);
        let elements = doc.resolve(start, &lookup).unwrap();
        assert!((elements[0].0.to().a_rad - 0.5).abs() < 1e-12);
        assert_eq!(elements[1].0.to(), place);
        let none = |_: &str| None;
        assert_eq!(
            doc.resolve(start, &none).unwrap_err().to_string(),
            "element 2: no taught position named 'place'"
        );
    }

    #[test]
    fn arcs_read_by_via_or_centre() {
        let doc = PathDoc::from_toml(
            r#"
[[element]]
arc = [0, 100, 0, 90]
via = [70.71, 70.71, 0]
[[element]]
arc = [0, 100, 0]
centre = [0, 0, 0]
direction = "cw"
"#,
        )
        .unwrap();
        assert_eq!(doc.elements[0].arc, Some(ArcDoc::Via([70.71, 70.71, 0.0])));
        assert_eq!(
            doc.elements[1].arc,
            Some(ArcDoc::Centre {
                centre_mm: [0.0; 3],
                axis: [0.0, 0.0, 1.0],
                clockwise: true
            })
        );
        // The same document as JSON.
        let json = serde_json::json!({
            "element": [
                {"arc": [0, 100, 0], "centre": [0, 0, 0], "direction": "ccw", "blend": 5},
                {"line": [0, 200, 0]}
            ]
        });
        let doc = PathDoc::from_json(json).unwrap();
        assert_eq!(doc.elements[0].corner, Corner::Blend(5.0));
    }

    #[test]
    fn a_blend_on_the_last_element_is_refused_not_ignored() {
        let err = |doc: Result<PathDoc, PathFileError>| doc.unwrap_err().to_string();
        let toml = "[[element]]\nline = [1, 2, 3]\nblend = \"5mm\"\n\
                    [[element]]\nline = [4, 5, 6]\nblend = \"5mm\"\n";
        let e = err(PathDoc::from_toml(toml));
        assert!(
            e.starts_with("element 2: blend: 5 mm rounds the corner into the next element"),
            "{e}"
        );
        assert!(e.contains("element 2 is the last"), "{e}");
        // The API's JSON document is read by the same check.
        let json = serde_json::json!({"element": [{"line": [1, 2, 3], "blend": "5mm"}]});
        assert!(
            err(PathDoc::from_json(json)).starts_with("element 1: blend: "),
            "the last element's blend is refused in JSON too"
        );
    }

    #[test]
    fn mistakes_are_named_with_their_element_and_key() {
        let err = |text: &str| PathDoc::from_toml(text).unwrap_err().to_string();
        assert_eq!(
            err("[[element]]\nline = [1, 2]\n"),
            "element 1: line: 2 numbers; it must be [x, y, z] or [x, y, z, a]"
        );
        assert_eq!(
            err("[[element]]\nline = [1, 2, 3]\nblend = \"-2mm\"\n"),
            "element 1: blend: -2 mm must be above 0"
        );
        assert_eq!(
            err("[[element]]\nline = [1, 2, 3]\nvia = [1, 2, 3]\n"),
            "element 1: via: belongs to an arc, and this is a line"
        );
        assert_eq!(
            err("[[element]]\narc = [1, 2, 3]\ncentre = [0, 0, 0]\n"),
            "element 1: direction: an arc about a centre needs `direction = \"cw\"` or `\"ccw\"`"
        );
        assert_eq!(
            err("[[element]]\narc = [1, 2, 3]\n"),
            "element 1: an arc needs `via = [x, y, z]` or `centre = [x, y, z]`"
        );
        assert_eq!(err(""), "element: a path needs at least one [[element]]");
        assert_eq!(
            err("linterpd_path = 2\n[[element]]\nline = [1, 2, 3]\n"),
            "linterpd_path: version 2 is not known; this linterpd reads version 1"
        );
        assert_eq!(
            err("path_accel = \"fast\"\n[[element]]\nline = [1, 2, 3]\n"),
            "path_accel: 'fast' is not a number of mm/s2"
        );
        assert!(
            err("[[element]]\nline = [1, 2, 3]\nspeed = 3\n").contains("unknown field `speed`")
        );
        assert_eq!(
            err("[[element]]\nline = \"pick\"\n"),
            "element 1: line: 'pick' is neither [x, y, z(, a)] nor a taught position '@name'"
        );
    }
}
