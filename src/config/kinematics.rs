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
