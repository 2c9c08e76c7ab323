//! PURE. The cell as it runs: each model's state, stepped once a scan with the time and what the
//! PLC shows (its bits, its channels' counts), giving back the inputs the cell drives; and the
//! inputs an operator forces, which win over every model until released.
//!
//! ```text
//!  press   open --go rises--> stroke (moving) --stroke_s--> settle (closed, still)
//!          --settle_s--> open                    open = phase is open, moving = phase is stroke
//!  stack   present = parts > 0; each rise of `take` takes one part
//!  sensor  input = the condition (or the count range), once it has held for delay_s
//!  constant
//! ```

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::contract::CHANNELS;
use crate::gateway::{Address, Area};

use super::description::{Description, Follows, Model, Press, Sensor, Stack};

/// What a scan shows the cell: the PLC's bits and its channels' counts.
pub struct Seen<'a> {
    /// Reads an X, Y or R bit as it stands.
    pub bit: &'a dyn Fn(Address) -> bool,
    /// Each channel's pulse count.
    pub counts: [i64; CHANNELS],
}

/// Where a press is in its stroke.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Open,
    Stroke { until_s: f64 },
    Settle { until_s: f64 },
}

/// One model and its state.
#[derive(Debug, Clone, PartialEq)]
enum Unit {
    Press {
        press: Press,
        phase: Phase,
        go_was: bool,
        strokes: u64,
    },
    Stack {
        stack: Stack,
        parts: u32,
        take_was: bool,
    },
    Sensor {
        sensor: Sensor,
        on: bool,
        /// Since when the followed value differs from `on`.
        differs_since_s: Option<f64>,
    },
    Constant {
        input: Address,
        on: bool,
    },
}

/// Why an input cannot be forced.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{target:?}: {reason}")]
pub struct ForceError {
    /// What was named.
    pub target: String,
    /// Why not.
    pub reason: String,
}

/// A cell running on the mock.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Cell {
    description: Description,
    units: Vec<Unit>,
    forced: BTreeMap<Address, bool>,
    /// Inputs released from a force that no model drives: set off once (their wiring is open).
    released: Vec<Address>,
}

impl Cell {
    /// A cell at rest: presses open, stacks full, sensors and constants off until the first step.
    #[must_use]
    pub fn new(description: Description) -> Self {
        let units = description
            .models
            .iter()
            .cloned()
            .map(|model| match model {
                Model::Press(press) => Unit::Press {
                    press,
                    phase: Phase::Open,
                    go_was: false,
                    strokes: 0,
                },
                Model::Stack(stack) => Unit::Stack {
                    parts: stack.parts,
                    stack,
                    take_was: false,
                },
                Model::Sensor(sensor) => Unit::Sensor {
                    sensor,
                    on: false,
                    differs_since_s: None,
                },
                Model::Constant { input, on } => Unit::Constant { input, on },
            })
            .collect();
        Self {
            description,
            units,
            forced: BTreeMap::new(),
            released: Vec::new(),
        }
    }

    /// The description it runs.
    #[must_use]
    pub fn description(&self) -> &Description {
        &self.description
    }

    /// Whether stepping it can change anything (no model, nothing forced or released: no).
    #[must_use]
    pub fn is_idle(&self) -> bool {
        self.units.is_empty() && self.forced.is_empty() && self.released.is_empty()
    }

    /// One step at `now_s`: every model advanced on what the PLC shows, then the inputs the cell
    /// drives now (forced ones as forced), each with its value.
    pub fn step(&mut self, now_s: f64, seen: &Seen<'_>) -> Vec<(Address, bool)> {
        let mut out: Vec<(Address, bool)> = self.released.drain(..).map(|a| (a, false)).collect();
        for unit in &mut self.units {
            unit.step(now_s, seen, &mut out);
        }
        out.retain(|(a, _)| !self.forced.contains_key(a));
        out.extend(self.forced.iter().map(|(a, on)| (*a, *on)));
        out
    }

    /// Forces `target` (a signal's name or an X or R address) on or off until released.
    pub fn force(&mut self, target: &str, on: bool) -> Result<Address, ForceError> {
        let address = self.input(target)?;
        self.forced.insert(address, on);
        Ok(address)
    }

    /// Releases a forced input: its model (if one drives it) takes it back, else it goes off.
    pub fn release(&mut self, target: &str) -> Result<Address, ForceError> {
        let address = self.input(target)?;
        if self.forced.remove(&address).is_none() {
            return Err(ForceError {
                target: target.to_owned(),
                reason: format!("{address} is not forced"),
            });
        }
        self.released_now(address);
        Ok(address)
    }

    /// Releases every forced input.
    pub fn release_all(&mut self) -> Vec<Address> {
        let released: Vec<Address> = std::mem::take(&mut self.forced).into_keys().collect();
        for a in &released {
            self.released_now(*a);
        }
        released
    }

    fn released_now(&mut self, address: Address) {
        let driven = self.description.driven().iter().any(|(a, _)| *a == address);
        if !driven {
            self.released.push(address);
        }
    }

