//! Whether a program of a programs directory is there at all, asked before anything in the
//! directory is read: `cycle run NAME` with no `NAME.toml` says so, whatever else the directory
//! holds (a neighbour that does not parse, two programs with one number).

use std::path::Path;

/// `None` when `dir` holds `name.toml`; else why not, naming the programs it has.
#[must_use]
pub fn missing(dir: &Path, name: &str) -> Option<String> {
    let plain = !name.is_empty() && !name.contains(['/', '\\']) && name != "." && name != "..";
    if plain && dir.join(format!("{name}.toml")).is_file() {
        return None;
    }
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("toml"))
                .filter_map(|p| p.file_stem()?.to_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    Some(format!(
        "program {name:?}: no such program; there are: {} (in {}, which has no {name}.toml)",
        if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        },
        dir.display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cycle_run_of_a_missing_program_says_so_whatever_its_neighbours_hold() {
        let dir = std::env::temp_dir().join(format!("linterpd-names-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("good.toml"), "[[step]]\ndwell = \"1s\"\n").unwrap();
        std::fs::write(dir.join("broken.toml"), "this is not toml").unwrap();
        assert_eq!(missing(&dir, "good"), None);
        let e = missing(&dir, "nosuch").unwrap();
        assert_eq!(
            e,
            format!(
                "program \"nosuch\": no such program; there are: broken, good (in {}, which has \
                 no nosuch.toml)",
                dir.display()
            )
        );
        assert!(missing(&dir, "../good").is_some());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
