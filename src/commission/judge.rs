//! PURE. What the commission's measurements mean: which frequency model a channel's pulse rate
//! fits, the test frequency that tells the models furthest apart, the scan time from heartbeat
//! reads, round-trip figures, and the search for the largest request a PLC takes. No IO, no
//! clock: times are arguments, in seconds.
//!
//! The rate fit: a table of `n` pulses at one frequency value is polled while it runs; each poll
//! gives (time, count). A least-squares line through the samples strictly inside the run (the
//! first and last pulse are blurred by the start and end of F174) gives the rate and its standard
//! error. A model fits when its predicted rate lies within three standard errors, but never
//! closer than [`RATE_FLOOR`] of the rate (the PLC's and the PC's clocks may disagree that much)
//! or [`MODEL_GAP_SHARE`] of the gap between the two models (the PC's read times jitter).

use serde::{Deserialize, Serialize};

use crate::table::{FrequencyModel, FrequencyRange};

/// Relative rate difference that is always within the measurement (clock tolerances), 2e-4.
pub const RATE_FLOOR: f64 = 2e-4;
/// The share of the gap between the two models' rates within which a measurement fits a model
/// whatever its standard error.
pub const MODEL_GAP_SHARE: f64 = 0.25;
/// Samples strictly inside a run needed for a rate fit.
pub const MIN_RATE_SAMPLES: usize = 5;

/// Which model a measured rate fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fit {
    /// `ideal` fits and `fpx-divider` does not.
    Ideal,
    /// `fpx-divider` fits and `ideal` does not.
    FpxDivider,
    /// Both fit: the measurement cannot tell them apart at this frequency.
    Undecided,
    /// Neither fits: the channel runs at another rate altogether.
    Neither,
}

impl Fit {
    /// The model that fits alone, if one does.
    #[must_use]
    pub fn model(self) -> Option<FrequencyModel> {
        match self {
            Self::Ideal => Some(FrequencyModel::Ideal),
            Self::FpxDivider => Some(FrequencyModel::FpxDivider),
            Self::Undecided | Self::Neither => None,
        }
    }

    /// Whether `model` is among the models that fit.
    #[must_use]
    pub fn admits(self, model: FrequencyModel) -> bool {
        match self {
            Self::Undecided => true,
            Self::Neither => false,
            _ => self.model() == Some(model),
        }
    }

    /// Lower-case words for reports.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Self::Ideal => "ideal fits",
            Self::FpxDivider => "fpx-divider fits",
            Self::Undecided => "both models fit: the measurement cannot tell them apart",
            Self::Neither => "neither model fits",
        }
    }
}

/// One run's rate, measured and predicted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RateFit {
    /// Frequency value written, Hz.
    pub set_hz: u32,
    /// Pulses of the run.
    pub pulses: i64,
    /// Samples inside the run the line was fitted through.
    pub samples: usize,
    /// Measured rate, Hz.
    pub measured_hz: f64,
    /// Three standard errors of the measured rate (or the floor), Hz.
    pub tolerance_hz: f64,
    /// The rate `ideal` predicts, Hz.
    pub ideal_hz: f64,
    /// The rate `fpx-divider` predicts, Hz.
    pub divider_hz: f64,
    /// What the measured rate fits.
    pub fit: Fit,
}

impl RateFit {
    /// How long the run's pulses took at the measured rate, s.
    #[must_use]
    pub fn took_s(&self) -> f64 {
        self.pulses as f64 / self.measured_hz
    }

    /// How long they take under `model`, s.
    #[must_use]
    pub fn predicted_s(&self, model: FrequencyModel) -> f64 {
        let hz = match model {
            FrequencyModel::Ideal => self.ideal_hz,
            FrequencyModel::FpxDivider => self.divider_hz,
        };
        self.pulses as f64 / hz
    }
}

/// A least-squares line: slope and its standard error.
fn line(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if points.len() < 3 {
        return None;
    }
    let mean_t = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mean_t).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = points.iter().map(|p| (p.0 - mean_t) * (p.1 - mean_y)).sum();
    let slope = sxy / sxx;
    let sse: f64 = points
        .iter()
        .map(|p| (p.1 - mean_y - slope * (p.0 - mean_t)).powi(2))
        .sum();
    Some((slope, (sse / (n - 2.0) / sxx).sqrt()))
}

