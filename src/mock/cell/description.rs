//! PURE. A cell description: the TOML a user writes (`config/examples/cells/press.toml`), read
//! strictly (every key known, serde's path to a bad one) and then checked into a
//! [`Description`], naming the key and the value at fault.
//!
//! ```toml
//! [signals]                 # names for bits, as a robot's [robots.NAME.cell] signals
//! press_open = "X5"
//! press_go = "Y0"
//! [[press]]                 # a stroke on each rise of `go` while open: moving `stroke`,
//! go = "press_go"           # still and closed `settle` more, then open again
//! open = "press_open"
//! moving = "press_moving"
//! stroke = "800ms"
//! settle = "200ms"
//! [[stack]]                 # `present` while parts are left; each rise of `take` takes one
//! present = "part_present"
//! take = "gripper"
//! parts = 1000
//! [[sensor]]                # an input following a condition (or a channel's count range),
//! input = "X7"              # `delay` later
//! when = "gripper & !press_go"
//! [constants]               # inputs held on or off
//! guard_closed = true
//! ```

use std::collections::BTreeMap;
use std::fmt;

use serde::Deserialize;
use thiserror::Error;

use crate::config::parse_duration_s;
use crate::contract::CHANNELS;
use crate::gateway::{Address, Area};
use crate::mock::{IO_WORDS, RELAY_WORDS};

use super::when::When;

/// The longest a stroke, a settle or a delay may be, s.
pub const MAX_DURATION_S: f64 = 3600.0;
/// The most parts a stack may hold.
pub const MAX_PARTS: u32 = 1_000_000;
/// The most models a description may have, of all kinds.
pub const MAX_MODELS: usize = 256;

/// Why a cell description cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CellError {
    /// Not TOML, or a key or type the description does not have.
    #[error("line {line}: {}{message}", if key.is_empty() { String::new() } else { format!("{key}: ") })]
    Syntax {
        /// The 1-based line of the offending text.
        line: usize,
        /// The key path (`press[0].stroke`), empty when there is none.
        key: String,
        /// The parser's message, with the nearest valid key when one is near.
        message: String,
    },
    /// A value the mock cannot use.
    #[error("{key} = {value}: {reason}")]
    Invalid {
        /// The key path (`press[0].stroke`).
        key: String,
        /// The value as written.
        value: String,
        /// What is wrong, with the limit.
        reason: String,
    },
}

