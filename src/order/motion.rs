//! PURE. The motion keys a move order, a path order and a cycle's path step share (speed,
//! acceleration time, method, period, tolerance, ramp profile and jerk), their check against the
//! robot's defaults and the order limits, and the reading of a document's table key by key.
//!
//! The orders embed [`OrderMotion`] and are read by hand ([`read_table`]) rather than with serde's
//! `flatten`: a flattened struct loses `deny_unknown_fields`, and serde buffers its keys, so an
//! error would no longer name the key where it stands. Read here, an unknown key is refused as
//! serde's derive refuses it (``unknown field `colour`, expected one of `to`, ...``), at the
//! key itself, and a value's error is blamed on its key.

use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, DeserializeSeed, MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserializer, Serialize, Serializer};

use super::{
    MAX_ACCEL_TIME_S, OrderError, OrderLimits, PERIOD_RANGE_S, TOLERANCE_RANGE_MM, duration,
    number, positive, refuse, within,
};
use crate::robot::{Method, Motion, Ramp};

/// The motion an order asks for; every key left out is the robot's default.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OrderMotion {
    /// Speed along the path, mm/s.
    pub speed_mm_s: Option<f64>,
    /// Acceleration time, e.g. `"200ms"`.
    pub accel_time: Option<String>,
    /// `"constant-period"` or `"bounded-error"`.
    pub method: Option<String>,
    /// Interpolation period, e.g. `"50ms"`.
    pub period: Option<String>,
    /// Path tolerance of a bounded-error move, mm.
    pub tolerance_mm: Option<f64>,
    /// The ramps' shape: `"trapezoid"` or `"s-curve"` (jerk-limited; its jerk from
    /// `jerk_mm_s3` or the robot's).
    pub profile: Option<String>,
    /// The path's jerk of an S-curve, mm/s^3.
    pub jerk_mm_s3: Option<f64>,
}

impl OrderMotion {
    /// The motion keys, in the order documents show them.
    pub const KEYS: [&'static str; 7] = [
        "speed_mm_s",
        "accel_time",
        "method",
        "period",
        "tolerance_mm",
        "profile",
        "jerk_mm_s3",
    ];

