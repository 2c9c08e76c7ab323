//! `linterpd plan` as a user runs it: the seed's move, its formats, and bad input.

mod common;

use common::cli::SEED;
use std::process::{Command, Output};

use serde_json::Value;

fn linterpd(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(args)
        .output()
        .expect("linterpd runs")
}

fn plan_json(extra: &[&str]) -> Value {
    let mut args = vec!["plan"];
    args.extend(SEED);
    args.extend(["--format", "json"]);
    args.extend(extra);
    let out = linterpd(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("json")
}

fn figure(doc: &Value, name: &str) -> f64 {
    doc["figures"][name]
        .as_f64()
        .unwrap_or_else(|| panic!("figure {name}"))
}

#[test]
fn seed_move_is_valid_and_no_worse_than_seed_exact() {
    let ours = plan_json(&[]);
    let seed = plan_json(&["--seed-exact"]);
    assert_eq!(ours["linterpd_plan"], 1);
    assert_eq!(ours["valid"], true);
    assert_eq!(seed["valid"], false);
    assert!(!seed["problems"].as_array().unwrap().is_empty());
    assert!(figure(&ours, "path_deviation_mm") <= figure(&seed, "path_deviation_mm"));
    assert_eq!(ours["robot"]["joints"][0]["unit"], "rad");
    assert_eq!(ours["profile"]["period_s"], 0.05);
}

#[test]
fn divider_plan_matches_the_ideal_one_and_ends_together() {
    let ideal = plan_json(&["--frequency-model", "ideal"]);
    let divider = plan_json(&["--frequency-model", "fpx-divider"]);
    let diff = (figure(&divider, "path_deviation_mm") - figure(&ideal, "path_deviation_mm")).abs();
    assert!(diff <= 0.02, "{diff}");
    assert!(figure(&divider, "end_skew_ms") < 1.0);
}

#[test]
fn json_rows_are_strictly_monotonic_segments_ending_on_the_channel_end() {
    let doc = plan_json(&[]);
    for ch in doc["channels"].as_array().unwrap() {
        let mut count = ch["start"].as_i64().unwrap();
        for seg in ch["segments"].as_array().unwrap() {
            let dir = seg["direction"].as_i64().unwrap();
            for row in seg["rows"].as_array().unwrap() {
                let target = row[1].as_i64().unwrap();
                assert!(
                    (target - count) * dir > 0,
                    "channel {}: {count} -> {target}",
                    ch["channel"]
                );
                count = target;
            }
        }
        assert_eq!(count, ch["end"].as_i64().unwrap());
    }
}

#[test]
fn csv_has_one_line_per_row() {
    let mut args = vec!["plan"];
    args.extend(SEED);
    args.extend(["--format", "csv"]);
    let out = linterpd(&args);
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("channel,joint,segment,row,frequency_hz,target,start_s,end_s")
    );
    let rows = plan_json(&[])["figures"]["rows"].as_u64().unwrap();
    assert_eq!(lines.count() as u64, rows);
}

