//! F174 frequency ranges and the frequency models that say what a channel really outputs.
//!
//! Source: Panasonic FP-X user's manual, F174 (SP0H) "pulse output with data table", control code
//! digit 2; the divider model is our own derivation (`docs/PLC.md`, "Actual output
//! frequency").

use serde::{Deserialize, Serialize};

/// The frequency range of one F174 table (control code digit 2). It holds for the whole table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum FrequencyRange {
    /// Range 0: 1.5 Hz - 9.8 kHz (the value 1 means 1.5 Hz).
    Low,
    /// Range 1: 48 Hz - 100 kHz.
    Mid,
    /// Range 2: 191 Hz - 100 kHz.
    High,
}

impl FrequencyRange {
    /// All ranges, finest resolution first (the planner's order of preference).
    pub const FINEST_FIRST: [Self; 3] = [Self::High, Self::Mid, Self::Low];

    /// The digit written into the control code.
    #[must_use]
    pub fn digit(self) -> u32 {
        match self {
            Self::Low => 0,
            Self::Mid => 1,
            Self::High => 2,
        }
    }

    /// The range for a control-code digit.
    #[must_use]
    pub fn from_digit(digit: u32) -> Option<Self> {
        match digit {
            0 => Some(Self::Low),
            1 => Some(Self::Mid),
            2 => Some(Self::High),
            _ => None,
        }
    }

    /// Smallest frequency value that may be written in this range.
    #[must_use]
    pub fn min_set_hz(self) -> u32 {
        match self {
            Self::Low => 1,
            Self::Mid => 48,
            Self::High => 191,
        }
    }

    /// Largest frequency value that may be written in this range.
    #[must_use]
    pub fn max_set_hz(self) -> u32 {
        match self {
            Self::Low => 9_800,
            Self::Mid | Self::High => 100_000,
        }
    }

    /// The lowest real frequency the range can produce (what a too-low value runs at).
    #[must_use]
    pub fn min_actual_hz(self) -> f64 {
        match self {
            Self::Low => 1.5,
            Self::Mid => 48.0,
            Self::High => 191.0,
        }
    }

    /// Whether a wanted real frequency (Hz) can be written in this range without clamping.
    #[must_use]
    pub fn covers(self, freq_hz: f64) -> bool {
        freq_hz >= self.min_actual_hz() && freq_hz <= f64::from(self.max_set_hz())
    }

    /// The divider's input clock under the `fpx-divider` model.
    #[must_use]
    pub fn divider_clock_hz(self) -> f64 {
        match self {
            Self::Low => 97_656.25,
            Self::Mid => 3_125_000.0,
            Self::High => 12_500_000.0,
        }
    }

    /// The smallest divisor the divider uses in this range (sets its top frequency).
    #[must_use]
    pub fn min_divisor(self) -> u32 {
        match self {
            Self::Low => 10,
            Self::Mid => 32,
            Self::High => 125,
        }
    }
}

/// How a frequency value written to the PLC turns into a real pulse rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrequencyModel {
    /// The channel outputs exactly the value written (range 0, value 1: 1.5 Hz).
    Ideal,
    /// A 16-bit divider of a fixed clock per range: `clock / ceil(clock / f_set)` (never above the
    /// value written). Our derivation from the documented worst-case errors, not Panasonic's.
    #[default]
    FpxDivider,
}

