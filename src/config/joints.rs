//! `[[robots.NAME.joints]]` -> four [`Joint`]s: units by the model's joint kinds, channels of an
//! FP-X C60T and their top frequencies, position limits.

use toml::Spanned;

use super::ConfigError;
use super::check::At;
use super::kinematics::joint_order;
use super::raw::{Quantity, RawJoint};
use crate::kinematics::{JOINTS, JointKind, Kinematics, Model};
use crate::robot::Joint;

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
    };
    check_step_and_limits(at, raw, &joint)?;
    Ok(joint)
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
            "joint {} is {}, so it takes {}_{unit}",
            raw.name.get_ref(),
            kind_name(kind),
            quantity.stem()
        );
        return Err(at
            .child(&format!("{}_{other}", quantity.stem()))
            .invalid(wrong, reason));
    }
    raw.get(quantity, unit)
        .map(|v| at.child(&format!("{}_{unit}", quantity.stem())).finite(v))
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
        let key = format!("{}_{}", quantity.stem(), kind.user_unit());
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
    let key = |q: Quantity| at.child(&format!("{}_{unit}", q.stem()));
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