/// Fits the rate of a run of `pulses` pulses (either direction) at `set_hz` in `range` on a
/// channel whose top is `limit_hz`, from `(time_s, pulses moved so far)` samples. `None` with
/// fewer than [`MIN_RATE_SAMPLES`] samples strictly inside the run.
#[must_use]
pub fn fit_rate(
    samples: &[(f64, i64)],
    pulses: i64,
    set_hz: u32,
    range: FrequencyRange,
    limit_hz: f64,
) -> Option<RateFit> {
    let inside: Vec<(f64, f64)> = samples
        .iter()
        .filter(|(_, moved)| *moved > 0 && *moved < pulses)
        .map(|&(t, moved)| (t, moved as f64))
        .collect();
    if inside.len() < MIN_RATE_SAMPLES {
        return None;
    }
    let (measured_hz, se_hz) = line(&inside)?;
    let predict = |m: FrequencyModel| crate::sim::row_actual_hz(m, set_hz, range, limit_hz);
    let (ideal_hz, divider_hz) = (
        predict(FrequencyModel::Ideal),
        predict(FrequencyModel::FpxDivider),
    );
    // The PC's read times carry its own scheduling jitter, which the residuals do not show
    // when it shifts a whole stretch of reads: a measurement within a quarter of the gap between
    // the models is taken as the nearer one (it can never fit both that way).
    let tolerance_hz = (3.0 * se_hz)
        .max(RATE_FLOOR * measured_hz.abs())
        .max(MODEL_GAP_SHARE * (ideal_hz - divider_hz).abs());
    let fits = |hz: f64| (measured_hz - hz).abs() <= tolerance_hz.max(RATE_FLOOR * hz);
    let fit = match (fits(ideal_hz), fits(divider_hz)) {
        (true, true) => Fit::Undecided,
        (true, false) => Fit::Ideal,
        (false, true) => Fit::FpxDivider,
        (false, false) => Fit::Neither,
    };
    Some(RateFit {
        set_hz,
        pulses,
        samples: inside.len(),
        measured_hz,
        tolerance_hz,
        ideal_hz,
        divider_hz,
        fit,
    })
}

/// How far apart the models put `set_hz` in `range`: the divider's rounding, 0..1 of a clock
/// tick per pulse (0: the models agree exactly).
fn separation(set_hz: u32, range: FrequencyRange) -> f64 {
    let ticks = range.divider_clock_hz() / f64::from(set_hz);
    ticks.ceil() - ticks
}

/// The frequency value within 10 % of `wanted_hz` (and inside `min_hz..=max_hz`) at which the
/// two models differ most in `range`; the nearest to `wanted_hz` among equals.
#[must_use]
pub fn timing_hz(wanted_hz: f64, min_hz: u32, max_hz: u32, range: FrequencyRange) -> u32 {
    let clamp = |hz: f64| (hz.round() as u32).clamp(min_hz, max_hz);
    let (low, high) = (clamp(wanted_hz * 0.9), clamp(wanted_hz * 1.1));
    let centre = clamp(wanted_hz);
    (low..=high)
        .max_by(|&a, &b| {
            let key = |f: u32| {
                (
                    separation(f, range),
                    -(f64::from(f) - f64::from(centre)).abs(),
                )
            };
            key(a)
                .partial_cmp(&key(b))
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .unwrap_or(centre)
}

/// The heartbeat's rate over `(time_s, heartbeat)` reads.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScanRate {
    /// Scans counted (heartbeat steps, wraps included).
    pub scans: u64,
    /// Over this long, s.
    pub window_s: f64,
    /// Mean scan time, s (`None` if the heartbeat never moved).
    pub mean_scan_s: Option<f64>,
    /// The longest the heartbeat was seen standing still, s (between reads that agreed).
    pub longest_still_s: f64,
}

/// Counts heartbeat steps across reads (each read less than 65 536 scans after the last).
#[must_use]
pub fn scan_rate(reads: &[(f64, u16)]) -> ScanRate {
    let mut scans = 0_u64;
    let mut longest_still_s = 0.0_f64;
    let mut still_since = reads.first().map_or(0.0, |r| r.0);
    for pair in reads.windows(2) {
        let ((_, a), (t, b)) = (pair[0], pair[1]);
        let steps = u64::from(b.wrapping_sub(a));
        scans += steps;
        if steps == 0 {
            longest_still_s = longest_still_s.max(t - still_since);
        } else {
            still_since = t;
        }
    }
    let window_s = match (reads.first(), reads.last()) {
        (Some(first), Some(last)) => last.0 - first.0,
        _ => 0.0,
    };
    ScanRate {
        scans,
        window_s,
        mean_scan_s: (scans > 0).then(|| window_s / scans as f64),
        longest_still_s,
    }
}

/// Least, median and greatest of some durations, ms.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Exchanges timed.
    pub count: usize,
    /// Shortest, ms.
    pub min_ms: f64,
    /// Median, ms.
    pub median_ms: f64,
    /// Longest, ms.
    pub max_ms: f64,
}

