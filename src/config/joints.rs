//! `[[robots.NAME.joints]]` -> four [`Joint`]s: units by the model's joint kinds, channels of an
//! FP-X C60T and their top frequencies, position limits.

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::kinematics::joint_order;
use super::raw::{Quantity, RawJoint};
use crate::kinematics::{JOINTS, JointKind, Kinematics, Model};
use crate::robot::{Dynamics, Joint, Ramp};

/// Highest pulse frequency of each channel of an FP-X C60T (transistor output), Hz: channels 0
/// and 1 are the 100 kHz ones, 2 and 3 the 20 kHz ones (FP-X User's Manual, positioning
/// specifications).
const FPX_C60T_MAX_FREQ_HZ: [u32; JOINTS] = [100_000, 100_000, 20_000, 20_000];

/// Highest count an F174 target holds (DINT).
const MAX_COUNT: f64 = i32::MAX as f64;

/// The joints table of a robot with `model`.
pub(super) fn joints(
    at: &At,
    raw: &Spanned<Vec<Spanned<RawJoint>>>,
    model: &Model,
) -> Result<[Joint; JOINTS], ConfigError> {
    let list = raw.get_ref();
    if list.len() != JOINTS {
        let count = Spanned::new(raw.span(), list.len() as i64);
        let reason = format!(
            "a {} robot has exactly {JOINTS} joints, in this order: {}",
            model.name(),
            joint_order(model)
        );
        return Err(at.invalid(&count, reason));
    }
    let kinds = model.joint_kinds();
    let mut joints = Vec::with_capacity(JOINTS);
    for (i, raw_joint) in list.iter().enumerate() {
        let joint = joint(&at.index(i), raw_joint, kinds[i])?;
        refuse_shared(at, i, raw_joint.get_ref(), &joints)?;
        joints.push(joint);
    }
    Ok(joints
        .try_into()
        .expect("exactly JOINTS joints were checked"))
}

/// One joint of `kind`.
fn joint(at: &At, table: &Spanned<RawJoint>, kind: JointKind) -> Result<Joint, ConfigError> {
    let raw = table.get_ref();
    let required = |q, value| required(at, table, q, kind, value);
    let name = raw.name.get_ref();
    if name.trim().is_empty() {
        return Err(at.child("name").invalid(&raw.name, "a joint needs a name"));
    }
    let channel = at
        .child("channel")
        .int_within(&raw.channel, 0, JOINTS as i64 - 1)? as u8;
    let value = |q| unit_value(at, raw, q, kind);
    let step = value(Quantity::Step)?;
    let offset = value(Quantity::Offset)?;
    let (min, max) = (value(Quantity::Min)?, value(Quantity::Max)?);
    let joint = Joint {
        name: name.clone(),
        channel,
        kind,
        step: required(Quantity::Step, step)?,
        offset: offset.unwrap_or(0.0),
        min: required(Quantity::Min, min)?,
        max: required(Quantity::Max, max)?,
        max_freq_hz: max_freq_hz(at, raw, channel)?,
        output: raw.output,
        dynamics: Dynamics::default(),
    };
    check_step_and_limits(at, raw, &joint)?;
    let dynamics = dynamics(
        at,
        raw,
        &joint,
        value(Quantity::MaxAccel)?,
        value(Quantity::MaxJerk)?,
    )?;
    Ok(Joint { dynamics, ..joint })
}

/// A joint's `max_jerk` is kept by an S-curve alone (a trapezoid steps its acceleration at
/// once): a robot whose motion is a trapezoid may not give one.
pub(super) fn jerk_needs_s_curve(
    at: &At,
    raw: &Spanned<Vec<Spanned<RawJoint>>>,
    joints: &[Joint; JOINTS],
    ramp: Ramp,
) -> Result<(), ConfigError> {
    if matches!(ramp, Ramp::SCurve { .. }) {
        return Ok(());
    }
    for (i, (joint, table)) in joints.iter().zip(raw.get_ref()).enumerate() {
        let unit = joint.kind.user_unit();
        if let Some(spanned) = table.get_ref().get(Quantity::MaxJerk, unit) {
            let key = at.index(i).child(&Quantity::MaxJerk.key(unit));
            return Err(key.invalid(
                spanned,
                "needs the robot's motion.profile = \"s-curve\" (a trapezoid steps its \
                 acceleration at once)",
            ));
        }
    }
    Ok(())
}