    /// The inputs forced now.
    #[must_use]
    pub fn forced(&self) -> &BTreeMap<Address, bool> {
        &self.forced
    }

    /// An input an operator may force: a signal's name or an X or R bit.
    fn input(&self, target: &str) -> Result<Address, ForceError> {
        let refuse = |reason: String| ForceError {
            target: target.to_owned(),
            reason,
        };
        let address = self
            .description
            .resolve("force", target)
            .map_err(|e| refuse(e.to_string()))?;
        match address.area {
            Area::X | Area::R => Ok(address),
            _ => Err(refuse(format!(
                "{address} is an output, the robot's: only X inputs and R relays are forced"
            ))),
        }
    }

    /// The cell in one line: each model's state and what is forced.
    #[must_use]
    pub fn describe(&self) -> String {
        let mut parts: Vec<String> = Vec::new();
        let (mut presses, mut stacks) = (0, 0);
        for unit in &self.units {
            match unit {
                Unit::Press { phase, strokes, .. } => {
                    let state = match phase {
                        Phase::Open => "open",
                        Phase::Stroke { .. } => "stroking",
                        Phase::Settle { .. } => "closed, settling",
                    };
                    parts.push(format!("press[{presses}] {state}, {strokes} strokes"));
                    presses += 1;
                }
                Unit::Stack {
                    stack, parts: n, ..
                } => {
                    parts.push(format!("stack[{stacks}] {n} of {} parts", stack.parts));
                    stacks += 1;
                }
                Unit::Sensor { .. } | Unit::Constant { .. } => {}
            }
        }
        let mut text = if parts.is_empty() {
            "no models".to_owned()
        } else {
            parts.join("; ")
        };
        if !self.forced.is_empty() {
            let forced: Vec<String> = self
                .forced
                .iter()
                .map(|(a, on)| format!("{a} {}", if *on { "on" } else { "off" }))
                .collect();
            let _ = write!(text, "; forced: {}", forced.join(", "));
        }
        text
    }
}

impl Unit {
    fn step(&mut self, now_s: f64, seen: &Seen<'_>, out: &mut Vec<(Address, bool)>) {
        match self {
            Self::Press {
                press,
                phase,
                go_was,
                strokes,
            } => {
                let go = (seen.bit)(press.go);
                if *phase == Phase::Open && go && !*go_was {
                    begin_stroke(press, phase, strokes, now_s);
                }
                *go_was = go;
                *phase = settled(*phase, press, now_s);
                out.extend(press_inputs(press, *phase));
            }
            Self::Stack {
                stack,
                parts,
                take_was,
            } => {
                let take = (seen.bit)(stack.take);
                if take && !*take_was {
                    *parts = parts.saturating_sub(1);
                }
                *take_was = take;
                out.push((stack.present, *parts > 0));
            }
            Self::Sensor {
                sensor,
                on,
                differs_since_s,
            } => {
                let now_on = follows(&sensor.follows, seen);
                debounce(now_on, on, differs_since_s, sensor.delay_s, now_s);
                out.push((sensor.input, *on));
            }
            Self::Constant { input, on } => out.push((*input, *on)),
        }
    }
}

/// A press's stroke begun at `now_s`, counted.
fn begin_stroke(press: &Press, phase: &mut Phase, strokes: &mut u64, now_s: f64) {
    *phase = Phase::Stroke {
        until_s: now_s + press.stroke_s,
    };
    *strokes += 1;
}

/// What a press in `phase` tells the PLC: open, moving (each if wired).
fn press_inputs(press: &Press, phase: Phase) -> impl Iterator<Item = (Address, bool)> {
    let open = press.open.map(|a| (a, phase == Phase::Open));
    let moving = press
        .moving
        .map(|a| (a, matches!(phase, Phase::Stroke { .. })));
    open.into_iter().chain(moving)
}

/// A sensor's output `on` following `now_on` once it has differed for `delay_s`, since
/// `differs_since_s`.
fn debounce(
    now_on: bool,
    on: &mut bool,
    differs_since_s: &mut Option<f64>,
    delay_s: f64,
    now_s: f64,
) {
    if now_on == *on {
        *differs_since_s = None;
    } else {
        let since = *differs_since_s.get_or_insert(now_s);
        if now_s - since >= delay_s {
            *on = now_on;
            *differs_since_s = None;
        }
    }
}

/// The phase after the stroke and settle times that ran out by `now_s`.
fn settled(mut phase: Phase, press: &Press, now_s: f64) -> Phase {
    loop {
        phase = match phase {
            Phase::Stroke { until_s } if now_s >= until_s => Phase::Settle {
                until_s: until_s + press.settle_s,
            },
            Phase::Settle { until_s } if now_s >= until_s => Phase::Open,
            other => return other,
        };
    }
}

