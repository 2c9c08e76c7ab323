//! Fault injection, seeded and scriptable. A [`FaultScript`] says what goes wrong and when; a
//! [`FaultInjector`] plays it. Link-level faults (drop, corrupt, delay, close, an error reply) are
//! handed to the servers as "what to do with command number k"; the core applies the rest
//! (freeze the heartbeat, PROG mode) itself.
//!
//! The compact text form, items separated by commas:
//! ```text
//! seed=7                     seed of the random draws (default 0)
//! ACTION@K                   at command number K (the first command a server sees is 1)
//! ACTION@t=S                 at S seconds since the mock started (core actions only)
//! ACTION@P%                  on each command with probability P percent (link actions only)
//!
//! link actions: drop  corrupt  close  delay<ms>  error<NN> (MEWTOCOL)  exception<N> (Modbus)
//! core actions: freeze  thaw  (the heartbeat)  prog  run  (the mode)  restart (a power cycle:
//!               counts 0, homed bit clear, first scan)
//! e.g. drop@3,corrupt@5,error61@7,prog@12,freeze@t=0.5,restart@t=2,seed=7,corrupt@1%
//! ```

use std::str::FromStr;

use thiserror::Error;

/// What a server does with one command's reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkFault {
    /// Send no reply.
    Drop,
    /// Flip bits of one reply byte: `reply[position % len] ^= xor` (`xor` is never 0).
    Corrupt {
        /// Which byte, modulo the reply's length.
        position: u64,
        /// The bits to flip.
        xor: u8,
    },
    /// Hold the reply back this long.
    Delay {
        /// Delay, ms.
        ms: u64,
    },
    /// Close the connection instead of answering.
    Close,
    /// Answer with this MEWTOCOL-COM error code (a Modbus server answers exception 04).
    MewtocolError {
        /// Two-digit error code.
        code: u8,
    },
    /// Answer with this Modbus exception (a MEWTOCOL server answers error 60).
    ModbusException {
        /// Exception code.
        code: u8,
    },
}

impl LinkFault {
    /// Applies a [`LinkFault::Corrupt`] to a reply; other faults leave it alone.
    pub fn corrupt_in_place(&self, reply: &mut [u8]) {
        if let Self::Corrupt { position, xor } = *self
            && !reply.is_empty()
        {
            let at = (position % reply.len() as u64) as usize;
            reply[at] ^= xor;
        }
    }
}

/// The fault script's own spelling (`drop`, `delay250`, `error61`, ...), as logs show it.
impl std::fmt::Display for LinkFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Drop => f.write_str("drop"),
            Self::Corrupt { position, xor } => {
                write!(f, "corrupt (byte {position}, xor {xor:#04x})")
            }
            Self::Delay { ms } => write!(f, "delay{ms}"),
            Self::Close => f.write_str("close"),
            Self::MewtocolError { code } => write!(f, "error{code:02}"),
            Self::ModbusException { code } => write!(f, "exception{code}"),
        }
    }
}

/// What the core does to itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CoreFault {
    /// Scans go on; the heartbeat stops counting.
    FreezeHeartbeat,
    /// The heartbeat counts again.
    ThawHeartbeat,
    /// Switch to PROG mode (the program stops).
    Prog,
    /// Switch back to RUN mode.
    Run,
    /// Power lost and back: counts 0, homed bit clear, the program's first scan.
    PowerCycle,
}

/// The fault script's own spelling (`freeze`, `restart`, ...), as logs show it.
impl std::fmt::Display for CoreFault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::FreezeHeartbeat => "freeze",
            Self::ThawHeartbeat => "thaw",
            Self::Prog => "prog",
            Self::Run => "run",
            Self::PowerCycle => "restart",
        })
    }
}

/// A script item's action.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// A link fault; `Corrupt` draws its byte and bits when it fires.
    Link(LinkFault),
    /// A core fault.
    Core(CoreFault),
}

/// When a script item fires.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trigger {
    /// At this command number (from 1).
    Command(u64),
    /// At this time, s since the mock started.
    Time(f64),
    /// On each command with this probability (0-1).
    Chance(f64),
}