/// The drive's limits: `max_accel_deg_s2` (or `_mm_s2`) and `max_jerk_deg_s3` (or `_mm_s3`)
/// above 0, `start_hz` above 0 and at most the channel's `max_freq_hz`.
fn dynamics(
    at: &At,
    raw: &RawJoint,
    joint: &Joint,
    max_accel: Option<f64>,
    max_jerk: Option<f64>,
) -> Result<Dynamics, ConfigError> {
    let unit = joint.kind.user_unit();
    for (quantity, value) in [
        (Quantity::MaxAccel, max_accel),
        (Quantity::MaxJerk, max_jerk),
    ] {
        if value.is_some_and(|v| v <= 0.0) {
            let spanned = raw.get(quantity, unit).expect("given");
            let key = at.child(&quantity.key(unit));
            return Err(key.invalid(spanned, "must be above 0"));
        }
    }
    let start_hz = raw
        .start_hz
        .as_ref()
        .map(|v| start_hz(&at.child("start_hz"), v, joint))
        .transpose()?;
    Ok(Dynamics {
        max_accel,
        start_hz,
        max_jerk,
    })
}

/// The frequency the drive starts at: above 0 Hz and at most the joint's `max_freq_hz`.
fn start_hz(at: &At, v: &Spanned<f64>, joint: &Joint) -> Result<f64, ConfigError> {
    let hz = at.finite(v)?;
    if hz <= 0.0 {
        return Err(at.invalid(v, "must be above 0 Hz"));
    }
    if hz > f64::from(joint.max_freq_hz) {
        let reason = format!(
            "must be at most the joint's max_freq_hz = {} Hz",
            joint.max_freq_hz
        );
        return Err(at.invalid(v, reason));
    }
    Ok(hz)
}

/// The quantity in internal units, when given in the unit `kind` takes; an error naming the
/// right key when given in the other one.
fn unit_value(
    at: &At,
    raw: &RawJoint,
    quantity: Quantity,
    kind: JointKind,
) -> Result<Option<f64>, ConfigError> {
    let (unit, other) = match kind {
        JointKind::Revolute => ("deg", "mm"),
        JointKind::Prismatic => ("mm", "deg"),
    };
    if let Some(wrong) = raw.get(quantity, other) {
        let reason = format!(
            "joint {} is {}, so it takes {}",
            raw.name.get_ref(),
            kind_name(kind),
            quantity.key(unit)
        );
        return Err(at.child(&quantity.key(other)).invalid(wrong, reason));
    }
    raw.get(quantity, unit)
        .map(|v| at.child(&quantity.key(unit)).finite(v))
        .transpose()
        .map(|v| v.map(|v| kind.from_user(v)))
}

/// A quantity that must be given.
fn required(
    at: &At,
    table: &Spanned<RawJoint>,
    quantity: Quantity,
    kind: JointKind,
    value: Option<f64>,
) -> Result<f64, ConfigError> {
    value.ok_or_else(|| {
        let key = quantity.key(kind.user_unit());
        let name = table.get_ref().name.get_ref();
        let reason = format!("joint {name} is {}", kind_name(kind));
        at.child(&key).missing(&table.span(), reason)
    })
}

fn kind_name(kind: JointKind) -> &'static str {
    match kind {
        JointKind::Revolute => "revolute",
        JointKind::Prismatic => "prismatic",
    }
}

/// `max_freq_hz` within 1 ..= what the channel allows.
fn max_freq_hz(at: &At, raw: &RawJoint, channel: u8) -> Result<u32, ConfigError> {
    let limit = FPX_C60T_MAX_FREQ_HZ[usize::from(channel)];
    let value = *raw.max_freq_hz.get_ref();
    let at = at.child("max_freq_hz");
    if value < 1 {
        return Err(at.invalid(&raw.max_freq_hz, "must be at least 1 Hz"));
    }
    if value > i64::from(limit) {
        let reason = format!("channel {channel} of an FP-X C60T allows at most {limit} Hz");
        return Err(at.invalid(&raw.max_freq_hz, reason));
    }
    Ok(value as u32)
}