fn follows(follows: &Follows, seen: &Seen<'_>) -> bool {
    match follows {
        Follows::Condition(when) => when.holds(seen.bit),
        Follows::Position { channel, min, max } => (*min..=*max).contains(&seen.counts[*channel]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;

    const PRESS: &str = include_str!("../../../config/examples/cells/press.toml");

    /// A world of bits the test sets, stepping the cell and keeping what it drives.
    struct World {
        cell: Cell,
        bits: RefCell<BTreeMap<Address, bool>>,
        counts: [i64; CHANNELS],
    }

    impl World {
        fn new(text: &str) -> Self {
            Self {
                cell: Cell::new(Description::from_toml(text).unwrap()),
                bits: RefCell::default(),
                counts: [0; CHANNELS],
            }
        }

        fn set(&self, name: &str, on: bool) {
            let a = self.cell.description().resolve("test", name).unwrap();
            self.bits.borrow_mut().insert(a, on);
        }

        fn get(&self, name: &str) -> bool {
            let a = self.cell.description().resolve("test", name).unwrap();
            self.bits.borrow().get(&a).copied().unwrap_or(false)
        }

        fn step(&mut self, now_s: f64) {
            let bits = self.bits.borrow().clone();
            let read = move |a: Address| bits.get(&a).copied().unwrap_or(false);
            let seen = Seen {
                bit: &read,
                counts: self.counts,
            };
            for (a, on) in self.cell.step(now_s, &seen) {
                self.bits.borrow_mut().insert(a, on);
            }
        }
    }

    #[test]
    fn the_press_strokes_on_a_rising_go_then_settles_and_opens() {
        let mut w = World::new(PRESS);
        w.step(0.0);
        assert!(w.get("press_open") && !w.get("press_moving"));
        w.set("press_go", true);
        w.step(1.0);
        assert!(!w.get("press_open") && w.get("press_moving"), "stroking");
        w.set("press_go", false);
        w.step(1.79);
        assert!(w.get("press_moving"));
        w.step(1.8);
        assert!(!w.get("press_open") && !w.get("press_moving"), "settling");
        w.step(2.0);
        assert!(w.get("press_open") && !w.get("press_moving"), "open again");
        assert!(w.cell.describe().starts_with("press[0] open, 1 strokes"));
    }

    #[test]
    fn a_go_held_on_strokes_once_and_a_step_late_runs_every_phase_out() {
        let mut w = World::new(PRESS);
        w.set("press_go", true);
        w.step(0.0);
        assert!(w.get("press_moving"));
        w.step(5.0);
        assert!(
            w.get("press_open") && !w.get("press_moving"),
            "one stroke only"
        );
        w.set("press_go", false);
        w.step(5.1);
        w.set("press_go", true);
        w.step(5.2);
        assert!(w.get("press_moving"), "a new rise, a new stroke");
    }

    #[test]
    fn the_stack_empties_one_part_per_rise_of_the_gripper() {
        let text = "[signals]\npart_present = \"X2\"\ngripper = \"Y1\"\n\
                    [[stack]]\npresent = \"part_present\"\ntake = \"gripper\"\nparts = 2\n";
        let mut w = World::new(text);
        w.step(0.0);
        assert!(w.get("part_present"));
        for t in [1.0, 2.0] {
            w.set("gripper", true);
            w.step(t);
            w.step(t + 0.1);
            w.set("gripper", false);
            w.step(t + 0.2);
        }
        assert!(!w.get("part_present"), "empty after two takes");
        assert_eq!(w.cell.describe(), "stack[0] 0 of 2 parts");
    }

    #[test]
    fn a_sensor_follows_its_condition_or_a_count_range_after_its_delay() {
        let text = "[[sensor]]\ninput = \"X7\"\nwhen = \"Y1 & !X6\"\ndelay = \"100ms\"\n\
                    [[sensor]]\ninput = \"X8\"\nchannel = 2\ncounts = [100, 200]\n";
        let mut w = World::new(text);
        w.set("Y1", true);
        w.step(0.0);
        assert!(!w.get("X7"), "not before its delay");
        w.step(0.05);
        assert!(!w.get("X7"));
        w.step(0.1);
        assert!(w.get("X7"));
        assert!(!w.get("X8"));
        w.counts[2] = 150;
        w.step(0.2);
        assert!(w.get("X8"));
    }

    #[test]
    fn a_forced_input_wins_over_its_model_until_released() {
        let mut w = World::new(PRESS);
        w.step(0.0);
        assert_eq!(w.cell.force("press_open", false).unwrap().to_string(), "X5");
        w.step(0.1);
        assert!(!w.get("press_open"));
        assert!(w.cell.describe().ends_with("forced: X5 off"));
        w.cell.force("X7", true).unwrap();
        w.step(0.2);
        assert!(w.get("X7"));
        w.cell.release("press_open").unwrap();
        assert_eq!(w.cell.release_all().len(), 1);
        w.step(0.3);
        assert!(w.get("press_open"), "the press model has it back");
        assert!(!w.get("X7"), "an input no model drives goes off");
        let e = w.cell.force("press_go", true).unwrap_err().to_string();
        assert!(e.contains("Y0 is an output, the robot's"), "{e}");
        let e = w.cell.release("X7").unwrap_err().to_string();
        assert_eq!(e, "\"X7\": X7 is not forced");
        let e = w.cell.force("presss_open", true).unwrap_err().to_string();
        assert!(e.contains("is neither a signal (gripper,"), "{e}");
    }
}