impl FrequencyModel {
    /// The name used in config, on the command line and in reports.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Ideal => "ideal",
            Self::FpxDivider => "fpx-divider",
        }
    }

    /// The real frequency (Hz) a channel outputs for the value `set_hz` in `range`, before any
    /// clamping to the range: a value below the range runs at the range's minimum, one above runs
    /// at its maximum.
    #[must_use]
    pub fn actual_hz(self, set_hz: u32, range: FrequencyRange) -> f64 {
        let set_hz = set_hz.clamp(range.min_set_hz(), range.max_set_hz());
        match self {
            Self::Ideal => {
                if range == FrequencyRange::Low && set_hz == 1 {
                    1.5
                } else {
                    f64::from(set_hz)
                }
            }
            Self::FpxDivider => {
                let clock = range.divider_clock_hz();
                let divisor = ceil_of(clock / f64::from(set_hz));
                clock / divisor.clamp(f64::from(range.min_divisor()), 65_535.0)
            }
        }
    }

    /// The value to write so that the real frequency comes as close as the model allows to
    /// `wanted_hz`, measured as the duration of `pulses` pulses. The value stays inside the range
    /// and at or below `max_set_hz`.
    #[must_use]
    pub fn best_set_hz(
        self,
        wanted_hz: f64,
        pulses: u64,
        range: FrequencyRange,
        max_set_hz: u32,
    ) -> u32 {
        let lo = range.min_set_hz();
        let hi = range.max_set_hz().min(max_set_hz).max(lo);
        let wanted = wanted_hz.clamp(f64::from(lo), f64::from(hi));
        let mut candidates = [floor_of(wanted), ceil_of(wanted), 0.0, 0.0];
        if self == Self::FpxDivider {
            // The values that land exactly on the two divisors around the wanted frequency.
            let clock = range.divider_clock_hz();
            let k = clock / wanted;
            candidates[2] = ceil_of(clock / floor_of(k).max(1.0));
            candidates[3] = ceil_of(clock / ceil_of(k).max(1.0));
        }
        let want_s = pulses as f64 / wanted_hz.max(f64::MIN_POSITIVE);
        let mut best = lo;
        let mut best_err = f64::INFINITY;
        for c in candidates {
            if !c.is_finite() || c < f64::from(lo) || c > f64::from(hi) {
                continue;
            }
            let set = c as u32;
            let err = (pulses as f64 / self.actual_hz(set, range) - want_s).abs();
            if err < best_err {
                best_err = err;
                best = set;
            }
        }
        best
    }
}

impl FrequencyModel {
    /// A value whose real pulse period lies in `[lo_s, hi_s]`, inside the range and at or below
    /// `max_set_hz`, the one nearest `want_s` among the few closest; `None` when none does.
    /// Constant time: it works on the divisor (or the integer value) directly.
    #[must_use]
    pub fn set_for_period(
        self,
        range: FrequencyRange,
        lo_s: f64,
        hi_s: f64,
        want_s: f64,
        max_set_hz: u32,
    ) -> Option<u32> {
        let lo_set = range.min_set_hz();
        let hi_set = range.max_set_hz().min(max_set_hz);
        if hi_set < lo_set || lo_s.is_nan() || lo_s <= 0.0 || hi_s < lo_s {
            return None;
        }
        let fits = |set: u32| {
            let p = 1.0 / self.actual_hz(set, range);
            (set >= lo_set
                && set <= hi_set
                && p >= lo_s * (1.0 - 1e-12)
                && p <= hi_s * (1.0 + 1e-12))
                .then_some((set, (p - want_s).abs()))
        };
        let candidates: [f64; 7] = match self {
            Self::Ideal => {
                let (a, b) = (ceil_of(1.0 / hi_s), floor_of(1.0 / lo_s));
                let w = round_of(1.0 / want_s).clamp(a, b.max(a));
                [a, b, w, 1.0, f64::NAN, f64::NAN, f64::NAN]
            }
            Self::FpxDivider => {
                // The real frequency is clock / k: find divisors k in the window, then the
                // smallest value that selects each.
                let clock = range.divider_clock_hz();
                let (ka, kb) = (ceil_of(clock * lo_s), floor_of(clock * hi_s));
                let kw = round_of(clock * want_s).clamp(ka, kb.max(ka));
                [ka, kb, kw, kw - 1.0, kw + 1.0, ka + 1.0, kb - 1.0].map(|k| {
                    if (1.0..=65_535.0).contains(&k) {
                        ceil_of(clock / k)
                    } else {
                        f64::NAN
                    }
                })
            }
        };
        candidates
            .into_iter()
            .filter(|c| c.is_finite() && *c >= 1.0 && *c <= f64::from(u32::MAX))
            .filter_map(|c| fits(c as u32))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(set, _)| set)
    }
}

/// Above this every `f64` is a whole number, and below it a positive one truncates exactly.
const WHOLE_FROM: f64 = 4_503_599_627_370_496.0; // 2^52

/// `x.ceil()`, made inline for the positive values the frequencies give (the build's baseline
/// CPU has no rounding instruction, and the C library's call cost the planner ~5 %); the same
/// value bit for bit, std's own elsewhere.
#[inline]
fn ceil_of(x: f64) -> f64 {
    if x > 0.0 && x < WHOLE_FROM {
        let t = x as i64 as f64;
        if t < x { t + 1.0 } else { t }
    } else {
        x.ceil()
    }
}

/// `x.floor()`, as [`ceil_of`].
#[inline]
fn floor_of(x: f64) -> f64 {
    if x > 0.0 && x < WHOLE_FROM {
        x as i64 as f64
    } else {
        x.floor()
    }
}

