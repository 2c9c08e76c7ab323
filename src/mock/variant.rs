//! How the mock departs from the reference listing: each [`MockVariant`] but `Listing` is one
//! defect a real FP-X might turn out to have, which `linterpd commission` is built to find
//! (`linterpd mock-plc --variant NAME`). Each changes the mock in one or two places only:
//!
//! ```text
//! listing           the listing as deploy/plc/README.md expects it (the default)
//! busy-never-rises  the busy relays never rise (a wrong address): the busy word stays 0 and
//!                   fault 2 can never fire; segments still end when the count shows their last
//!                   target, as the listing's fallback does           program/mod.rs, start.rs
//! stop-pauses       H n108 only pauses F174: the output halts, the busy flag drops, and the
//!                   next F174 on the channel (after the listing's H n100) resumes the paused
//!                   table and is itself refused without an error     engine.rs
//! angle-refused     `<` frames get no answer at all                  mewtocol_server.rs
//! one-frame-replies a MEWTOCOL-COM reply longer than one frame gets no answer at all (a
//!                   PLC without multi-frame replies)                mewtocol_server.rs
//! small-requests    MEWTOCOL reads and writes of more than 64 words answer `! 41`, Modbus
//!                   requests of more than 100 registers exception 03 answer.rs, modbus_server.rs
//! divider-clock     the channels output per the fpx-divider model, whatever --frequency-model
//! ideal-clock       the channels output exactly the value written, whatever --frequency-model
//! ignores-permit    a program at version 2's logic that reports version 3: the status block
//!                   (inputs too) is version 3's, but a start's permit is never checked (no
//!                   fault 8) and a running move is never held by it (no fault 9)
//!                                                                   program/mod.rs, start.rs
//! ```

use crate::table::FrequencyModel;

/// Words a MEWTOCOL-COM read or write may hold under [`MockVariant::SmallRequests`].
pub const SMALL_MEWTOCOL_WORDS: usize = 64;
/// Registers a Modbus read or write may hold under [`MockVariant::SmallRequests`].
pub const SMALL_MODBUS_REGISTERS: usize = 100;

/// A mock that behaves like the listing, or misbehaves in one way.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MockVariant {
    /// The listing as expected.
    #[default]
    Listing,
    /// The busy relays never rise.
    BusyNeverRises,
    /// A stop only pauses F174; the next F174 on the channel resumes the old table.
    StopPauses,
    /// `<` frames get no answer.
    AngleRefused,
    /// MEWTOCOL-COM replies longer than one frame get no answer.
    OneFrameReplies,
    /// Reads and writes above 64 MEWTOCOL words or 100 Modbus registers are refused.
    SmallRequests,
    /// The channels follow the fpx-divider model.
    DividerClock,
    /// The channels output exactly the value written.
    IdealClock,
    /// The permit is never checked: no fault 8 at a start, no fault 9 while running.
    IgnoresPermit,
}

impl MockVariant {
    /// Every variant, the default first.
    pub const ALL: [Self; 9] = [
        Self::Listing,
        Self::BusyNeverRises,
        Self::StopPauses,
        Self::AngleRefused,
        Self::OneFrameReplies,
        Self::SmallRequests,
        Self::DividerClock,
        Self::IdealClock,
        Self::IgnoresPermit,
    ];

    /// The name used on the command line.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Listing => "listing",
            Self::BusyNeverRises => "busy-never-rises",
            Self::StopPauses => "stop-pauses",
            Self::AngleRefused => "angle-refused",
            Self::OneFrameReplies => "one-frame-replies",
            Self::SmallRequests => "small-requests",
            Self::DividerClock => "divider-clock",
            Self::IdealClock => "ideal-clock",
            Self::IgnoresPermit => "ignores-permit",
        }
    }

    /// The variant called `name`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|v| v.name() == name)
    }

    /// The frequency model the variant imposes on the channels, if any.
    #[must_use]
    pub fn model(self) -> Option<FrequencyModel> {
        match self {
            Self::DividerClock => Some(FrequencyModel::FpxDivider),
            Self::IdealClock => Some(FrequencyModel::Ideal),
            _ => None,
        }
    }

    /// Whether the busy relays the program reads follow the pulse output.
    #[must_use]
    pub fn busy_flags_work(self) -> bool {
        self != Self::BusyNeverRises
    }

    /// Whether a stop command aborts F174 (false: it only pauses it).
    #[must_use]
    pub fn stop_aborts(self) -> bool {
        self != Self::StopPauses
    }

    /// Whether the program checks a start's permit (fault 8) and a running move's (fault 9).
    #[must_use]
    pub fn checks_permit(self) -> bool {
        self != Self::IgnoresPermit
    }

    /// Whether `<` frames are answered.
    #[must_use]
    pub fn answers_angle(self) -> bool {
        self != Self::AngleRefused
    }

    /// Whether a MEWTOCOL-COM reply may come in several frames.
    #[must_use]
    pub fn answers_multi_frame(self) -> bool {
        self != Self::OneFrameReplies
    }

    /// Most words one MEWTOCOL-COM read or write may hold, if the variant limits it below the
    /// header's own limit.
    #[must_use]
    pub fn mewtocol_words_limit(self) -> Option<usize> {
        (self == Self::SmallRequests).then_some(SMALL_MEWTOCOL_WORDS)
    }

    /// Most registers one Modbus read or write may hold, if the variant limits it below the
    /// specification's.
    #[must_use]
    pub fn modbus_registers_limit(self) -> Option<usize> {
        (self == Self::SmallRequests).then_some(SMALL_MODBUS_REGISTERS)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_only_clock_variants_fix_the_model() {
        for v in MockVariant::ALL {
            assert_eq!(MockVariant::from_name(v.name()), Some(v));
        }
        assert_eq!(MockVariant::from_name("nonsense"), None);
        let fixed: Vec<MockVariant> = MockVariant::ALL
            .into_iter()
            .filter(|v| v.model().is_some())
            .collect();
        assert_eq!(fixed, [MockVariant::DividerClock, MockVariant::IdealClock]);
    }
}