/// The spread of `durations_s` (`None` when empty).
#[must_use]
pub fn spread(durations_s: &[f64]) -> Option<Spread> {
    let mut ms: Vec<f64> = durations_s.iter().map(|d| d * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    Some(Spread {
        count: ms.len(),
        min_ms: *ms.first()?,
        median_ms: ms[ms.len() / 2],
        max_ms: *ms.last()?,
    })
}

/// The search for the largest request size `1..=max` a PLC accepts, assuming every size below
/// an accepted one is accepted: the maximum first (a PLC that takes it needs one probe), then
/// bisection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bisect {
    /// Largest size accepted so far (0: none).
    accepted: usize,
    /// Smallest size refused so far (`max + 1`: none).
    refused: usize,
    max: usize,
}

impl Bisect {
    /// A search over `1..=max`.
    #[must_use]
    pub fn new(max: usize) -> Self {
        Self {
            accepted: 0,
            refused: max + 1,
            max,
        }
    }

    /// The next size to try, or `None` once the answer is known.
    #[must_use]
    pub fn next(&self) -> Option<usize> {
        if self.refused == self.max + 1 && self.accepted < self.max {
            return Some(self.max);
        }
        (self.refused - self.accepted > 1).then_some(usize::midpoint(self.accepted, self.refused))
    }

    /// Records what the PLC did with `size`.
    pub fn record(&mut self, size: usize, accepted: bool) {
        if accepted {
            self.accepted = self.accepted.max(size);
        } else {
            self.refused = self.refused.min(size);
        }
    }

    /// The largest size accepted (0: not even one word).
    #[must_use]
    pub fn largest(&self) -> usize {
        self.accepted
    }