/// A nonzero step, min below max, and both limits within the PLC's count range.
fn check_step_and_limits(at: &At, raw: &RawJoint, joint: &Joint) -> Result<(), ConfigError> {
    let unit = joint.kind.user_unit();
    let spanned = |q| raw.get(q, unit).expect("required quantities are present");
    let key = |q: Quantity| at.child(&q.key(unit));
    if joint.step == 0.0 {
        return Err(key(Quantity::Step).invalid(spanned(Quantity::Step), "must not be 0"));
    }
    if joint.min >= joint.max {
        let min = joint.user(joint.min);
        let reason = format!("must be above min_{unit} = {min}");
        return Err(key(Quantity::Max).invalid(spanned(Quantity::Max), reason));
    }
    for q in [Quantity::Min, Quantity::Max] {
        let value = if q == Quantity::Min {
            joint.min
        } else {
            joint.max
        };
        let count = ((value - joint.offset) / joint.step).round();
        if count.abs() > MAX_COUNT {
            let reason = format!(
                "is {count} pulses from offset_{unit}; a PLC count reaches at most {}",
                i32::MAX
            );
            return Err(key(q).invalid(spanned(q), reason));
        }
    }
    Ok(())
}

/// Refuses a channel or a name an earlier joint already has.
fn refuse_shared(at: &At, i: usize, raw: &RawJoint, earlier: &[Joint]) -> Result<(), ConfigError> {
    let channel = *raw.channel.get_ref();
    if let Some((j, other)) = earlier
        .iter()
        .enumerate()
        .find(|(_, o)| i64::from(o.channel) == channel)
    {
        let reason = format!(
            "channel {channel} already drives joints[{j}] ({})",
            other.name
        );
        return Err(at.index(i).child("channel").invalid(&raw.channel, reason));
    }
    if let Some(j) = earlier.iter().position(|o| o.name == *raw.name.get_ref()) {
        let reason = format!("joints[{j}] already has this name");
        return Err(at.index(i).child("name").invalid(&raw.name, reason));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::fixture::Says::{Contains, EndsWith, Is};
    use super::super::fixture::{assert_refusals, edited, error, message};
    use super::ConfigError;

    #[test]
    fn each_bad_joint_key_is_refused_naming_its_line_value_and_limit() {
        assert_refusals(&[
            (
                35,
                "channel = 4",
                Is("config line 35: robots.r.joints[3].channel = 4: must be within 0..=3"),
            ),
            (
                27,
                "channel = 1",
                Is(
                    "config line 27: robots.r.joints[2].channel = 1: channel 1 already drives \
                     joints[1] (d2)",
                ),
            ),
            (
                31,
                "max_freq_hz = 200000",
                Is(
                    "config line 31: robots.r.joints[2].max_freq_hz = 200000: channel 2 of an FP-X \
                     C60T allows at most 20000 Hz",
                ),
            ),
            (
                15,
                "max_freq_hz = 0",
                EndsWith("max_freq_hz = 0: must be at least 1 Hz"),
            ),
            (
                20,
                "step_mm = 0.0",
                Is("config line 20: robots.r.joints[1].step_mm = 0: must not be 0"),
            ),
            (
                12,
                "step_deg = nan",
                Is("config line 12: robots.r.joints[0].step_deg = nan: must be a finite number"),
            ),
            (
                13,
                "min_deg = 170.0",
                Is("config line 14: robots.r.joints[0].max_deg = 170: must be above min_deg = 170"),
            ),
            (
                36,
                "step_mm = 0.0025",
                Is(
                    "config line 36: robots.r.joints[3].step_mm = 0.0025: joint wrist is revolute, \
                     so it takes step_deg",
                ),
            ),
            (
                29,
                "min_deg = 0.0",
                Contains("joint d3 is prismatic, so it takes min_mm"),
            ),
            (
                12,
                "",
                Is(
                    "config line 9: robots.r.joints[0].step_deg is missing: joint theta1 is \
                     revolute",
                ),
            ),
            (
                34,
                "name = \"d2\"",
                EndsWith("joints[3].name = \"d2\": joints[1] already has this name"),
            ),
            (
                30,
                "max_mm = 1e9",
                Contains("a PLC count reaches at most 2147483647"),
            ),
        ]);
    }

    #[test]
    fn three_joints_are_refused_naming_the_model_order() {
        let text = edited(&[(33, ""), (34, ""), (35, ""), (36, ""), (37, ""), (38, "")])
            .replace("max_freq_hz = 20000\noutput = \"pulse-sign\"\n\n", "");
        let e = error(&text);
        assert!(
            matches!(&e, ConfigError::Invalid { line: 9, key, value, .. }
                if key == "robots.r.joints" && value == "3"),
            "{e}"
        );
        assert!(
            e.to_string()
                .contains("a cylindrical robot has exactly 4 joints")
        );
    }

    #[test]
    fn drive_limits_are_read_in_the_joint_s_units() {
        let text = edited(&[
            (16, "output = \"pulse-sign\"\nmax_accel_deg_s2 = 90.0"),
            (
                32,
                "output = \"pulse-sign\"\nmax_accel_mm_s2 = 2000.0\nstart_hz = 800.0",
            ),
        ]);
        let config = super::super::Config::from_toml(&text).unwrap();
        let joints = &config.robot(Some("r")).unwrap().joints;
        let a = joints[0].dynamics.max_accel.unwrap();
        assert!((a - 90f64.to_radians()).abs() < 1e-12, "{a}");
        assert_eq!(joints[0].dynamics.start_hz, None);
        assert_eq!(joints[2].dynamics.max_accel, Some(2000.0));
        assert_eq!(joints[2].dynamics.start_hz, Some(800.0));
        assert!(!joints[1].dynamics.is_set());
    }

    #[test]
    fn drive_limits_name_the_joint_the_key_the_value_and_the_limit() {
        let after_d3 = |extra: &str| edited(&[(32, &format!("output = \"pulse-sign\"\n{extra}"))]);
        assert_eq!(
            message(&after_d3("max_accel_mm_s2 = 0.0")),
            "config line 33: robots.r.joints[2].max_accel_mm_s2 = 0: must be above 0"
        );
        assert_eq!(
            message(&after_d3("max_accel_deg_s2 = 50.0")),
            "config line 33: robots.r.joints[2].max_accel_deg_s2 = 50: joint d3 is prismatic, so \
             it takes max_accel_mm_s2"
        );
        assert_eq!(
            message(&after_d3("start_hz = 25000.0")),
            "config line 33: robots.r.joints[2].start_hz = 25000: must be at most the joint's \
             max_freq_hz = 20000 Hz"
        );
        assert_eq!(
            message(&after_d3("start_hz = -1.0")),
            "config line 33: robots.r.joints[2].start_hz = -1: must be above 0 Hz"
        );
        assert!(
            message(&after_d3("start_hz = nan"))
                .contains("start_hz = nan: must be a finite number")
        );
    }

    #[test]
    fn a_joint_s_jerk_is_read_in_its_units_and_needs_an_s_curve() {
        let s_curve = "accel_time = \"200ms\"\nprofile = \"s-curve\"\njerk_mm_s3 = 20000.0";
        let text = edited(&[
            (8, s_curve),
            (16, "output = \"pulse-sign\"\nmax_jerk_deg_s3 = 900.0"),
            (32, "output = \"pulse-sign\"\nmax_jerk_mm_s3 = 5000.0"),
        ]);
        let config = super::super::Config::from_toml(&text).unwrap();
        let joints = &config.robot(Some("r")).unwrap().joints;
        let j = joints[0].dynamics.max_jerk.unwrap();
        assert!((j - 900f64.to_radians()).abs() < 1e-12, "{j}");
        assert_eq!(joints[2].dynamics.max_jerk, Some(5000.0));
        assert!(joints[2].dynamics.is_set() && !joints[1].dynamics.is_set());

        let after_d3 = |motion: &str, extra: &str| {
            edited(&[
                (8, motion),
                (32, &format!("output = \"pulse-sign\"\n{extra}")),
            ])
        };
        assert_eq!(
            message(&after_d3(s_curve, "max_jerk_mm_s3 = 0.0")),
            "config line 35: robots.r.joints[2].max_jerk_mm_s3 = 0: must be above 0"
        );
        assert_eq!(
            message(&after_d3(s_curve, "max_jerk_deg_s3 = 50.0")),
            "config line 35: robots.r.joints[2].max_jerk_deg_s3 = 50: joint d3 is prismatic, \
             so it takes max_jerk_mm_s3"
        );
        assert_eq!(
            message(&after_d3(
                "accel_time = \"200ms\"",
                "max_jerk_mm_s3 = 5000.0"
            )),
            "config line 33: robots.r.joints[2].max_jerk_mm_s3 = 5000: needs the robot's \
             motion.profile = \"s-curve\" (a trapezoid steps its acceleration at once)"
        );
    }
}
