//! The validation pass's tools: [`At`], a key path in the file's text, which turns a spanned raw
//! value into a checked one or into a [`ConfigError`] naming the line, the key and the value.

use std::fmt::Display;
use std::ops::Range;

use toml::Spanned;

use super::ConfigError;
use super::locate::line_of;

/// A key path (`robots.press-loader.joints[2]`) in the config text.
#[derive(Debug, Clone)]
pub(super) struct At<'t> {
    text: &'t str,
    key: String,
}

impl<'t> At<'t> {
    /// The path `key` at the top of `text`.
    pub(super) fn new(text: &'t str, key: &str) -> Self {
        Self {
            text,
            key: key.to_owned(),
        }
    }

    /// The key `name` inside this table.
    pub(super) fn child(&self, name: &str) -> Self {
        Self::new(self.text, &format!("{}.{name}", self.key))
    }

    /// Table `index` of this array.
    pub(super) fn index(&self, index: usize) -> Self {
        Self::new(self.text, &format!("{}[{index}]", self.key))
    }

    /// The key path.
    pub(super) fn key(&self) -> &str {
        &self.key
    }

    /// The 1-based line of a span.
    pub(super) fn line(&self, span: &Range<usize>) -> usize {
        line_of(self.text, span.start)
    }

    /// This key's value is refused.
    pub(super) fn invalid<T: Shown>(
        &self,
        value: &Spanned<T>,
        reason: impl Display,
    ) -> ConfigError {
        ConfigError::Invalid {
            line: self.line(&value.span()),
            key: self.key.clone(),
            value: value.get_ref().shown(),
            reason: reason.to_string(),
        }
    }

    /// This key is absent from the table at `table`.
    pub(super) fn missing(&self, table: &Range<usize>, reason: impl Display) -> ConfigError {
        ConfigError::Missing {
            line: self.line(table),
            key: self.key.clone(),
            reason: reason.to_string(),
        }
    }

    /// A finite number.
    pub(super) fn finite(&self, value: &Spanned<f64>) -> Result<f64, ConfigError> {
        let v = *value.get_ref();
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.invalid(value, "must be a finite number"))
        }
    }

    /// A finite number above 0.
    pub(super) fn positive(&self, value: &Spanned<f64>) -> Result<f64, ConfigError> {
        let v = self.finite(value)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.invalid(value, "must be above 0"))
        }
    }

    /// A finite number at least 0.
    pub(super) fn non_negative(&self, value: &Spanned<f64>) -> Result<f64, ConfigError> {
        let v = self.finite(value)?;
        if v >= 0.0 {
            Ok(v + 0.0)
        } else {
            Err(self.invalid(value, "must be at least 0"))
        }
    }

    /// An integer within `min..=max`.
    pub(super) fn int_within(
        &self,
        value: &Spanned<i64>,
        min: i64,
        max: i64,
    ) -> Result<i64, ConfigError> {
        let v = *value.get_ref();
        if (min..=max).contains(&v) {
            Ok(v)
        } else {
            Err(self.invalid(value, format!("must be within {min}..={max}")))
        }
    }
}

/// A raw value as it would be written in TOML.
pub(super) trait Shown {
    /// The TOML spelling.
    fn shown(&self) -> String;
}

impl Shown for f64 {
    fn shown(&self) -> String {
        match self {
            v if v.is_nan() => "nan".to_owned(),
            v if v.is_infinite() && *v > 0.0 => "inf".to_owned(),
            v if v.is_infinite() => "-inf".to_owned(),
            v => v.to_string(),
        }
    }
}

impl Shown for i64 {
    fn shown(&self) -> String {
        self.to_string()
    }
}

impl Shown for Vec<Spanned<i64>> {
    fn shown(&self) -> String {
        let items: Vec<String> = self.iter().map(|v| v.get_ref().to_string()).collect();
        format!("[{}]", items.join(", "))
    }
}

impl Shown for bool {
    fn shown(&self) -> String {
        self.to_string()
    }
}

impl Shown for String {
    fn shown(&self) -> String {
        format!("{self:?}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shown_spells_values_as_toml_does() {
        assert_eq!(f64::NAN.shown(), "nan");
        assert_eq!(f64::NEG_INFINITY.shown(), "-inf");
        assert_eq!(0.0025.shown(), "0.0025");
        assert_eq!(500.0.shown(), "500");
        assert_eq!("50 ms".to_owned().shown(), "\"50 ms\"");
    }
}