/// Runs the seed's move with `args` replacing some of its values and expects bad input.
fn refused(replace: &[(&str, &str)], extra: &[&str]) -> String {
    let mut args: Vec<&str> = vec!["plan"];
    args.extend(SEED);
    for (flag, value) in replace {
        let at = args.iter().position(|a| a == flag).expect("flag in SEED") + 1;
        args[at] = value;
    }
    args.extend(extra);
    let out = linterpd(&args);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
    assert!(
        out.stdout.is_empty(),
        "printed as if it had worked: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    stderr
}

#[test]
fn bad_input_is_one_line_naming_value_and_limit_with_exit_code_2() {
    let e = refused(&[("--to", "-2000,1200,100")], &[]);
    assert!(
        e.contains("joint d3 would reach") && e.contains("limits are 0 to 1000 mm"),
        "{e}"
    );
    let e = refused(&[("--to", "-1144.43,659.60,500")], &[]);
    assert!(e.contains("joint d2") && e.contains("400 mm"), "{e}");
    let e = refused(&[("--to", "926.57,-535.03,50")], &[]);
    assert!(
        e.contains("from the base axis") && e.contains("at least 50 mm"),
        "{e}"
    );
    let e = refused(&[("--to", "-1144.43,NaN,186.6")], &[]);
    assert!(e.contains("'NaN' is not a finite number"), "{e}");
    let e = refused(&[("--to", "-1144.43,abc,186.6")], &[]);
    assert!(e.contains("'abc' is not a number"), "{e}");
    let e = refused(&[("--speed", "0")], &[]);
    assert!(
        e.contains("speed_mm_s is 0; it must be a number above 0"),
        "{e}"
    );
    let e = refused(&[("--speed", "-5")], &[]);
    assert!(e.contains("-5"), "{e}");
    let e = refused(&[("--period", "0ms")], &[]);
    assert!(e.contains("period_s is 0"), "{e}");
    let e = refused(&[("--period", "-1ms")], &[]);
    assert!(e.contains("--period"), "{e}");
    let e = refused(&[("--to", "-926.57,535.03,50")], &[]);
    assert!(e.contains("has length 0"), "{e}");
    let e = refused(&[], &["--robot", "welder"]);
    assert!(
        e.contains("\"welder\"") && e.contains("press-loader"),
        "{e}"
    );
    let e = refused(&[("--speed", "5000")], &[]);
    assert!(
        e.contains("would need") && e.contains("allows 20000 Hz"),
        "{e}"
    );
}

#[test]
fn missing_config_is_bad_input_naming_the_path() {
    let e = refused(&[("--config", "/nonexistent/linterpd.toml")], &[]);
    assert!(e.contains("/nonexistent/linterpd.toml"), "{e}");
}

#[test]
fn json_flag_is_format_json_and_speed_takes_its_unit() {
    let mut args = vec!["plan"];
    args.extend(SEED);
    let at = args.iter().position(|a| *a == "--speed").unwrap() + 1;
    args[at] = "240mm/s";
    args.push("--json");
    let out = linterpd(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(doc, plan_json(&[]));
    args.extend(["--format", "csv"]);
    let out = linterpd(&args);
    assert_eq!(out.status.code(), Some(2), "--json and --format conflict");
}

#[test]
fn a_path_file_plans_its_blended_cycle_within_the_tolerance_and_names_a_bad_element() {
    let example = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/config/examples/pick-and-place.toml"
    );
    let config = concat!(env!("CARGO_MANIFEST_DIR"), "/config/linterpd.toml");
    let out = linterpd(&[
        "plan",
        "--config",
        config,
        "--path",
        example,
        "--tolerance",
        "0.05mm",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_slice(&out.stdout).expect("json");
    let kinds: Vec<&str> = doc["path"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["kind"].as_str().unwrap())
        .collect();
    assert_eq!(kinds, ["line", "arc", "line"]);
    assert!(doc["path"][1]["element"].is_null());
    assert_eq!(doc["sections"].as_array().unwrap().len(), 1);
    assert!(doc["valid"].as_bool().unwrap());
    let deviation = doc["path_deviation_mm"].as_f64().unwrap();
    assert!(deviation <= 0.05, "{deviation} mm");
    // The text form says the same.
    let out = linterpd(&[
        "plan",
        "--config",
        config,
        "--path",
        example,
        "--tolerance",
        "0.05mm",
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("blend       arc"), "{text}");
    assert!(text.contains("valid    yes"), "{text}");

    let dir = std::env::temp_dir().join(format!("linterpd-path-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[element]]\nline = [1, 2, 3]\n[[element]]\narc = [4, 5, 6]\n",
    )
    .unwrap();
    let out = linterpd(&[
        "plan",
        "--config",
        config,
        "--path",
        bad.to_str().unwrap(),
        "--from",
        "-926.57,535.03,50",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("element 2: an arc needs `via = [x, y, z]` or `centre = [x, y, z]`"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