fn invalid(key: &str, value: impl fmt::Debug, reason: impl Into<String>) -> CellError {
    CellError::Invalid {
        key: key.to_owned(),
        value: format!("{value:?}"),
        reason: reason.into(),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCell {
    description: Option<String>,
    #[serde(default)]
    signals: BTreeMap<String, String>,
    #[serde(default)]
    press: Vec<RawPress>,
    #[serde(default)]
    stack: Vec<RawStack>,
    #[serde(default)]
    sensor: Vec<RawSensor>,
    #[serde(default)]
    constants: BTreeMap<String, bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPress {
    go: String,
    open: Option<String>,
    moving: Option<String>,
    stroke: String,
    settle: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStack {
    present: String,
    take: String,
    parts: i64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSensor {
    input: String,
    when: Option<String>,
    channel: Option<i64>,
    counts: Option<[i64; 2]>,
    delay: Option<String>,
}

/// A press: a stroke begins when `go` rises while it is open.
#[derive(Debug, Clone, PartialEq)]
pub struct Press {
    /// The output that starts a stroke on its rising edge.
    pub go: Address,
    /// The input on while the press is open.
    pub open: Option<Address>,
    /// The input on while the press strokes.
    pub moving: Option<Address>,
    /// How long a stroke takes (closed, moving), s.
    pub stroke_s: f64,
    /// How long it stays closed and still after a stroke, s.
    pub settle_s: f64,
}

/// A stack of parts: `present` while parts are left.
#[derive(Debug, Clone, PartialEq)]
pub struct Stack {
    /// The input on while parts are left.
    pub present: Address,
    /// The output whose rising edge takes one part.
    pub take: Address,
    /// Parts at the start.
    pub parts: u32,
}

/// What a sensor's input follows.
#[derive(Debug, Clone, PartialEq)]
pub enum Follows {
    /// A condition on bits.
    Condition(When),
    /// A channel's pulse count inside `min..=max` (a joint's position).
    Position {
        /// The channel, 0..=3.
        channel: usize,
        /// The lowest count that turns it on.
        min: i64,
        /// The highest.
        max: i64,
    },
}

/// An input that follows a condition or a position, `delay_s` later.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// The input.
    pub input: Address,
    /// What it follows.
    pub follows: Follows,
    /// How long the condition must hold (or stop holding) before the input follows, s.
    pub delay_s: f64,
}

/// One model of the cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Model {
    /// A press.
    Press(Press),
    /// A stack of parts.
    Stack(Stack),
    /// A sensor.
    Sensor(Sensor),
    /// An input held on or off.
    Constant {
        /// The input.
        input: Address,
        /// Its value.
        on: bool,
    },
}

/// A checked cell description.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Description {
    /// What it describes, as written.
    pub description: Option<String>,
    /// Its signals' names.
    pub signals: BTreeMap<String, Address>,
    /// Its models, in the file's order (presses, stacks, sensors, constants).
    pub models: Vec<Model>,
}

impl Description {
    /// Reads and checks a description's text.
    pub fn from_toml(text: &str) -> Result<Self, CellError> {
        let raw = parse(text)?;
        check(raw)
    }

    /// The address a signal name or an address text stands for.
    pub fn resolve(&self, key: &str, text: &str) -> Result<Address, CellError> {
        bit_of(key, text, &self.signals)
    }

    /// The inputs the models drive, each with the key that drives it.
    #[must_use]
    pub fn driven(&self) -> Vec<(Address, String)> {
        let mut out = Vec::new();
        let (mut presses, mut stacks, mut sensors) = (0, 0, 0);
        for model in &self.models {
            match model {
                Model::Press(p) => {
                    let at = format!("press[{presses}]");
                    out.extend(p.open.map(|a| (a, format!("{at}.open"))));
                    out.extend(p.moving.map(|a| (a, format!("{at}.moving"))));
                    presses += 1;
                }
                Model::Stack(s) => {
                    out.push((s.present, format!("stack[{stacks}].present")));
                    stacks += 1;
                }
                Model::Sensor(s) => {
                    out.push((s.input, format!("sensor[{sensors}].input")));
                    sensors += 1;
                }
                Model::Constant { input, .. } => out.push((*input, format!("constants.{input}"))),
            }
        }
        out
    }
}

/// The text through serde, strictly: a syntax error or a bad key named by its path and line.
fn parse(text: &str) -> Result<RawCell, CellError> {
    let syntax = |e: &toml::de::Error, key: String| {
        let line = e.span().map_or(1, |s| line_of(text, s.start));
        let message = e.message().trim_end().to_owned();
        let message = match crate::config::suggest::hint(&message) {
            Some(hint) => format!("{message}; {hint}"),
            None => message,
        };
        CellError::Syntax { line, key, message }
    };
    let de = toml::Deserializer::parse(text).map_err(|e| syntax(&e, String::new()))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        let key = if key == "." { String::new() } else { key };
        syntax(e.inner(), key)
    })
}

fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end].split(|&b| b == b'\n').count()
}