/// One script item.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultItem {
    /// What happens.
    pub action: Action,
    /// When.
    pub trigger: Trigger,
}

/// A fault script: a seed and items.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FaultScript {
    /// Seed of the random draws.
    pub seed: u64,
    /// The items, in script order.
    pub items: Vec<FaultItem>,
}

/// A script item that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("fault script item {index} `{item}`: {reason}")]
pub struct ScriptError {
    /// Item number, from 1.
    pub index: usize,
    /// The item as written.
    pub item: String,
    /// What is wrong with it.
    pub reason: ItemFault,
}

/// What is wrong with a script item, naming the value.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ItemFault {
    /// Nothing between two commas.
    #[error("empty item")]
    Empty,
    /// Not `ACTION@WHEN`.
    #[error("expected ACTION@WHEN (e.g. drop@3, freeze@t=0.5, corrupt@1%)")]
    NoTrigger,
    /// A value that is not a number of its kind.
    #[error("`{text}` is not a valid {what}")]
    NotANumber {
        /// The value.
        text: String,
        /// What it should be.
        what: &'static str,
    },
    /// A MEWTOCOL error code of three digits.
    #[error("MEWTOCOL error code {0} has more than two digits")]
    ErrorCodeTooLong(u8),
    /// Modbus exception 0.
    #[error("Modbus exception code 0 does not exist")]
    NoException0,
    /// An action there is not.
    #[error(
        "unknown action `{0}`; expected drop, corrupt, close, delay<ms>, error<NN>, \
         exception<N>, freeze, thaw, prog, run or restart"
    )]
    UnknownAction(String),
    /// A time before the start.
    #[error("time {0} s must be 0 or more")]
    NegativeTime(String),
    /// A percentage out of range (as written back).
    #[error("percentage {0} must be above 0 and at most 100")]
    Percentage(String),
    /// Command 0.
    #[error("command numbers start at 1")]
    Command0,
    /// A link fault at a time.
    #[error("link faults fire on a command number or a percentage, not a time")]
    LinkAtTime,
    /// A core fault at random.
    #[error("only link faults may fire at random; give a command number or t=")]
    CoreAtRandom,
}

fn number<T: FromStr>(text: &str, what: &'static str) -> Result<T, ItemFault> {
    text.parse().map_err(|_| ItemFault::NotANumber {
        text: text.to_owned(),
        what,
    })
}

fn parse_action(name: &str) -> Result<Action, ItemFault> {
    let link = |f| Ok(Action::Link(f));
    let core = |f| Ok(Action::Core(f));
    match name {
        "drop" => link(LinkFault::Drop),
        "corrupt" => link(LinkFault::Corrupt {
            position: 0,
            xor: 1,
        }),
        "close" => link(LinkFault::Close),
        "freeze" => core(CoreFault::FreezeHeartbeat),
        "thaw" => core(CoreFault::ThawHeartbeat),
        "prog" => core(CoreFault::Prog),
        "run" => core(CoreFault::Run),
        "restart" => core(CoreFault::PowerCycle),
        _ => parse_coded_action(name),
    }
}

fn parse_coded_action(name: &str) -> Result<Action, ItemFault> {
    if let Some(ms) = name.strip_prefix("delay") {
        let ms = ms.strip_suffix("ms").unwrap_or(ms);
        return Ok(Action::Link(LinkFault::Delay {
            ms: number(ms, "delay in ms")?,
        }));
    }
    if let Some(code) = name.strip_prefix("error") {
        let code: u8 = number(code, "MEWTOCOL error code")?;
        if code > 99 {
            return Err(ItemFault::ErrorCodeTooLong(code));
        }
        return Ok(Action::Link(LinkFault::MewtocolError { code }));
    }
    if let Some(code) = name.strip_prefix("exception") {
        let code: u8 = number(code, "Modbus exception code")?;
        if code == 0 {
            return Err(ItemFault::NoException0);
        }
        return Ok(Action::Link(LinkFault::ModbusException { code }));
    }
    Err(ItemFault::UnknownAction(name.to_owned()))
}