    /// The keys and their values as written (`None`: not given), in [`Self::KEYS`]' order.
    #[must_use]
    pub fn shown(&self) -> [(&'static str, Option<String>); 7] {
        let shown = |v: Option<f64>| v.map(|v| v.to_string());
        [
            ("speed_mm_s", shown(self.speed_mm_s)),
            ("accel_time", self.accel_time.clone()),
            ("method", self.method.clone()),
            ("period", self.period.clone()),
            ("tolerance_mm", shown(self.tolerance_mm)),
            ("profile", self.profile.clone()),
            ("jerk_mm_s3", shown(self.jerk_mm_s3)),
        ]
    }

    /// Reads the value of the motion key `key` from `map` (a key of [`Self::KEYS`]).
    pub(crate) fn read<'de, A: MapAccess<'de>>(
        &mut self,
        key: &str,
        map: &mut A,
    ) -> Result<(), A::Error> {
        match key {
            "speed_mm_s" => self.speed_mm_s = map.next_value()?,
            "accel_time" => self.accel_time = map.next_value()?,
            "method" => self.method = map.next_value()?,
            "period" => self.period = map.next_value()?,
            "tolerance_mm" => self.tolerance_mm = map.next_value()?,
            "profile" => self.profile = map.next_value()?,
            "jerk_mm_s3" => self.jerk_mm_s3 = map.next_value()?,
            other => return Err(de::Error::unknown_field(other, &Self::KEYS)),
        }
        Ok(())
    }

    /// The motion asked, the robot's `defaults` filling the gaps, checked against `limits`;
    /// the speed override applied last.
    ///
    /// # Errors
    /// The key at fault, its value and the limit.
    pub fn check(&self, defaults: Motion, limits: OrderLimits) -> Result<Motion, OrderError> {
        let mut m = defaults;
        if let Some(v) = self.speed_mm_s {
            m.speed_mm_s = positive("speed_mm_s", v)?;
            if v > limits.max_speed_mm_s {
                return Err(refuse(
                    "speed_mm_s",
                    &number(v),
                    format!(
                        "must be at most {} mm/s, the robot's max_speed_mm_s",
                        limits.max_speed_mm_s
                    ),
                ));
            }
        }
        if let Some(t) = &self.accel_time {
            m.accel_s = accel_time(t)?;
        }
        if let Some(t) = &self.period {
            m.period_s = period(t)?;
        }
        m.method = self.method(defaults.method)?;
        m.ramp = self.ramp(defaults.ramp)?;
        // The speed override: every order's speed (asked, or the robot's default) is planned
        // at its share, once checked against the robot's limit as asked.
        m.speed_mm_s *= limits.speed_override.clamp(0.01, 1.0);
        Ok(m)
    }

    /// The method asked (`method`, `tolerance_mm`), the robot's `default` filling the gaps.
    fn method(&self, default: Method) -> Result<Method, OrderError> {
        let tolerance = self
            .tolerance_mm
            .map(|t| {
                positive("tolerance_mm", t)
                    .and_then(|t| within("tolerance_mm", t, &TOLERANCE_RANGE_MM, "mm"))
            })
            .transpose()?;
        Ok(match (self.method.as_deref(), tolerance, default) {
            (Some("constant-period"), None, _) => Method::ConstantPeriod,
            (Some("bounded-error") | None, Some(tolerance_mm), _)
            | (Some("bounded-error"), None, Method::BoundedError { tolerance_mm }) => {
                Method::BoundedError { tolerance_mm }
            }
            (Some("bounded-error"), None, Method::ConstantPeriod) => {
                return Err(refuse(
                    "tolerance_mm",
                    &"null",
                    "method bounded-error needs a tolerance above 0 mm",
                ));
            }
            (Some("constant-period"), Some(t), _) => {
                return Err(refuse(
                    "tolerance_mm",
                    &t,
                    "only method bounded-error takes a tolerance",
                ));
            }
            (Some(other), _, _) => {
                return Err(refuse(
                    "method",
                    &format!("{other:?}"),
                    "must be \"constant-period\" or \"bounded-error\"",
                ));
            }
            (None, None, method) => method,
        })
    }

    /// The ramps' shape asked (`profile`, `jerk_mm_s3`), the robot's filling the gaps.
    fn ramp(&self, default: Ramp) -> Result<Ramp, OrderError> {
        let jerk = self
            .jerk_mm_s3
            .map(|j| positive("jerk_mm_s3", j))
            .transpose()?;
        Ok(match (self.profile.as_deref(), jerk, default) {
            (None, None, ramp) => ramp,
            (Some("trapezoid"), None, _) => Ramp::Trapezoid,
            (Some("s-curve") | None, Some(jerk_mm_s3), Ramp::SCurve { .. })
            | (Some("s-curve"), Some(jerk_mm_s3), Ramp::Trapezoid)
            | (Some("s-curve"), None, Ramp::SCurve { jerk_mm_s3 }) => Ramp::SCurve { jerk_mm_s3 },
            (Some("s-curve"), None, Ramp::Trapezoid) => {
                return Err(refuse(
                    "jerk_mm_s3",
                    &"null",
                    "profile \"s-curve\" needs the path's jerk (the robot's profile is the \
                     trapezoid), e.g. 20000 mm/s^3",
                ));
            }
            (Some("trapezoid") | None, Some(j), _) => {
                return Err(refuse(
                    "jerk_mm_s3",
                    &number(j),
                    "only profile \"s-curve\" takes a jerk",
                ));
            }
            (Some(other), _, _) => {
                return Err(refuse(
                    "profile",
                    &format!("{other:?}"),
                    "must be \"trapezoid\" or \"s-curve\"",
                ));
            }
        })
    }
}

/// The acceleration time asked, at most [`MAX_ACCEL_TIME_S`], s.
fn accel_time(t: &str) -> Result<f64, OrderError> {
    let accel_s = duration("accel_time", t, true)?;
    if accel_s > MAX_ACCEL_TIME_S {
        return Err(refuse(
            "accel_time",
            &format!("{t:?}"),
            format!("must be at most {MAX_ACCEL_TIME_S} s"),
        ));
    }
    Ok(accel_s)
}

/// The interpolation period asked, within [`PERIOD_RANGE_S`], s.
fn period(t: &str) -> Result<f64, OrderError> {
    let period_s = duration("period", t, false)?;
    if !PERIOD_RANGE_S.contains(&period_s) {
        return Err(refuse(
            "period",
            &format!("{t:?}"),
            format!(
                "must be within {} ms to {} s",
                PERIOD_RANGE_S.start() * 1e3,
                PERIOD_RANGE_S.end()
            ),
        ));
    }
    Ok(period_s)
}

/// The keys given, as a map (flattened into an order's JSON, in [`OrderMotion::KEYS`]' order).
impl Serialize for OrderMotion {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        fn entry<M: SerializeMap, T: Serialize>(
            map: &mut M,
            key: &str,
            value: Option<&T>,
        ) -> Result<(), M::Error> {
            value.map_or(Ok(()), |v| map.serialize_entry(key, v))
        }
        let mut map = s.serialize_map(None)?;
        entry(&mut map, "speed_mm_s", self.speed_mm_s.as_ref())?;
        entry(&mut map, "accel_time", self.accel_time.as_ref())?;
        entry(&mut map, "method", self.method.as_ref())?;
        entry(&mut map, "period", self.period.as_ref())?;
        entry(&mut map, "tolerance_mm", self.tolerance_mm.as_ref())?;
        entry(&mut map, "profile", self.profile.as_ref())?;
        entry(&mut map, "jerk_mm_s3", self.jerk_mm_s3.as_ref())?;
        map.end()
    }
}