/// `x.round()` (halves away from zero), as [`ceil_of`]: the fraction `x - trunc(x)` is exact
/// below 2^52.
#[inline]
fn round_of(x: f64) -> f64 {
    if x > 0.0 && x < WHOLE_FROM {
        let t = x as i64 as f64;
        if x - t >= 0.5 { t + 1.0 } else { t }
    } else {
        x.round()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_inline_roundings_are_std_s_bit_for_bit() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            1.5,
            2.5,
            0.499_999_999_999_999_94,
            1.0 - f64::EPSILON / 2.0,
            f64::MIN_POSITIVE,
            4_503_599_627_370_495.5,
            4_503_599_627_370_496.0,
            9.0e15,
            -1.5,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        // Quotients like the divider's, and their neighbours.
        for set in 1..20_000u32 {
            let q = 12_500_000.0 / f64::from(set);
            values.extend([q, q.next_up(), q.next_down(), 97_656.25 / f64::from(set)]);
        }
        for x in values {
            assert_eq!(ceil_of(x).to_bits(), x.ceil().to_bits(), "ceil {x}");
            assert_eq!(floor_of(x).to_bits(), x.floor().to_bits(), "floor {x}");
            assert_eq!(round_of(x).to_bits(), x.round().to_bits(), "round {x}");
        }
    }

    #[test]
    fn set_for_period_finds_a_value_inside_the_window_or_none() {
        for model in [FrequencyModel::Ideal, FrequencyModel::FpxDivider] {
            for range in FrequencyRange::FINEST_FIRST {
                // 1 kHz +- 1 % (range 0's divider moves in 1 % steps there): a value exists.
                let set = model
                    .set_for_period(range, 0.99e-3, 1.01e-3, 1e-3, 100_000)
                    .unwrap();
                let p = 1.0 / model.actual_hz(set, range);
                assert!(
                    (0.99e-3..=1.01e-3).contains(&p),
                    "{model:?} {range:?} {set} {p}"
                );
            }
            // A window narrower than one Hz step at 50 kHz holds no value.
            assert_eq!(
                model.set_for_period(
                    FrequencyRange::High,
                    1.0 / 50_000.4,
                    1.0 / 50_000.2,
                    1.0 / 50_000.3,
                    100_000
                ),
                None
            );
        }
    }

    #[test]
    fn divider_never_exceeds_the_set_value() {
        for range in FrequencyRange::FINEST_FIRST {
            for set in [range.min_set_hz(), 250, 1_000, 9_765, range.max_set_hz()] {
                let f = FrequencyModel::FpxDivider.actual_hz(set, range);
                // Range 0's value 1 stands for 1.5 Hz.
                let meant = if set == 1 { 1.5 } else { f64::from(set) };
                assert!(f <= meant + 1e-9, "{range:?} {set} -> {f}");
            }
        }
    }

    #[test]
    fn divider_matches_documented_worst_errors() {
        // PLC.md: about -3 kHz near 100 kHz in range 1, -0.8 kHz in range 2, -0.9 kHz near 9.8 kHz in range 0.
        let m = FrequencyModel::FpxDivider;
        assert!((m.actual_hz(100_000, FrequencyRange::Mid) - 97_656.25).abs() < 1e-6);
        assert!((m.actual_hz(99_999, FrequencyRange::High) - 99_206.349).abs() < 1e-2);
        assert!((m.actual_hz(9_800, FrequencyRange::Low) - 9_765.625).abs() < 1e-6);
        assert!((m.actual_hz(1, FrequencyRange::Low) - 1.490_139).abs() < 1e-5);
    }

    #[test]
    fn ideal_low_range_value_one_is_one_and_a_half_hertz() {
        assert!((FrequencyModel::Ideal.actual_hz(1, FrequencyRange::Low) - 1.5).abs() < 1e-12);
        assert!((FrequencyModel::Ideal.actual_hz(2, FrequencyRange::Low) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn best_set_value_beats_naive_rounding_under_the_divider() {
        let m = FrequencyModel::FpxDivider;
        let range = FrequencyRange::Mid;
        let wanted: f64 = 40_123.4;
        let pulses = 2_006;
        let naive = wanted.round() as u32;
        let best = m.best_set_hz(wanted, pulses, range, 100_000);
        let err = |set| (pulses as f64 / m.actual_hz(set, range) - pulses as f64 / wanted).abs();
        assert!(err(best) <= err(naive), "best {best} naive {naive}");
    }
}