fn check(raw: RawCell) -> Result<Description, CellError> {
    let mut signals = BTreeMap::new();
    for (name, text) in &raw.signals {
        let key = format!("signals.{name}");
        if !is_name(name) {
            return Err(invalid(
                &key,
                text,
                "a signal's name is letters, digits and _, starting with a letter",
            ));
        }
        signals.insert(name.clone(), address(&key, text)?);
    }
    let count = raw.press.len() + raw.stack.len() + raw.sensor.len() + raw.constants.len();
    if count > MAX_MODELS {
        return Err(invalid(
            "press, stack, sensor, constants",
            count,
            format!("at most {MAX_MODELS} models in all"),
        ));
    }
    let mut models = Vec::with_capacity(count);
    for (i, p) in raw.press.iter().enumerate() {
        models.push(Model::Press(press(&format!("press[{i}]"), p, &signals)?));
    }
    for (i, s) in raw.stack.iter().enumerate() {
        models.push(Model::Stack(stack(&format!("stack[{i}]"), s, &signals)?));
    }
    for (i, s) in raw.sensor.iter().enumerate() {
        models.push(Model::Sensor(sensor(&format!("sensor[{i}]"), s, &signals)?));
    }
    for (name, on) in &raw.constants {
        let input = input(&format!("constants.{name}"), name, &signals)?;
        models.push(Model::Constant { input, on: *on });
    }
    let description = Description {
        description: raw.description,
        signals,
        models,
    };
    one_driver_each(&description)?;
    Ok(description)
}

fn is_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// An X, Y or R bit that the mock has.
fn address(key: &str, text: &str) -> Result<Address, CellError> {
    let a: Address = text
        .parse()
        .map_err(|e: crate::gateway::AddressError| invalid(key, text, e.reason))?;
    let words = match a.area {
        Area::Dt => {
            return Err(invalid(
                key,
                text,
                "must be an X, Y or R bit, not a DT word",
            ));
        }
        Area::X | Area::Y => u32::from(IO_WORDS),
        Area::R => u32::from(RELAY_WORDS),
    };
    if a.index / 16 >= words {
        return Err(invalid(
            key,
            text,
            format!(
                "the mock has {area}0..={area}{last}F",
                area = a.area.name(),
                last = words - 1
            ),
        ));
    }
    Ok(a)
}

/// A signal's name or an address: the bit it stands for.
fn bit_of(
    key: &str,
    text: &str,
    signals: &BTreeMap<String, Address>,
) -> Result<Address, CellError> {
    if let Some(a) = signals.get(text) {
        return Ok(*a);
    }
    address(key, text).map_err(|e| match e {
        CellError::Invalid { reason, .. } if text.parse::<Address>().is_err() => {
            let names: Vec<&str> = signals.keys().map(String::as_str).collect();
            invalid(
                key,
                text,
                format!(
                    "is neither a signal ({}) nor an X, Y or R bit: {reason}",
                    if names.is_empty() {
                        "none named".to_owned()
                    } else {
                        names.join(", ")
                    }
                ),
            )
        }
        other => other,
    })
}

/// A bit a model drives: an X input or an R relay (a Y output is the robot's).
fn input(key: &str, text: &str, signals: &BTreeMap<String, Address>) -> Result<Address, CellError> {
    let a = bit_of(key, text, signals)?;
    if a.area == Area::Y {
        return Err(invalid(
            key,
            text,
            format!("{a} is an output, the robot's; a cell model drives X inputs or R relays"),
        ));
    }
    Ok(a)
}

fn duration(key: &str, text: &str, min_s: f64) -> Result<f64, CellError> {
    let s = parse_duration_s(text).map_err(|e| invalid(key, text, e.problem.to_string()))?;
    if s < min_s || s > MAX_DURATION_S || (min_s > 0.0 && s == 0.0) {
        let at_least = if min_s > 0.0 {
            "above 0 s"
        } else {
            "at least 0 s"
        };
        return Err(invalid(
            key,
            text,
            format!("must be {at_least} and at most {MAX_DURATION_S} s"),
        ));
    }
    Ok(s)
}

