//! Wall time as the journal writes it: ms since the Unix epoch <-> RFC 3339 in UTC
//! (`2026-11-29T08:48:01.123Z`), the civil calendar by Howard Hinnant's days-from-civil
//! arithmetic (proleptic Gregorian), and spans as the CLI takes them (`10m`, `8h`).

use thiserror::Error;

const MS_PER_DAY: i64 = 86_400_000;

/// Why a time or a span was not taken.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum TimeError {
    /// Not an RFC 3339 time.
    #[error(
        "{text:?} is not an RFC 3339 time (e.g. 2026-11-29T08:00:00Z or \
         2026-11-29T09:00:00+01:00)"
    )]
    Time {
        /// What was given.
        text: String,
    },
    /// Not a span.
    #[error("{text:?} is not a span: a whole number and s, m, h or d (e.g. 10m, 8h)")]
    Span {
        /// What was given.
        text: String,
    },
}

/// `ms` since the epoch as RFC 3339 in UTC, to the millisecond.
#[must_use]
pub fn format_rfc3339(ms: u64) -> String {
    let ms = ms as i64;
    let (days, in_day) = (ms.div_euclid(MS_PER_DAY), ms.rem_euclid(MS_PER_DAY));
    let (y, m, d) = civil_from_days(days);
    let s = in_day / 1000;
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}.{:03}Z",
        s / 3600,
        s / 60 % 60,
        s % 60,
        in_day % 1000
    )
}

/// An RFC 3339 time (`Z` or an offset, fractions of a second optional) as ms since the epoch.
pub fn parse_rfc3339(text: &str) -> Result<u64, TimeError> {
    let bad = || TimeError::Time {
        text: text.to_owned(),
    };
    let b = text.trim().as_bytes();
    if b.len() < 20 || b[4] != b'-' || b[7] != b'-' || !matches!(b[10], b'T' | b't' | b' ') {
        return Err(bad());
    }
    let num = |from: usize, to: usize| -> Result<i64, TimeError> {
        let part = std::str::from_utf8(&b[from..to]).map_err(|_| bad())?;
        if part.bytes().all(|c| c.is_ascii_digit()) {
            part.parse().map_err(|_| bad())
        } else {
            Err(bad())
        }
    };
    let (y, mo, d) = (num(0, 4)?, num(5, 7)?, num(8, 10)?);
    if b[13] != b':' || b[16] != b':' {
        return Err(bad());
    }
    let (h, mi, s) = (num(11, 13)?, num(14, 16)?, num(17, 19)?);
    if !(1..=12).contains(&mo) || !(1..=31).contains(&d) || h > 23 || mi > 59 || s > 60 {
        return Err(bad());
    }
    let (frac_ms, rest) = fraction(&b[19..]).ok_or_else(bad)?;
    let offset_min = offset(rest).ok_or_else(bad)?;
    let ms = days_from_civil(y, mo, d) * MS_PER_DAY
        + ((h * 60 + mi - offset_min) * 60 + s) * 1000
        + frac_ms;
    u64::try_from(ms).map_err(|_| bad())
}

/// `.123...` at the start of `b`: its ms and what follows.
fn fraction(b: &[u8]) -> Option<(i64, &[u8])> {
    if b.first() != Some(&b'.') {
        return Some((0, b));
    }
    let digits = b[1..].iter().take_while(|c| c.is_ascii_digit()).count();
    if digits == 0 {
        return None;
    }
    let mut ms = 0;
    for i in 0..3 {
        let digit = b
            .get(1 + i)
            .filter(|c| c.is_ascii_digit())
            .map_or(0, |c| c - b'0');
        ms = ms * 10 + i64::from(digit);
    }
    Some((ms, &b[1 + digits..]))
}

/// `Z` or `+hh:mm` / `-hh:mm`, in minutes east of UTC.
fn offset(b: &[u8]) -> Option<i64> {
    match b {
        [b'Z' | b'z'] => Some(0),
        [sign @ (b'+' | b'-'), h1, h2, b':', m1, m2] => {
            let digits = [*h1, *h2, *m1, *m2];
            if !digits.iter().all(u8::is_ascii_digit) {
                return None;
            }
            let v = |a: u8, b: u8| i64::from(a - b'0') * 10 + i64::from(b - b'0');
            let minutes = v(*h1, *h2) * 60 + v(*m1, *m2);
            Some(if *sign == b'-' { -minutes } else { minutes })
        }
        _ => None,
    }
}

