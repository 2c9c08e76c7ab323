//! `[robots.NAME.kinematics]` -> [`Model`]: which keys each model takes, their defaults and
//! their limits.

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::raw::{ModelType, RawElbow, RawKinematics};
use crate::kinematics::{Cartesian, Cylindrical, Elbow, Model, Scara};

/// `min_axis_distance_mm` when not given.
const DEFAULT_MIN_AXIS_DISTANCE_MM: f64 = 50.0;
/// `reach_margin_mm` when not given.
const DEFAULT_REACH_MARGIN_MM: f64 = 1.0;

/// The model a kinematics table describes.
pub(super) fn model(at: &At, raw: &Spanned<RawKinematics>) -> Result<Model, ConfigError> {
    let k = raw.get_ref();
    let model = *k.model.get_ref();
    refuse_foreign_keys(at, k, model)?;
    match model {
        ModelType::Cylindrical => cylindrical(at, raw).map(Model::Cylindrical),
        ModelType::Cartesian => Ok(Model::Cartesian(Cartesian)),
        ModelType::Scara => scara(at, raw).map(Model::Scara),
    }
}

/// The joints of a model, in order, for messages.
pub(super) fn joint_order(model: &Model) -> &'static str {
    match model {
        Model::Cylindrical(_) => {
            "theta1 (revolute), d2 (prismatic), d3 (prismatic), wrist (revolute)"
        }
        Model::Cartesian(_) => "x (prismatic), y (prismatic), z (prismatic), a (revolute)",
        Model::Scara(_) => "theta1 (revolute), theta2 (revolute), z (prismatic), wrist (revolute)",
    }
}

fn name(model: ModelType) -> &'static str {
    match model {
        ModelType::Cylindrical => "cylindrical",
        ModelType::Cartesian => "cartesian",
        ModelType::Scara => "scara",
    }
}

fn keys_of(model: ModelType) -> &'static [&'static str] {
    match model {
        ModelType::Cylindrical => &["l0_mm", "min_axis_distance_mm"],
        ModelType::Cartesian => &[],
        ModelType::Scara => &["l1_mm", "l2_mm", "elbow", "reach_margin_mm"],
    }
}

/// Refuses a key that belongs to another model, naming the keys this one takes.
fn refuse_foreign_keys(at: &At, k: &RawKinematics, model: ModelType) -> Result<(), ConfigError> {
    let allowed = keys_of(model);
    let takes = if allowed.is_empty() {
        "no key but type".to_owned()
    } else {
        allowed.join(", ")
    };
    let reason = format!("a {} model takes {takes}", name(model));
    let numbers = [
        ("l0_mm", &k.l0_mm),
        ("min_axis_distance_mm", &k.min_axis_distance_mm),
        ("l1_mm", &k.l1_mm),
        ("l2_mm", &k.l2_mm),
        ("reach_margin_mm", &k.reach_margin_mm),
    ];
    for (key, value) in numbers {
        if let Some(value) = value.as_ref().filter(|_| !allowed.contains(&key)) {
            return Err(at.child(key).invalid(value, &reason));
        }
    }
    match &k.elbow {
        Some(elbow) if !allowed.contains(&"elbow") => {
            let shown = Spanned::new(elbow.span(), elbow_name(*elbow.get_ref()).to_owned());
            Err(at.child("elbow").invalid(&shown, &reason))
        }
        _ => Ok(()),
    }
}

fn elbow_name(elbow: RawElbow) -> &'static str {
    match elbow {
        RawElbow::Left => "left",
        RawElbow::Right => "right",
    }
}

fn cylindrical(at: &At, raw: &Spanned<RawKinematics>) -> Result<Cylindrical, ConfigError> {
    let k = raw.get_ref();
    let l0 = at.child("l0_mm");
    let l0_mm = match &k.l0_mm {
        Some(v) => l0.non_negative(v)?,
        None => {
            return Err(l0.missing(
                &raw.span(),
                "a cylindrical model needs its radius at d3 = 0",
            ));
        }
    };
    let min_axis_distance_mm = match &k.min_axis_distance_mm {
        Some(v) => at.child("min_axis_distance_mm").positive(v)?,
        None => DEFAULT_MIN_AXIS_DISTANCE_MM,
    };
    Ok(Cylindrical {
        l0_mm,
        min_axis_distance_mm,
    })
}