fn press(at: &str, p: &RawPress, signals: &BTreeMap<String, Address>) -> Result<Press, CellError> {
    let key = |k: &str| format!("{at}.{k}");
    let optional = |k: &str, v: &Option<String>| {
        v.as_deref()
            .map(|text| input(&key(k), text, signals))
            .transpose()
    };
    let (open, moving) = (optional("open", &p.open)?, optional("moving", &p.moving)?);
    if open.is_none() && moving.is_none() {
        return Err(invalid(
            at,
            "{ go }",
            "a press needs `open` or `moving` (or both): the inputs it drives",
        ));
    }
    Ok(Press {
        go: bit_of(&key("go"), &p.go, signals)?,
        open,
        moving,
        stroke_s: duration(&key("stroke"), &p.stroke, f64::MIN_POSITIVE)?,
        settle_s: p
            .settle
            .as_deref()
            .map_or(Ok(0.0), |t| duration(&key("settle"), t, 0.0))?,
    })
}

fn stack(at: &str, s: &RawStack, signals: &BTreeMap<String, Address>) -> Result<Stack, CellError> {
    let parts = u32::try_from(s.parts)
        .ok()
        .filter(|&p| p <= MAX_PARTS)
        .ok_or_else(|| {
            invalid(
                &format!("{at}.parts"),
                s.parts,
                format!("must be within 0..={MAX_PARTS}"),
            )
        })?;
    Ok(Stack {
        present: input(&format!("{at}.present"), &s.present, signals)?,
        take: bit_of(&format!("{at}.take"), &s.take, signals)?,
        parts,
    })
}

/// A sensor at `at` that is on while channel `channel`'s count is within `counts`.
fn position(at: &str, channel: i64, [min, max]: [i64; 2]) -> Result<Follows, CellError> {
    let channel = usize::try_from(channel)
        .ok()
        .filter(|&c| c < CHANNELS)
        .ok_or_else(|| {
            invalid(
                &format!("{at}.channel"),
                channel,
                format!("must be within 0..={}", CHANNELS - 1),
            )
        })?;
    if min > max {
        return Err(invalid(
            &format!("{at}.counts"),
            [min, max],
            "is [lowest, highest]: the first must not be above the second",
        ));
    }
    Ok(Follows::Position { channel, min, max })
}

fn sensor(
    at: &str,
    s: &RawSensor,
    signals: &BTreeMap<String, Address>,
) -> Result<Sensor, CellError> {
    let key = |k: &str| format!("{at}.{k}");
    let follows = match (&s.when, s.channel, s.counts) {
        (Some(text), None, None) => Follows::Condition(
            When::parse(text, &|name| bit_of(&key("when"), name, signals).ok())
                .map_err(|reason| invalid(&key("when"), text, reason.to_string()))?,
        ),
        (None, Some(channel), Some(counts)) => position(at, channel, counts)?,
        _ => {
            return Err(invalid(
                at,
                format!("input = {:?}", s.input),
                "a sensor follows either `when` (a condition) or `channel` and `counts` (a \
                 position), one of them",
            ));
        }
    };
    Ok(Sensor {
        input: input(&key("input"), &s.input, signals)?,
        follows,
        delay_s: s
            .delay
            .as_deref()
            .map_or(Ok(0.0), |t| duration(&key("delay"), t, 0.0))?,
    })
}