/// A document's table that embeds an [`OrderMotion`], read key by key by [`read_table`].
pub(crate) trait Table: Default {
    /// Its name, as serde's messages give it (`MoveOrder`: "expected struct `MoveOrder`").
    const NAME: &'static str;
    /// Every key it takes, in the order it is written (the motion's among them).
    const KEYS: &'static [&'static str];
    /// The key that must be given, if any.
    const REQUIRED: Option<&'static str> = None;

    /// Reads the value of `key`, one of [`Self::KEYS`], from `map`.
    ///
    /// # Errors
    /// The value's error.
    fn read<'de, A: MapAccess<'de>>(&mut self, key: &str, map: &mut A) -> Result<(), A::Error>;
}

/// A table's keys in the order it writes them: `before`, the motion keys, then `after` (`N`
/// keys in all).
#[must_use]
pub(crate) const fn keys<const N: usize>(
    before: &[&'static str],
    after: &[&'static str],
) -> [&'static str; N] {
    let motion = &OrderMotion::KEYS;
    assert!(before.len() + motion.len() + after.len() == N);
    let mut out = [""; N];
    let mut i = 0;
    while i < N {
        out[i] = if i < before.len() {
            before[i]
        } else if i < before.len() + motion.len() {
            motion[i - before.len()]
        } else {
            after[i - before.len() - motion.len()]
        };
        i += 1;
    }
    out
}

/// Reads a [`Table`] as serde's derive with `deny_unknown_fields` reads a struct: an unknown
/// key, a key given twice or a required key left out is refused in serde's words.
///
/// # Errors
/// The deserializer's, naming the key.
pub(crate) fn read_table<'de, D: Deserializer<'de>, T: Table>(d: D) -> Result<T, D::Error> {
    d.deserialize_struct(T::NAME, T::KEYS, TableVisitor(PhantomData))
}

struct TableVisitor<T>(PhantomData<T>);

impl<'de, T: Table> Visitor<'de> for TableVisitor<T> {
    type Value = T;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "struct {}", T::NAME)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<T, A::Error> {
        let mut table = T::default();
        let mut seen: Vec<&'static str> = Vec::new();
        while let Some(key) = map.next_key_seed(Key(T::KEYS))? {
            if seen.contains(&key) {
                return Err(de::Error::duplicate_field(key));
            }
            seen.push(key);
            table.read(key, &mut map)?;
        }
        match T::REQUIRED {
            Some(key) if !seen.contains(&key) => Err(de::Error::missing_field(key)),
            _ => Ok(table),
        }
    }
}

/// A table's key, refused unless it is one of the keys given.
struct Key(&'static [&'static str]);

impl<'de> DeserializeSeed<'de> for Key {
    type Value = &'static str;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_identifier(self)
    }
}

impl Visitor<'_> for Key {
    type Value = &'static str;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("field identifier")
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Self::Value, E> {
        self.0
            .iter()
            .find(|k| **k == v)
            .copied()
            .ok_or_else(|| E::unknown_field(v, self.0))
    }
}

#[cfg(test)]
mod tests {
    use super::super::{MoveOrder, PathOrder};
    use super::OrderMotion;
    use serde::Deserialize;
    use serde::de::DeserializeOwned;

    /// The orders as serde's derive read them before the motion keys were one struct: every
    /// answer of the hand-written reading is checked against theirs, word for word.
    mod derived {
        use serde::Deserialize;

        #[derive(Debug, Default, Deserialize)]
        #[serde(deny_unknown_fields, default)]
        #[allow(dead_code)] // read only through Debug
        pub(super) struct MoveOrder {
            to: Option<Vec<f64>>,
            by: Option<Vec<f64>>,
            joints: Option<Vec<f64>>,
            position: Option<String>,
            speed_mm_s: Option<f64>,
            accel_time: Option<String>,
            method: Option<String>,
            period: Option<String>,
            tolerance_mm: Option<f64>,
            profile: Option<String>,
            jerk_mm_s3: Option<f64>,
            permit: Option<String>,
        }