fn parse_trigger(text: &str) -> Result<Trigger, ItemFault> {
    if let Some(s) = text.strip_prefix("t=") {
        let t: f64 = number(s, "time in seconds")?;
        if !t.is_finite() || t < 0.0 {
            return Err(ItemFault::NegativeTime(s.to_owned()));
        }
        return Ok(Trigger::Time(t));
    }
    if let Some(p) = text.strip_suffix('%') {
        let p: f64 = number(p, "percentage")?;
        if !(p > 0.0 && p <= 100.0) {
            return Err(ItemFault::Percentage(p.to_string()));
        }
        return Ok(Trigger::Chance(p / 100.0));
    }
    let k: u64 = number(text, "command number")?;
    if k == 0 {
        return Err(ItemFault::Command0);
    }
    Ok(Trigger::Command(k))
}

fn parse_item(text: &str) -> Result<FaultItem, ItemFault> {
    let (name, when) = text.split_once('@').ok_or(ItemFault::NoTrigger)?;
    let action = parse_action(name.trim())?;
    let trigger = parse_trigger(when.trim())?;
    match (action, trigger) {
        (Action::Link(_), Trigger::Time(_)) => Err(ItemFault::LinkAtTime),
        (Action::Core(_), Trigger::Chance(_)) => Err(ItemFault::CoreAtRandom),
        _ => Ok(FaultItem { action, trigger }),
    }
}

impl FaultScript {
    /// Parses the compact text form (see the module docs). Empty text is an empty script.
    pub fn parse(text: &str) -> Result<Self, ScriptError> {
        let mut script = Self::default();
        if text.trim().is_empty() {
            return Ok(script);
        }
        for (i, raw) in text.split(',').enumerate() {
            let item = raw.trim();
            let error = |reason: ItemFault| ScriptError {
                index: i + 1,
                item: item.to_owned(),
                reason,
            };
            if item.is_empty() {
                return Err(error(ItemFault::Empty));
            }
            if let Some(seed) = item.strip_prefix("seed=") {
                script.seed = number(seed, "seed").map_err(error)?;
            } else {
                script.items.push(parse_item(item).map_err(error)?);
            }
        }
        Ok(script)
    }
}

impl FromStr for FaultScript {
    type Err = ScriptError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::parse(s)
    }
}

/// `SplitMix64`: a tiny, well-mixed PRNG, enough for reproducible fault draws.
#[derive(Debug, Clone, PartialEq, Eq)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn next_unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// What fired for one command.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Fired {
    /// For the server to apply to this command's reply, in script order.
    pub link: Vec<LinkFault>,
    /// For the core to apply now.
    pub core: Vec<CoreFault>,
}

/// Plays a [`FaultScript`].
#[derive(Debug, Clone, PartialEq)]
pub struct FaultInjector {
    script: FaultScript,
    rng: SplitMix64,
    fired_at_time: Vec<bool>,
}

impl FaultInjector {
    /// An injector at the start of `script`.
    #[must_use]
    pub fn new(script: FaultScript) -> Self {
        let rng = SplitMix64(script.seed);
        let fired_at_time = vec![false; script.items.len()];
        Self {
            script,
            rng,
            fired_at_time,
        }
    }

    /// What fires at command number `k`. Every random item draws once per command, in script
    /// order, so a seed replays the same faults for the same command sequence.
    pub fn on_command(&mut self, k: u64) -> Fired {
        let mut fired = Fired::default();
        for item in &self.script.items {
            let fires = match item.trigger {
                Trigger::Command(n) => n == k,
                Trigger::Chance(p) => self.rng.next_unit() < p,
                Trigger::Time(_) => false,
            };
            if fires {
                match item.action {
                    Action::Link(LinkFault::Corrupt { .. }) => {
                        let position = self.rng.next_u64();
                        let xor = (self.rng.next_u64() % 255 + 1) as u8;
                        fired.link.push(LinkFault::Corrupt { position, xor });
                    }
                    Action::Link(f) => fired.link.push(f),
                    Action::Core(f) => fired.core.push(f),
                }
            }
        }
        fired
    }