fn scara(at: &At, raw: &Spanned<RawKinematics>) -> Result<Scara, ConfigError> {
    let k = raw.get_ref();
    let arm = |key: &str, value: &Option<Spanned<f64>>| match value {
        Some(v) => at.child(key).positive(v),
        None => Err(at
            .child(key)
            .missing(&raw.span(), "a scara model needs both arm lengths")),
    };
    let l1_mm = arm("l1_mm", &k.l1_mm)?;
    let l2_mm = arm("l2_mm", &k.l2_mm)?;
    let elbow = match k.elbow.as_ref().map(|e| *e.get_ref()) {
        Some(RawElbow::Left) => Elbow::Left,
        Some(RawElbow::Right) => Elbow::Right,
        None => {
            let reason = "a scara model keeps its elbow on one side: left or right";
            return Err(at.child("elbow").missing(&raw.span(), reason));
        }
    };
    let margin = at.child("reach_margin_mm");
    let reach_margin_mm = match &k.reach_margin_mm {
        Some(v) => margin.non_negative(v)?,
        None => DEFAULT_REACH_MARGIN_MM,
    };
    let scara = Scara {
        l1_mm,
        l2_mm,
        elbow,
        reach_margin_mm,
    };
    let (inner, outer) = scara.reach_mm();
    if inner >= outer {
        let value = k
            .reach_margin_mm
            .clone()
            .unwrap_or_else(|| Spanned::new(raw.span(), reach_margin_mm));
        let reason = format!("leaves no reachable radius (inner {inner} mm, outer {outer} mm)");
        return Err(margin.invalid(&value, reason));
    }
    Ok(scara)
}

#[cfg(test)]
mod tests {
    use super::super::Config;
    use super::super::fixture::Says::{EndsWith, Is};
    use super::super::fixture::{assert_refusals, edited, message};
    use super::*;

    #[test]
    fn each_bad_kinematics_key_is_refused_naming_its_line_value_and_limit() {
        assert_refusals(&[
            (
                4,
                "l0_mm = 500.0\nl1_mm = 300.0",
                Is(
                    "config line 5: robots.r.kinematics.l1_mm = 300: a cylindrical model takes \
                     l0_mm, min_axis_distance_mm",
                ),
            ),
            (
                4,
                "",
                Is(
                    "config line 2: robots.r.kinematics.l0_mm is missing: a cylindrical model \
                     needs its radius at d3 = 0",
                ),
            ),
            (
                4,
                "l0_mm = -1.0",
                EndsWith("l0_mm = -1: must be at least 0"),
            ),
            (
                4,
                "l0_mm = 0\nmin_axis_distance_mm = 0",
                EndsWith("min_axis_distance_mm = 0: must be above 0"),
            ),
            (
                3,
                "type = \"cartesian\"",
                EndsWith("l0_mm = 500: a cartesian model takes no key but type"),
            ),
        ]);
    }

    #[test]
    fn scara_reads_arms_elbow_and_default_margin() {
        let text = edited(&[(
            4,
            "l1_mm = 300.0\nl2_mm = 250.0\nelbow = \"right\"",
        )])
        .replace("type = \"cylindrical\"", "type = \"scara\"")
        .replace("name = \"d2\"\nchannel = 1\nstep_mm = 0.025\nmin_mm = -50.0\nmax_mm = 400.0",
                 "name = \"theta2\"\nchannel = 1\nstep_deg = 0.01\nmin_deg = -150.0\nmax_deg = 150.0");
        let robot = &Config::from_toml(&text).unwrap().robots[0];
        let Model::Scara(s) = robot.kinematics.model else {
            panic!("scara")
        };
        assert_eq!(
            (s.l1_mm, s.l2_mm, s.elbow, s.reach_margin_mm),
            (300.0, 250.0, Elbow::Right, 1.0)
        );
    }

    #[test]
    fn scara_without_elbow_is_refused() {
        let text = edited(&[(3, "type = \"scara\""), (4, "l1_mm = 300.0\nl2_mm = 250.0")]);
        assert!(message(&text).starts_with("config line 2: robots.r.kinematics.elbow is missing"));
    }

    #[test]
    fn scara_margin_that_leaves_no_reach_is_refused() {
        let text = edited(&[
            (3, "type = \"scara\""),
            (
                4,
                "l1_mm = 300.0\nl2_mm = 250.0\nelbow = \"left\"\nreach_margin_mm = 260.0",
            ),
        ]);
        assert!(message(&text).contains("reach_margin_mm = 260: leaves no reachable radius"));
    }
}