    /// The smallest size refused, if any was.
    #[must_use]
    pub fn smallest_refused(&self) -> Option<usize> {
        (self.refused <= self.max).then_some(self.refused)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Samples of a run at `hz`, polled at irregular intervals around `poll_s`.
    fn run(hz: f64, pulses: i64, poll_s: f64) -> Vec<(f64, i64)> {
        let end_s = pulses as f64 / hz + 0.05;
        let mut t = 0.0;
        let mut out = Vec::new();
        for k in 0_u32.. {
            t += poll_s * (0.5 + (f64::from(k) * 0.618_034).fract());
            if t >= end_s {
                break;
            }
            out.push((t, ((t * hz).floor() as i64).min(pulses)));
        }
        out
    }

    #[test]
    fn the_timing_frequency_is_where_the_divider_rounds_most() {
        let range = FrequencyRange::Low;
        let f = timing_hz(2_000.0, 100, 2_000, range);
        assert!((1_800..=2_000).contains(&f), "{f}");
        let ideal = FrequencyModel::Ideal.actual_hz(f, range);
        let divider = FrequencyModel::FpxDivider.actual_hz(f, range);
        assert!(
            (ideal - divider) / ideal > 0.015,
            "{f}: {ideal} vs {divider}"
        );
        assert_eq!(timing_hz(50.0, 100, 2_000, range), 100);
    }

    #[test]
    fn a_divider_run_fits_the_divider_model_with_figures() {
        let range = FrequencyRange::Low;
        let f = timing_hz(2_000.0, 100, 2_000, range);
        let actual = FrequencyModel::FpxDivider.actual_hz(f, range);
        let fit = fit_rate(&run(actual, 500, 0.002), 500, f, range, 100_000.0).unwrap();
        assert_eq!(fit.fit, Fit::FpxDivider, "{fit:?}");
        assert!((fit.measured_hz - actual).abs() < fit.tolerance_hz);
        assert!((fit.took_s() - fit.predicted_s(FrequencyModel::FpxDivider)).abs() < 1e-3);
        assert!(fit.samples > 50);
    }

    #[test]
    fn an_ideal_run_fits_the_ideal_model() {
        let range = FrequencyRange::Low;
        let f = timing_hz(2_000.0, 100, 2_000, range);
        let fit = fit_rate(&run(f64::from(f), 500, 0.002), 500, f, range, 100_000.0).unwrap();
        assert_eq!(fit.fit, Fit::Ideal, "{fit:?}");
        assert!(fit.fit.admits(FrequencyModel::Ideal));
        assert!(!fit.fit.admits(FrequencyModel::FpxDivider));
    }

    #[test]
    fn a_rate_shifted_by_read_jitter_fits_the_nearer_model_within_a_quarter_of_their_gap() {
        // Seen under load: 1878 Hz set, ideal 1878, divider 1842.57, measured 1847.13 with a
        // standard error that does not cover the 4.6 Hz (the reads' times shifted together).
        let range = FrequencyRange::Low;
        let fit = fit_rate(&run(1_847.13, 500, 0.002), 500, 1_878, range, 1e5).unwrap();
        assert!((fit.divider_hz - 1_842.57).abs() < 0.01, "{fit:?}");
        assert_eq!(fit.fit, Fit::FpxDivider, "{fit:?}");
        // Halfway between the two is neither.
        let fit = fit_rate(&run(1_860.3, 500, 0.002), 500, 1_878, range, 1e5).unwrap();
        assert_eq!(fit.fit, Fit::Neither, "{fit:?}");
    }

    #[test]
    fn a_rate_far_from_both_fits_neither_and_close_models_are_undecided() {
        let range = FrequencyRange::Low;
        let fit = fit_rate(&run(1_500.0, 500, 0.002), 500, 2_000, range, 1e5).unwrap();
        assert_eq!(fit.fit, Fit::Neither);
        // At 97656.25 / 100 the divider divides exactly: the models agree.
        let slow = run(976.5625, 300, 0.01);
        let fit = fit_rate(&slow, 300, 977, range, 1e5).unwrap();
        assert!(
            matches!(fit.fit, Fit::Undecided | Fit::FpxDivider),
            "{fit:?}"
        );
    }

    #[test]
    fn too_few_samples_inside_the_run_give_no_fit() {
        let samples = [(0.0, 0), (0.1, 10), (0.2, 20), (0.3, 30), (0.4, 40)];
        assert!(fit_rate(&samples, 40, 100, FrequencyRange::Low, 1e5).is_none());
    }

    #[test]
    fn heartbeat_reads_give_the_mean_scan_across_a_wrap() {
        let reads = [
            (0.0, 65_530),
            (0.010, 65_535),
            (0.020, 4),
            (0.030, 4),
            (0.040, 14),
        ];
        let rate = scan_rate(&reads);
        assert_eq!(rate.scans, 20);
        assert!((rate.mean_scan_s.unwrap() - 0.002).abs() < 1e-12);
        assert!((rate.longest_still_s - 0.010).abs() < 1e-12);
        assert_eq!(scan_rate(&[(0.0, 7), (1.0, 7)]).mean_scan_s, None);
    }

    #[test]
    fn spread_gives_min_median_max_in_ms() {
        let s = spread(&[0.003, 0.001, 0.002]).unwrap();
        assert_eq!(
            (s.count, s.min_ms, s.median_ms, s.max_ms),
            (3, 1.0, 2.0, 3.0)
        );
        assert!(spread(&[]).is_none());
    }

    #[test]
    fn bisection_tries_the_maximum_first_then_halves() {
        let mut b = Bisect::new(509);
        assert_eq!(b.next(), Some(509));
        b.record(509, true);
        assert_eq!(
            (b.next(), b.largest(), b.smallest_refused()),
            (None, 509, None)
        );

        let limit = 64;
        let mut b = Bisect::new(509);
        let mut probes = 0;
        while let Some(n) = b.next() {
            b.record(n, n <= limit);
            probes += 1;
        }
        assert_eq!((b.largest(), b.smallest_refused()), (64, Some(65)));
        assert!(probes <= 11, "{probes}");

        let mut b = Bisect::new(24);
        while let Some(n) = b.next() {
            b.record(n, false);
        }
        assert_eq!((b.largest(), b.smallest_refused()), (0, Some(1)));
    }
}
