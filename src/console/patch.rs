//! PURE. A snapshot's changes as a JSON merge patch (RFC 7396): only the fields that changed,
//! objects diffed field by field, anything else (numbers, strings, arrays) sent whole when it
//! changed, a field that went away as `null`. The page and `linterpd status --watch` apply it to
//! the snapshot they hold with [`apply`] (the page with the same ten lines of JavaScript).

use serde_json::{Map, Value};

/// What turns `old` into `new` as a merge patch; `None` when nothing changed.
#[must_use]
pub fn diff(old: &Value, new: &Value) -> Option<Value> {
    match (old, new) {
        (Value::Object(a), Value::Object(b)) => {
            let mut patch = Map::new();
            for (key, b_value) in b {
                let changed = match a.get(key) {
                    Some(a_value) => diff(a_value, b_value),
                    // A new field; a null one stands for itself only as a nested null object.
                    None => Some(b_value.clone()),
                };
                if let Some(change) = changed {
                    patch.insert(key.clone(), change);
                }
            }
            for key in a.keys() {
                if !b.contains_key(key) {
                    patch.insert(key.clone(), Value::Null);
                }
            }
            (!patch.is_empty()).then_some(Value::Object(patch))
        }
        // `null` in a patch means "remove": a field whose value became null is removed, and
        // reads back as absent, which the snapshot's readers take as null.
        _ if old == new => None,
        _ => Some(new.clone()),
    }
}

/// Applies a merge patch to `target` (RFC 7396, section 2).
pub fn apply(target: &mut Value, patch: &Value) {
    let Value::Object(changes) = patch else {
        *target = patch.clone();
        return;
    };
    if !target.is_object() {
        *target = Value::Object(Map::new());
    }
    let Value::Object(fields) = target else {
        return;
    };
    for (key, change) in changes {
        if change.is_null() {
            fields.remove(key);
        } else {
            apply(fields.entry(key.clone()).or_insert(Value::Null), change);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn only_changed_fields_are_sent() {
        let old = json!({"phase": "running", "counts": [1, 2, 3, 4], "link": {"connected": true, "reconnects": 0}});
        let new = json!({"phase": "running", "counts": [1, 2, 3, 5], "link": {"connected": true, "reconnects": 1}});
        assert_eq!(
            diff(&old, &new),
            Some(json!({"counts": [1, 2, 3, 5], "link": {"reconnects": 1}}))
        );
    }

    #[test]
    fn nothing_changed_is_no_patch() {
        let v = json!({"a": {"b": [1, {"c": 2}]}, "d": null});
        assert_eq!(diff(&v, &v), None);
    }

    #[test]
    fn a_removed_or_nulled_field_is_null_in_the_patch() {
        let old = json!({"fault": 7, "cycle": {"step": 3}});
        let new = json!({"fault": null});
        let patch = diff(&old, &new).unwrap();
        assert_eq!(patch, json!({"fault": null, "cycle": null}));
        let mut applied = old.clone();
        apply(&mut applied, &patch);
        assert_eq!(applied, json!({}));
    }

    #[test]
    fn applying_the_diff_gives_the_new_snapshot_back() {
        let cases = [
            (json!({}), json!({"a": 1, "b": {"c": [1, 2]}})),
            (json!({"a": {"x": 1, "y": 2}}), json!({"a": {"x": 1}})),
            (json!({"a": [1, 2]}), json!({"a": {"now": "an object"}})),
            (
                json!({"a": {"b": {"c": 1}}}),
                json!({"a": {"b": {"c": 2, "d": "x"}}}),
            ),
            (json!({"a": 1}), json!({"a": "one"})),
        ];
        for (old, new) in cases {
            let mut applied = old.clone();
            if let Some(patch) = diff(&old, &new) {
                apply(&mut applied, &patch);
            }
            assert_eq!(applied, new, "{old} -> {new}");
        }
    }
}