/// No input driven by two models.
fn one_driver_each(d: &Description) -> Result<(), CellError> {
    let mut seen: BTreeMap<Address, String> = BTreeMap::new();
    for (address, key) in d.driven() {
        if let Some(first) = seen.insert(address, key.clone()) {
            return Err(invalid(
                &key,
                address.to_string(),
                format!("{address} is driven by {first} already: one model drives an input"),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const PRESS: &str = include_str!("../../../config/examples/cells/press.toml");

    fn err(text: &str) -> String {
        Description::from_toml(text).unwrap_err().to_string()
    }

    #[test]
    fn the_shipped_press_cell_reads_as_a_press_and_a_stack() {
        let d = Description::from_toml(PRESS).unwrap();
        let x = |i| Address {
            area: Area::X,
            index: i,
        };
        let y = |i| Address {
            area: Area::Y,
            index: i,
        };
        assert_eq!(d.signals["press_open"], x(5));
        assert_eq!(d.signals["gripper"], y(1));
        let [Model::Press(p), Model::Stack(s)] = d.models.as_slice() else {
            panic!("{:?}", d.models)
        };
        assert_eq!((p.go, p.open, p.moving), (y(0), Some(x(5)), Some(x(6))));
        assert!((p.stroke_s - 0.8).abs() < 1e-12 && (p.settle_s - 0.2).abs() < 1e-12);
        assert_eq!((s.present, s.take), (x(2), y(1)));
    }

    #[test]
    fn a_misspelt_key_is_named_by_its_path_with_the_nearest_valid_one() {
        let e = err("[[press]]\ngo = \"Y0\"\nopen = \"X5\"\nstrok = \"1s\"\n");
        assert!(
            e.starts_with("line 4: press[0].strok: unknown field `strok`")
                && e.ends_with("did you mean `stroke`?"),
            "{e}"
        );
        let e = err("[[stack]]\npresent = \"X2\"\ntake = \"Y1\"\nparts = \"many\"\n");
        assert!(e.contains("stack[0].parts: invalid type: string"), "{e}");
        let e = err("[press]\n");
        assert!(e.contains("press: invalid type"), "{e}");
    }

    #[test]
    fn bad_values_name_the_key_the_value_and_the_limit() {
        let cases = [
            (
                "[[press]]\ngo = \"Y0\"\nopen = \"X5\"\nstroke = \"0s\"\n",
                "press[0].stroke = \"0s\": must be above 0 s and at most 3600 s",
            ),
            (
                "[[press]]\ngo = \"Y0\"\nopen = \"X5\"\nstroke = \"8oo ms\"\n",
                "press[0].stroke = \"8oo ms\": \"8oo\" is not a number",
            ),
            (
                "[[press]]\ngo = \"Y0\"\nstroke = \"1s\"\n",
                "press[0] = \"{ go }\": a press needs `open` or `moving`",
            ),
            (
                "[[stack]]\npresent = \"X2\"\ntake = \"Y1\"\nparts = -1\n",
                "stack[0].parts = -1: must be within 0..=1000000",
            ),
            (
                "[[stack]]\npresent = \"Y2\"\ntake = \"Y1\"\nparts = 1\n",
                "stack[0].present = \"Y2\": Y2 is an output, the robot's",
            ),
            (
                "[signals]\nopen = \"X1100\"\n",
                "signals.open = \"X1100\": the mock has X0..=X109F",
            ),
            (
                "[signals]\nopen = \"DT5\"\n",
                "signals.open = \"DT5\": must be an X, Y or R bit, not a DT word",
            ),
            (
                "[[sensor]]\ninput = \"X7\"\nchannel = 4\ncounts = [0, 1]\n",
                "sensor[0].channel = 4: must be within 0..=3",
            ),
            (
                "[[sensor]]\ninput = \"X7\"\nwhen = \"gripper\"\n",
                "sensor[0].when = \"gripper\": \"gripper\" is neither a signal nor a bit",
            ),
            (
                "[[sensor]]\ninput = \"X7\"\n",
                "a sensor follows either `when` (a condition) or `channel` and `counts`",
            ),
            (
                "[[stack]]\npresent = \"press_opn\"\ntake = \"Y1\"\nparts = 1\n",
                "stack[0].present = \"press_opn\": is neither a signal (none named) nor an X, Y \
                 or R bit",
            ),
        ];
        for (text, message) in cases {
            let e = err(text);
            assert!(e.contains(message), "{e}\n  wanted: {message}");
        }
    }

    #[test]
    fn an_input_driven_twice_names_both_drivers() {
        let text = "[[press]]\ngo = \"Y0\"\nopen = \"X5\"\nstroke = \"1s\"\n\
                    [constants]\nX5 = true\n";
        assert_eq!(
            err(text),
            "constants.X5 = \"X5\": X5 is driven by press[0].open already: one model drives an \
             input"
        );
    }
}
