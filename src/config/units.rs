//! Quantities as people write them, for the config, path files and the command line alike: one
//! parser of a number and its unit. Durations take a unit (`50ms`, `0.2s`, `200 ms`, `250us`);
//! lengths, speeds and accelerations may leave theirs out (`20mm` or `20`, `240mm/s`,
//! `5000mm/s2`).

use thiserror::Error;

/// Why a text is not a duration.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("duration {text:?}: {problem}")]
pub struct DurationError {
    /// The text as given.
    pub text: String,
    /// What is wrong with it.
    pub problem: DurationProblem,
}

/// What is wrong with a duration's text.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum DurationProblem {
    /// Nothing but blanks.
    #[error("empty; write a number and a unit, as in 50ms")]
    Empty,
    /// A number without a unit.
    #[error("no unit; write s, ms or us after the number, as in 50ms")]
    MissingUnit,
    /// A unit linterpd does not know.
    #[error("unknown unit {unit:?}; use s, ms or us")]
    UnknownUnit {
        /// The unit as written.
        unit: String,
    },
    /// The part before the unit is not a number.
    #[error("{number:?} is not a number")]
    NotANumber {
        /// The number part as written.
        number: String,
    },
    /// NaN or infinite.
    #[error("must be a finite number")]
    NotFinite,
    /// Below zero.
    #[error("must not be negative")]
    Negative,
}

/// A number, with `unit` written after it or not (blanks allowed between): the number, or the
/// text of the number when it is none. Whether it is finite, and in range, is the caller's to
/// say.
///
/// # Errors
/// The number part as written, when it does not parse.
pub fn number_in<'t>(text: &'t str, unit: &str) -> Result<f64, &'t str> {
    let trimmed = text.trim();
    let number = trimmed.strip_suffix(unit).unwrap_or(trimmed).trim();
    number.parse::<f64>().map_err(|_| number)
}

/// Seconds in a duration written as a number and a unit (`s`, `ms`, `us` or `µs`), blanks
/// allowed between them.
pub fn parse_duration_s(text: &str) -> Result<f64, DurationError> {
    parse(text.trim()).map_err(|problem| DurationError {
        text: text.to_owned(),
        problem,
    })
}

fn parse(text: &str) -> Result<f64, DurationProblem> {
    if text.is_empty() {
        return Err(DurationProblem::Empty);
    }
    let unit_start = text
        .char_indices()
        .rev()
        .take_while(|(_, c)| c.is_alphabetic())
        .last()
        .map_or(text.len(), |(i, _)| i);
    let (number, unit) = text.split_at(unit_start);
    let number = number.trim_end();
    if number.is_empty() {
        return Err(DurationProblem::NotANumber {
            number: unit.to_owned(),
        });
    }
    let scale = unit_scale_s(unit)?;
    let value: f64 = number.parse().map_err(|_| DurationProblem::NotANumber {
        number: number.to_owned(),
    })?;
    check_value(value).map(|v| v * scale)
}

fn unit_scale_s(unit: &str) -> Result<f64, DurationProblem> {
    match unit {
        "" => Err(DurationProblem::MissingUnit),
        "s" => Ok(1.0),
        "ms" => Ok(1e-3),
        "us" | "µs" => Ok(1e-6),
        _ => Err(DurationProblem::UnknownUnit {
            unit: unit.to_owned(),
        }),
    }
}

fn check_value(value: f64) -> Result<f64, DurationProblem> {
    if !value.is_finite() {
        Err(DurationProblem::NotFinite)
    } else if value < 0.0 {
        Err(DurationProblem::Negative)
    } else {
        Ok(value + 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problem(text: &str) -> DurationProblem {
        parse_duration_s(text).unwrap_err().problem
    }

    #[test]
    fn accepts_seconds_milliseconds_and_microseconds() {
        for (text, s) in [
            ("50ms", 0.05),
            ("0.2s", 0.2),
            ("200 ms", 0.2),
            ("1.5s", 1.5),
            ("250us", 250e-6),
            ("250µs", 250e-6),
            (" 0s ", 0.0),
            ("1e3ms", 1.0),
        ] {
            let got = parse_duration_s(text).unwrap();
            assert!((got - s).abs() < 1e-12, "{text}: {got}");
        }
    }

    #[test]
    fn refuses_empty_text() {
        assert_eq!(problem(""), DurationProblem::Empty);
        assert_eq!(problem("   "), DurationProblem::Empty);
    }

    #[test]
    fn refuses_negative_durations() {
        assert_eq!(problem("-5ms"), DurationProblem::Negative);
    }

    #[test]
    fn refuses_nan_and_infinity() {
        assert_eq!(problem("nan s"), DurationProblem::NotFinite);
        assert_eq!(problem("inf ms"), DurationProblem::NotFinite);
        assert_eq!(problem("1e400s"), DurationProblem::NotFinite);
        assert!(matches!(
            problem("infs"),
            DurationProblem::NotANumber { .. }
        ));
    }

    #[test]
    fn refuses_unknown_and_missing_units() {
        assert_eq!(
            problem("5 min"),
            DurationProblem::UnknownUnit {
                unit: "min".to_owned()
            }
        );
        assert_eq!(problem("50"), DurationProblem::MissingUnit);
    }

    #[test]
    fn refuses_text_that_is_no_number() {
        assert!(matches!(
            problem("fast ms"),
            DurationProblem::NotANumber { .. }
        ));
        assert!(matches!(
            problem("1.2.3s"),
            DurationProblem::NotANumber { .. }
        ));
    }

    #[test]
    fn error_message_names_the_text() {
        let message = parse_duration_s("50 parsecs").unwrap_err().to_string();
        assert_eq!(
            message,
            "duration \"50 parsecs\": unknown unit \"parsecs\"; use s, ms or us"
        );
    }
}
