//! Places in the config text: byte offset -> line number; the key path of a schema error, as
//! serde walked it (`serde_path_to_error`: exact inside inline tables and arrays), else read off
//! the text for a syntax error the TOML parser reports with a span but without a key path; and
//! the nearest valid key of an unknown one ("did you mean").

use std::fmt::Write as _;

use super::ConfigError;

/// The 1-based line holding byte `offset` of `text`.
pub(super) fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end].split(|&b| b == b'\n').count()
}

/// Parses `text` into `T` strictly: a syntax error placed on its line, a schema error (unknown
/// key, wrong type, missing key) on its line with the exact key path serde walked, and the
/// nearest valid key of an unknown one.
pub(super) fn parse<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, ConfigError> {
    let de = toml::Deserializer::parse(text).map_err(|e| syntax_error(text, &e, None))?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let offset = e.inner().span().map_or(0, |span| span.start);
        let path = key_path(e.path(), key_at(text, offset).as_deref());
        syntax_error(text, e.inner(), path)
    })
}

/// A serde path as a config key path (`robots.press-loader.plc.serial.parity`), without the
/// segments `toml::Spanned` walks through. A key serde could not see (a robot's name, a
/// `Spanned` map key) is taken from `read`, the path read off the line, where their segments
/// before it agree; `None` when nothing is left.
fn key_path(path: &serde_path_to_error::Path, read: Option<&str>) -> Option<String> {
    use serde_path_to_error::Segment;
    let read: Vec<&str> = read.map(|r| r.split('.').collect()).unwrap_or_default();
    let mut parts: Vec<String> = Vec::new();
    for segment in path {
        match segment {
            Segment::Map { key } if key.starts_with("$__serde_spanned_private") => {}
            Segment::Seq { index } => match parts.last_mut() {
                Some(last) => {
                    let _ = write!(last, "[{index}]");
                }
                None => parts.push(format!("[{index}]")),
            },
            Segment::Map { key } | Segment::Enum { variant: key } => parts.push(key.clone()),
            Segment::Unknown => {
                let agree =
                    read.len() > parts.len() && parts.iter().zip(&read).all(|(p, r)| p == r);
                parts.push(if agree { read[parts.len()] } else { "?" }.to_owned());
            }
        }
    }
    (!parts.is_empty()).then(|| parts.join("."))
}

/// A TOML or schema error, placed on its line, with `path` (else the key read off the line) and
/// the nearest valid key when it names an unknown one.
pub(super) fn syntax_error(
    text: &str,
    error: &toml::de::Error,
    path: Option<String>,
) -> ConfigError {
    let offset = error.span().map_or(0, |span| span.start);
    let message = error.message().trim_end().to_owned();
    let message = match super::suggest::hint(&message) {
        Some(hint) => format!("{message}; {hint}"),
        None => message,
    };
    ConfigError::Syntax {
        line: line_of(text, offset),
        key: path.or_else(|| key_at(text, offset)),
        message,
    }
}

/// The key path of the line holding `offset`: its table header's path, `[i]` for the i-th table
/// of an array of tables, and the line's own key. `None` where the text is not plain enough to
/// be sure (quoted keys, multi-line values, text before any key).
pub(super) fn key_at(text: &str, offset: usize) -> Option<String> {
    let index = line_of(text, offset) - 1;
    let lines: Vec<&str> = text.lines().collect();
    let line = strip_comment(lines.get(index)?);
    if let Some(header) = header_path(&lines, index) {
        return Some(header);
    }
    let (key, _) = line.split_once('=')?;
    let key = bare_key(key)?;
    match (0..index)
        .rev()
        .find(|&i| strip_comment(lines[i]).starts_with('['))
    {
        Some(table) => Some(format!("{}.{key}", header_path(&lines, table)?)),
        None => Some(key),
    }
}

/// The path of the header on line `index`, if that line is a plain header.
fn header_path(lines: &[&str], index: usize) -> Option<String> {
    let line = strip_comment(lines[index]);
    if let Some(inner) = line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")) {
        let path = bare_key(inner)?;
        let nth = lines[..index]
            .iter()
            .filter(|l| strip_comment(l) == line)
            .count();
        return Some(format!("{path}[{nth}]"));
    }
    let inner = line.strip_prefix('[')?.strip_suffix(']')?;
    bare_key(inner)
}

/// A line without its comment and surrounding blanks (a `#` inside a string ends it too early,
/// which only costs the key path, never a wrong one: such a line has no bare key).
fn strip_comment(line: &str) -> &str {
    line.split_once('#').map_or(line, |(code, _)| code).trim()
}

/// A dotted key made only of bare keys, normalised (`a . b` -> `a.b`).
fn bare_key(text: &str) -> Option<String> {
    let parts: Vec<&str> = text.split('.').map(str::trim).collect();
    let bare = |p: &&str| {
        !p.is_empty()
            && p.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    };
    parts.iter().all(bare).then(|| parts.join("."))
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "[robots.a]\narea_words = 3 # c\n[[robots.a.joints]]\nname = \"x\"\n\
                        [[robots.a.joints]]\nname = \"y\"\n";

    fn offset_of(needle: &str) -> usize {
        TEXT.find(needle).unwrap()
    }

    #[test]
    fn line_of_counts_newlines_before_the_offset() {
        assert_eq!(line_of(TEXT, 0), 1);
        assert_eq!(line_of(TEXT, offset_of("area_words")), 2);
        assert_eq!(line_of(TEXT, TEXT.len() + 10), 7);
    }

    #[test]
    fn key_at_joins_header_and_key() {
        assert_eq!(
            key_at(TEXT, offset_of("3 # c")).as_deref(),
            Some("robots.a.area_words")
        );
    }

    #[test]
    fn key_at_numbers_tables_of_an_array() {
        assert_eq!(
            key_at(TEXT, offset_of("\"y\"")).as_deref(),
            Some("robots.a.joints[1].name")
        );
        assert_eq!(
            key_at(TEXT, offset_of("\"x\"")).as_deref(),
            Some("robots.a.joints[0].name")
        );
    }

    #[test]
    fn key_at_gives_up_on_quoted_keys() {
        let text = "[robots.a]\n[robots.\"a b\"]\nx = 1\n";
        assert_eq!(key_at(text, text.find("x =").unwrap()), None);
    }
}