    /// Core faults whose time has come by `now_s` (each fires once).
    pub fn due_at(&mut self, now_s: f64) -> Vec<CoreFault> {
        let mut due = Vec::new();
        for (item, fired) in self.script.items.iter().zip(&mut self.fired_at_time) {
            if let (Trigger::Time(t), Action::Core(f)) = (item.trigger, item.action)
                && !*fired
                && t <= now_s
            {
                *fired = true;
                due.push(f);
            }
        }
        due
    }
}

impl Default for FaultInjector {
    fn default() -> Self {
        Self::new(FaultScript::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn script_parses_every_kind_of_item() {
        let s = FaultScript::parse("drop@3, corrupt@5,error61@7,prog@12,freeze@t=0.5,seed=7,delay250ms@2,exception2@4,close@1%,restart@t=2")
            .unwrap();
        assert_eq!(s.seed, 7);
        assert_eq!(s.items.len(), 9);
        assert_eq!(
            s.items[8],
            FaultItem {
                action: Action::Core(CoreFault::PowerCycle),
                trigger: Trigger::Time(2.0)
            }
        );
        assert_eq!(
            s.items[2],
            FaultItem {
                action: Action::Link(LinkFault::MewtocolError { code: 61 }),
                trigger: Trigger::Command(7)
            }
        );
        assert_eq!(s.items[4].trigger, Trigger::Time(0.5));
        assert_eq!(
            s.items[5].action,
            Action::Link(LinkFault::Delay { ms: 250 })
        );
        assert_eq!(s.items[7].trigger, Trigger::Chance(0.01));
    }

    #[test]
    fn bad_items_are_named_with_their_position() {
        let cases = [
            ("drop@3,explode@4", 2, "unknown action `explode`"),
            ("drop", 1, "expected ACTION@WHEN"),
            ("drop@0", 1, "start at 1"),
            ("error100@2", 1, "more than two digits"),
            ("drop@t=1", 1, "not a time"),
            ("prog@5%", 1, "at random"),
            ("corrupt@150%", 1, "at most 100"),
            ("drop@3,,drop@4", 2, "empty item"),
            ("seed=x", 1, "not a valid seed"),
        ];
        for (text, index, reason) in cases {
            let e = FaultScript::parse(text).unwrap_err();
            assert_eq!(e.index, index, "{text}: {e}");
            assert!(e.to_string().contains(reason), "{text}: {e}");
        }
    }

    #[test]
    fn command_items_fire_at_their_command_only() {
        let mut f = FaultInjector::new("drop@3,prog@3".parse().unwrap());
        assert_eq!(f.on_command(2), Fired::default());
        let fired = f.on_command(3);
        assert_eq!(fired.link, vec![LinkFault::Drop]);
        assert_eq!(fired.core, vec![CoreFault::Prog]);
    }

    #[test]
    fn time_items_fire_once_when_due() {
        let mut f = FaultInjector::new("freeze@t=0.5".parse().unwrap());
        assert!(f.due_at(0.4).is_empty());
        assert_eq!(f.due_at(0.6), vec![CoreFault::FreezeHeartbeat]);
        assert!(f.due_at(0.7).is_empty());
    }

    #[test]
    fn seeded_corruption_is_reproducible_and_near_its_rate() {
        let run = |seed: u64| {
            let mut f =
                FaultInjector::new(FaultScript::parse(&format!("seed={seed},corrupt@1%")).unwrap());
            (1..=10_000)
                .flat_map(|k| f.on_command(k).link.into_iter().map(move |l| (k, l)))
                .collect::<Vec<_>>()
        };
        let a = run(7);
        assert_eq!(a, run(7));
        assert_ne!(a, run(8));
        assert!(
            (60..=140).contains(&a.len()),
            "{} corruptions in 10 000",
            a.len()
        );
        let mut reply = *b"%01$WD13\r";
        a[0].1.corrupt_in_place(&mut reply);
        assert_ne!(&reply, b"%01$WD13\r");
    }
}