        #[derive(Debug, Deserialize)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)] // read only through Debug
        pub(super) struct PathOrder {
            path: serde_json::Value,
            #[serde(default)]
            speed_mm_s: Option<f64>,
            #[serde(default)]
            accel_time: Option<String>,
            #[serde(default)]
            method: Option<String>,
            #[serde(default)]
            period: Option<String>,
            #[serde(default)]
            tolerance_mm: Option<f64>,
            #[serde(default)]
            profile: Option<String>,
            #[serde(default)]
            jerk_mm_s3: Option<f64>,
            #[serde(default)]
            permit: Option<String>,
        }
    }

    /// A JSON body's error as the API reads it: the path serde blames, and the words.
    fn api<T: DeserializeOwned>(body: &str) -> Result<(), (String, String)> {
        let mut de = serde_json::Deserializer::from_str(body);
        serde_path_to_error::deserialize::<_, T>(&mut de)
            .map(drop)
            .map_err(|e| (e.path().to_string(), e.inner().to_string()))
    }

    fn toml_words<T: DeserializeOwned>(text: &str) -> Result<(), String> {
        toml::from_str::<T>(text)
            .map(drop)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn a_move_order_is_refused_in_the_words_and_at_the_key_serdes_derive_refused_it() {
        let bodies = [
            r#"{"to":[1,2,3],"colour":1}"#,
            r#"{"to":[1,2,3],"speed_mm_s":"fast"}"#,
            r#"{"to":[1,2,3],"speed_mm_s":1,"speed_mm_s":2}"#,
            r#"{"to":[1,2,3],"permit":5}"#,
            r#"{"jerk_mm_s3":[1]}"#,
            r#"{"position":"pick","tolerance_mm":0.05,"profile":"s-curve","period":"1s"}"#,
            r#"{"speed_mm_s":null}"#,
            "[1,2,3]",
            "5",
            "{}",
        ];
        for body in bodies {
            let (ours, theirs) = (api::<MoveOrder>(body), api::<derived::MoveOrder>(body));
            if body.starts_with('[') {
                // serde's derive took a struct as a sequence of its fields; orders never are.
                assert!(ours.is_err(), "{body}");
                continue;
            }
            assert_eq!(ours, theirs, "{body}");
        }
        let tables = [
            "to = [1, 2, 3]\nsped_mm_s = 3\n",
            "to = [1, 2, 3]\nspeed_mm_s = \"fast\"\n",
            "to = [1, 2, 3]\nspeed_mm_s = 300\naccel_time = \"0s\"\n",
        ];
        for text in tables {
            assert_eq!(
                toml_words::<MoveOrder>(text),
                toml_words::<derived::MoveOrder>(text),
                "{text}"
            );
        }
    }

    #[test]
    fn a_path_order_is_refused_as_before_and_needs_its_path() {
        for body in [
            r#"{"speed_mm_s":100}"#,
            r#"{"path":{},"colour":1}"#,
            r#"{"path":{},"method":7}"#,
            r#"{"path":{"element":[]},"period":"20ms","permit":"X5"}"#,
        ] {
            assert_eq!(
                api::<PathOrder>(body),
                api::<derived::PathOrder>(body),
                "{body}"
            );
        }
    }

    #[test]
    fn the_motion_keys_read_are_the_ones_written_and_serialized_back_in_order() {
        let body = r#"{"to":[1.0,2.0,3.0],"speed_mm_s":120.0,"accel_time":"200ms","method":"bounded-error","period":"20ms","tolerance_mm":0.05,"profile":"s-curve","jerk_mm_s3":20000.0,"permit":"X5"}"#;
        let order: MoveOrder = serde_json::from_str(body).unwrap();
        assert_eq!(
            order.motion,
            OrderMotion {
                speed_mm_s: Some(120.0),
                accel_time: Some("200ms".into()),
                method: Some("bounded-error".into()),
                period: Some("20ms".into()),
                tolerance_mm: Some(0.05),
                profile: Some("s-curve".into()),
                jerk_mm_s3: Some(20000.0),
            }
        );
        assert_eq!(serde_json::to_string(&order).unwrap(), body);
        let path = PathOrder::deserialize(serde_json::json!({"path": {}, "period": "20ms"}));
        assert_eq!(
            serde_json::to_string(&path.unwrap()).unwrap(),
            r#"{"path":{},"period":"20ms"}"#
        );
    }
}
