//! The API's answers about taught positions, as the daemon writes them and the CLI reads them
//! back. The list, a save and a delete are written through a `serde_json::Value`, whose maps
//! keep their keys sorted, as these answers always were.

use serde::{Deserialize, Serialize};

use crate::daemon::Position;

/// A taught position with its name (`GET .../positions/{pos}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NamedPosition {
    /// Its name.
    pub name: String,
    /// The position.
    #[serde(flatten)]
    pub position: Position,
}

/// `GET .../positions`: every taught position of a robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositionList {
    /// The positions, by name.
    pub positions: Vec<NamedPosition>,
    /// What went wrong with the positions file at start, if anything did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// `PUT .../positions/{pos}`: the position saved.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SavedPosition {
    /// The position.
    #[serde(flatten)]
    pub saved: NamedPosition,
    /// Whether it replaced one of the same name.
    pub replaced: bool,
    /// What went wrong with the positions file at start, if anything did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// `DELETE .../positions/{pos}`: the position deleted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeletedPosition {
    /// The position.
    pub deleted: NamedPosition,
}

/// `answer` as JSON with its keys sorted (a `serde_json::Value`'s maps are ordered by key).
pub(super) fn sorted(answer: &impl Serialize) -> serde_json::Value {
    serde_json::to_value(answer).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pick() -> NamedPosition {
        NamedPosition {
            name: "pick".into(),
            position: Position {
                pose: [-0.0, 520.0, 20.5, 90.0],
                joint_counts: [0, 800, 1538, 0],
                saved_unix_s: 1_700_000_000,
                frame: None,
            },
        }
    }

    /// The answers as the handlers wrote them before issue 26 typed them, read back.
    #[test]
    fn position_answers_are_written_as_before_and_read_back() {
        let shown = r#"{"name":"pick","pose":[-0.0,520.0,20.5,90.0],"joint_counts":[0,800,1538,0],"saved_unix_s":1700000000}"#;
        let sorted_pick = r#"{"joint_counts":[0,800,1538,0],"name":"pick","pose":[-0.0,520.0,20.5,90.0],"saved_unix_s":1700000000}"#;
        assert_eq!(serde_json::to_string(&pick()).unwrap(), shown);
        assert_eq!(
            serde_json::from_str::<NamedPosition>(shown).unwrap(),
            pick()
        );
        let list = PositionList {
            positions: vec![pick()],
            warning: Some("set aside".into()),
        };
        let list_json = format!(r#"{{"positions":[{sorted_pick}],"warning":"set aside"}}"#);
        assert_eq!(sorted(&list).to_string(), list_json);
        assert_eq!(
            serde_json::from_str::<PositionList>(&list_json).unwrap(),
            list
        );
        let saved = SavedPosition {
            saved: pick(),
            replaced: true,
            warning: None,
        };
        let saved_json = r#"{"joint_counts":[0,800,1538,0],"name":"pick","pose":[-0.0,520.0,20.5,90.0],"replaced":true,"saved_unix_s":1700000000}"#;
        assert_eq!(sorted(&saved).to_string(), saved_json);
        assert_eq!(
            serde_json::from_str::<SavedPosition>(saved_json).unwrap(),
            saved
        );
        let deleted = DeletedPosition { deleted: pick() };
        let deleted_json = format!(r#"{{"deleted":{sorted_pick}}}"#);
        assert_eq!(sorted(&deleted).to_string(), deleted_json);
        assert_eq!(
            serde_json::from_str::<DeletedPosition>(&deleted_json).unwrap(),
            deleted
        );
    }
}