/// A span as the CLI takes it (`30s`, `10m`, `8h`, `2d`), in ms.
pub fn parse_span_ms(text: &str) -> Result<u64, TimeError> {
    let bad = || TimeError::Span {
        text: text.to_owned(),
    };
    let t = text.trim();
    let unit_at = t.find(|c: char| !c.is_ascii_digit()).ok_or_else(bad)?;
    let (number, unit) = t.split_at(unit_at);
    let n: u64 = number.parse().map_err(|_| bad())?;
    let scale = match unit {
        "s" => 1_000,
        "m" | "min" => 60_000,
        "h" => 3_600_000,
        "d" => MS_PER_DAY as u64,
        _ => return Err(bad()),
    };
    n.checked_mul(scale).filter(|ms| *ms > 0).ok_or_else(bad)
}

/// Days since 1970-01-01 of a civil date.
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The civil date of a day since 1970-01-01.
fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (
        if m <= 2 {
            yoe + era * 400 + 1
        } else {
            yoe + era * 400
        },
        m,
        d,
    )
}

/// serde for [`super::Entry::at_ms`]: RFC 3339 on the wire.
pub(super) mod as_rfc3339 {
    use serde::{Deserialize, Deserializer, Serializer};

    #[allow(
        clippy::trivially_copy_pass_by_ref,
        reason = "serde's `with` passes by reference"
    )]
    pub(in crate::wire::journal) fn serialize<S: Serializer>(
        ms: &u64,
        out: S,
    ) -> Result<S::Ok, S::Error> {
        out.serialize_str(&super::format_rfc3339(*ms))
    }

    pub(in crate::wire::journal) fn deserialize<'de, D: Deserializer<'de>>(
        from: D,
    ) -> Result<u64, D::Error> {
        let text = String::deserialize(from)?;
        super::parse_rfc3339(&text).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_instants_format_and_parse_both_ways() {
        // Python's datetime.fromtimestamp(ms / 1000, timezone.utc) agrees.
        let cases = [
            (0, "1970-01-01T00:00:00.000Z"),
            (951_868_800_000, "2000-03-01T00:00:00.000Z"),
            (1_709_164_800_000, "2024-02-29T00:00:00.000Z"),
            (1_795_855_681_123, "2026-11-28T08:48:01.123Z"),
        ];
        for (ms, text) in cases {
            assert_eq!(format_rfc3339(ms), text);
            assert_eq!(parse_rfc3339(text), Ok(ms), "{text}");
        }
    }

    #[test]
    fn an_offset_and_a_long_fraction_are_taken() {
        let utc = parse_rfc3339("2026-11-29T08:00:00Z").unwrap();
        assert_eq!(parse_rfc3339("2026-11-29T09:30:00+01:30"), Ok(utc));
        assert_eq!(parse_rfc3339("2026-11-29T03:00:00-05:00"), Ok(utc));
        assert_eq!(
            parse_rfc3339("2026-11-29T08:00:00.123456789Z"),
            Ok(utc + 123)
        );
    }

    #[test]
    fn bad_times_and_spans_are_refused_naming_them() {
        for text in [
            "",
            "2026-11-29",
            "2026-13-01T00:00:00Z",
            "2026-11-29T08:00:00",
            "x",
        ] {
            let e = parse_rfc3339(text).unwrap_err();
            assert!(
                e.to_string().starts_with(&format!("{text:?} is not")),
                "{e}"
            );
        }
        for text in ["", "10", "m", "10y", "0s", "-5m"] {
            assert!(parse_span_ms(text).is_err(), "{text}");
        }
        assert_eq!(parse_span_ms("10m"), Ok(600_000));
        assert_eq!(parse_span_ms("8h"), Ok(28_800_000));
        assert_eq!(parse_span_ms("2d"), Ok(172_800_000));
    }
}
