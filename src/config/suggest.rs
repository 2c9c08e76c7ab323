//! PURE. "Did you mean": the valid name nearest a misspelt one, for serde's "unknown field" and
//! "unknown variant" messages (unknown field \`partiy\`, expected one of \`path\`, \`baud\`,
//! ...), which every strict TOML document of linterpd (the config, a mock's cell description)
//! reports through `toml`.

/// The candidate nearest `word` by edit distance, if it is near enough to be a typo: at most a
/// third of the word's length (and at least 1) edits away. Ties go to the first candidate.
#[must_use]
pub fn nearest<'a>(word: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let limit = (word.chars().count() / 3).max(1);
    candidates
        .iter()
        .map(|c| (edit_distance(word, c), *c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// Levenshtein distance between `a` and `b`, by characters.
#[must_use]
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substituted = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substituted.min(row[j] + 1).min(diagonal + 1);
        }
    }
    row[b.len()]
}

/// For serde's message about an unknown field or variant, the hint ``did you mean `parity`?``
/// naming the nearest valid one; `None` for any other message, or when none is near.
#[must_use]
pub fn hint(message: &str) -> Option<String> {
    let (word, expected) = unknown_and_expected(message)?;
    let candidates: Vec<&str> = expected
        .split('`')
        .skip(1)
        .step_by(2)
        .filter(|c| !c.is_empty())
        .collect();
    nearest(word, &candidates).map(|c| format!("did you mean `{c}`?"))
}

/// The unknown word and the text listing what was expected, from serde's message.
fn unknown_and_expected(message: &str) -> Option<(&str, &str)> {
    let rest = message
        .strip_prefix("unknown field `")
        .or_else(|| message.strip_prefix("unknown variant `"))?;
    let (word, expected) = rest.split_once('`')?;
    let expected = expected.strip_prefix(", expected")?;
    Some((word, expected))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edit_distance_counts_insertions_deletions_and_substitutions() {
        assert_eq!(edit_distance("parity", "parity"), 0);
        assert_eq!(edit_distance("partiy", "parity"), 2);
        assert_eq!(edit_distance("paity", "parity"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(edit_distance("stroke", "strok"), 1);
    }

    #[test]
    fn a_misspelt_field_gets_the_nearest_valid_one() {
        let message = "unknown field `partiy`, expected one of `path`, `baud`, `data_bits`, \
                       `parity`, `stop_bits`";
        assert_eq!(hint(message).as_deref(), Some("did you mean `parity`?"));
        let one = "unknown field `pth`, expected `path`";
        assert_eq!(hint(one).as_deref(), Some("did you mean `path`?"));
        let variant = "unknown variant `cylindricl`, expected one of `cylindrical`, `cartesian`";
        assert_eq!(
            hint(variant).as_deref(),
            Some("did you mean `cylindrical`?")
        );
    }

    #[test]
    fn a_word_far_from_every_valid_one_gets_no_hint() {
        let message = "unknown field `colour`, expected one of `path`, `baud`";
        assert_eq!(hint(message), None);
        assert_eq!(hint("invalid type: string \"x\", expected u32"), None);
        assert_eq!(nearest("x", &[]), None);
    }
}
