//! `linterpd plan` as a user runs it: the seed's move, its formats, and bad input.

use crate::common;

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
    // One section between stops, planned as two starts: cut where d2 reverses at the top of
    // the blend while the other joints move.
    assert_eq!(doc["sections"].as_array().unwrap().len(), 2);
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
    assert!(text.contains("blend 1     arc"), "{text}");
    assert!(text.contains("1 (section 1, element 1): "), "{text}");
    assert!(
        text.contains("2 (section 1, element 2), chained at speed: "),
        "{text}"
    );
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

const EXAMPLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/config/examples/pick-and-place.toml"
);
const CONFIG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/config/linterpd.toml");

/// `linterpd plan --path FILE --tolerance 0.05mm` with `extra`, which must succeed.
fn plan_path(file: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "plan",
        "--config",
        CONFIG,
        "--path",
        file,
        "--tolerance",
        "0.05mm",
    ];
    args.extend(extra);
    let out = linterpd(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn num(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("{v} is no number"))
}

#[test]
fn a_paths_json_lists_its_blend_as_the_arc_paths_md_gives_with_figures_measured_against_it() {
    let doc: Value = serde_json::from_slice(&plan_path(EXAMPLE, &["--json"]).stdout).unwrap();
    let path = doc["path"].as_array().unwrap();
    // docs/PATHS.md: the 20 mm blend is an arc of radius 8.63 mm turning 133.3 deg.
    let blend = &path[1];
    assert_eq!(blend["kind"], "arc");
    assert_eq!(blend["waypoint"], 1);
    assert!((num(&blend["radius_mm"]) - 8.63).abs() < 0.005, "{blend}");
    assert!((num(&blend["sweep_deg"]) - 133.3).abs() < 0.05, "{blend}");
    assert_eq!(path[0]["element"], 1);
    assert!(path[0]["waypoint"].is_null());
    // The arc's centre is one radius from both its ends.
    let centre: Vec<f64> = blend["centre"]
        .as_array()
        .unwrap()
        .iter()
        .map(num)
        .collect();
    for end in ["from", "to"] {
        let p: Vec<f64> = blend[end].as_array().unwrap().iter().map(num).collect();
        let r = (0..3)
            .map(|i| (p[i] - centre[i]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!((r - num(&blend["radius_mm"])).abs() < 1e-6, "{end}: {r} mm");
    }
    // Each primitive in time, one after the other, the last ending with the path.
    let mut t = 0.0;
    for p in path {
        assert!((num(&p["start_s"]) - t).abs() < 1e-9, "{p}");
        t = num(&p["end_s"]);
        assert!(t > num(&p["start_s"]), "{p}");
        assert_eq!(p["section"], 1);
    }
    assert!((t - num(&doc["duration_s"])).abs() < 1e-9);
    // The worst primitive holds the path's deviation, and the blend is within the tolerance.
    let worst = path
        .iter()
        .map(|p| num(&p["path_deviation_mm"]))
        .fold(0.0, f64::max);
    assert!(
        (worst - num(&doc["path_deviation_mm"])).abs() < 1e-9,
        "{worst}"
    );
    assert!(num(&blend["path_deviation_mm"]) > 0.0);
    assert!(num(&blend["path_deviation_mm"]) <= 0.05);
    // Two starts (cut at d2's reversal), each with its figures beside the plan document's.
    let starts = doc["starts"].as_array().unwrap();
    assert_eq!(starts.len(), 2);
    for (k, (start, elements)) in starts.iter().zip(["1", "2"]).enumerate() {
        assert_eq!(start["elements"], elements);
        assert_eq!(start["rows"], doc["sections"][k]["figures"]["rows"]);
        assert_eq!(
            start["tracking_error_mm"],
            doc["sections"][k]["figures"]["tracking_error_mm"]
        );
    }
    let tracking = starts
        .iter()
        .map(|s| num(&s["tracking_error_mm"]))
        .fold(0.0, f64::max);
    assert!((tracking - num(&doc["tracking_error_mm"])).abs() < 1e-12);
}

#[test]
fn a_path_with_a_stop_gives_one_csv_of_every_starts_rows_and_an_svg_of_its_arc() {
    let dir = std::env::temp_dir().join(format!("linterpd-path-csv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The example with a stop after the first line: element 1, then 2 with a blend, then 3.
    let file = dir.join("stopped.toml");
    std::fs::write(
        &file,
        "start = [-926.57, 535.03, 50.0]\npath_accel = \"5000mm/s2\"\n\
         [[element]]\nline = [-926.57, 535.03, 60.0]\n\
         [[element]]\nline = [-1144.43, 659.60, 286.60]\nblend = \"20mm\"\n\
         [[element]]\nline = [-1144.43, 659.60, 186.60]\n",
    )
    .unwrap();
    let file = file.to_str().unwrap();
    let doc: Value = serde_json::from_slice(&plan_path(file, &["--json"]).stdout).unwrap();
    // The stop after element 1, then element 2 cut where d2 reverses at the top of the blend.
    assert_eq!(doc["starts"].as_array().unwrap().len(), 3);
    assert_eq!(doc["starts"][1]["elements"], "2");
    assert_eq!(doc["starts"][2]["elements"], "3");
    let svg = dir.join("path.svg");
    let out = plan_path(file, &["--format", "csv", "--svg", svg.to_str().unwrap()]);
    let csv = String::from_utf8(out.stdout).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "start,section,channel,joint,segment,row,frequency_hz,target,start_s,end_s,\
         path_start_s,path_end_s"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // As many lines as the plans' tables have rows, each start's under its number.
    for (n, start) in doc["starts"].as_array().unwrap().iter().enumerate() {
        let mine = rows.iter().filter(|r| r[0] == (n + 1).to_string()).count();
        assert_eq!(mine as u64, start["rows"].as_u64().unwrap());
    }
    assert_eq!(rows.len() as u64, doc["rows"].as_u64().unwrap());
    // The second start's rows run after the first start ends, on the path's clock.
    let second_begins = num(&doc["starts"][1]["begins_s"]);
    for r in rows.iter().filter(|r| r[0] == "2") {
        let own: f64 = r[8].parse().unwrap();
        let on_path: f64 = r[10].parse().unwrap();
        assert!((on_path - own - second_begins).abs() < 1e-5, "{r:?}");
    }
    let svg = std::fs::read_to_string(&svg).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    for text in [
        "blend at waypoint 2, radius 8.",
        "planned path",
        "distance along the path (mm)",
        "tolerance 0.05 mm",
    ] {
        assert!(svg.contains(text), "no {text:?}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn plan_path_refuses_a_blend_on_the_last_element_instead_of_ignoring_it() {
    let dir = std::env::temp_dir().join(format!("linterpd-last-blend-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("last-blend.toml");
    std::fs::write(
        &file,
        "[[element]]\nline = [-1000, 600, 100]\n[[element]]\nline = [-1100, 650, 150]\n\
         blend = \"20mm\"\n",
    )
    .unwrap();
    let out = linterpd(&[
        "plan",
        "--config",
        CONFIG,
        "--path",
        file.to_str().unwrap(),
        "--from",
        "-926.57,535.03,50",
    ]);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("element 2: blend: 20 mm rounds the corner into the next element"),
        "{err}"
    );
}

/// The shipped config with d3's drive limited to `accel` mm/s^2 and `start` Hz from rest, in a
/// file of its own.
fn limited_config(name: &str, accel: &str, start: &str) -> String {
    let shipped = include_str!("../../config/linterpd.toml");
    let d3 = "max_freq_hz = 20000\n# Wiring.";
    assert!(shipped.contains(d3));
    let text = shipped.replacen(
        d3,
        &format!("max_freq_hz = 20000\nmax_accel_mm_s2 = {accel}\nstart_hz = {start}\n# Wiring."),
        1,
    );
    let path = std::env::temp_dir().join(format!("linterpd-{}-{name}.toml", std::process::id()));
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_owned()
}

/// The seed's move's arguments on the config at `config`.
fn seed_on(config: &str) -> Vec<&str> {
    let mut args: Vec<&str> = vec!["plan"];
    args.extend(SEED);
    let at = args.iter().position(|a| *a == "--config").unwrap() + 1;
    args[at] = config;
    args
}

#[test]
fn plan_reports_every_drive_against_its_limits_and_times_the_line_under_them() {
    let config = limited_config("drives", "1000.0", "1000.0");
    let free = plan_json(&[]);
    let mut args = seed_on(&config);
    args.extend(["--format", "json"]);
    let out = linterpd(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(free["profile"]["timing"], "trapezoid");
    assert_eq!(doc["profile"]["timing"], "time-optimal");
    let d3 = &doc["drives"][2];
    assert_eq!(d3["joint"], "d3");
    assert_eq!(d3["max_accel"], 1000.0);
    assert_eq!(d3["start_hz"], 1000.0);
    assert!(d3["step_load"].as_f64().unwrap() <= 1.0, "{d3}");
    assert!(d3["rest_hz"].as_f64().unwrap() <= 1000.0, "{d3}");
    // Without the limits the radial joint starts at about 2 kHz.
    assert!(free["drives"][2]["rest_hz"].as_f64().unwrap() > 1_900.0);
    assert!(free["drives"][2]["max_accel"].is_null());
    // The text names the limits beside the peaks.
    let out = linterpd(&seed_on(&config));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("profile  time-optimal under the drive limits"),
        "{text}"
    );
    assert!(
        text.contains("(max_accel 1000), largest row step"),
        "{text}"
    );
    assert!(text.contains("(start_hz 1000)"), "{text}");
    std::fs::remove_file(&config).unwrap();
}

#[test]
fn plan_shows_an_s_curve_under_drive_limits_as_the_time_optimal_motion_averaged() {
    // d3 at 300 mm/s^2: the S-curve is the time-optimal motion averaged (1.923 s, where slowing
    // it as a whole took 2.600 s: PLANNING.md, "S-curve ramps").
    let config = limited_config("averaged", "300.0", "1000.0");
    let mut args = seed_on(&config);
    args.extend(["--profile", "s-curve:20000"]);
    let out = linterpd(&args);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains(
            "profile  s-curve (jerk 20000 mm/s^3), the time-optimal motion averaged to that \
             jerk"
        ),
        "{text}"
    );
    assert!(text.contains("1.923 s"), "{text}");
    assert!(!text.contains("slowed down"), "{text}");
    args.extend(["--format", "json"]);
    let doc: Value = serde_json::from_slice(&linterpd(&args).stdout).unwrap();
    assert_eq!(doc["profile"]["timing"], "time-optimal s-curve");
    assert!(doc["drives"][2]["peak_accel"].as_f64().unwrap() <= 300.0 * 1.02);
    std::fs::remove_file(&config).unwrap();
}

#[test]
fn a_drive_limit_no_row_can_keep_is_refused_naming_the_joint_and_the_figure() {
    let config = limited_config("refused", "1000.0", "10.0");
    let e = refused(&[("--config", &config)], &[]);
    assert!(e.contains("joint d3: start_hz = 10 Hz"), "{e}");
    assert!(e.contains("raise start_hz to at least 20.6 Hz"), "{e}");
    std::fs::remove_file(&config).unwrap();
}

#[test]
fn an_s_curve_is_planned_on_request_and_a_bad_one_named() {
    let trapezoid = plan_json(&[]);
    let s_curve = plan_json(&["--profile", "s-curve:20000"]);
    assert_eq!(s_curve["profile"]["timing"], "s-curve");
    assert_eq!(s_curve["valid"], true);
    let duration = |doc: &Value| doc["profile"]["duration_s"].as_f64().unwrap();
    assert!(duration(&s_curve) > duration(&trapezoid));
    assert!(s_curve["profile"]["accel_mm_s2"].as_f64().unwrap() <= 1_200.0 + 1e-6);
    let e = refused(&[], &["--profile", "s-curve:-5"]);
    assert!(e.contains("--profile") && e.contains("above 0"), "{e}");
    let e = refused(&[], &["--profile", "sine"]);
    assert!(e.contains("\"sine\"") && e.contains("s-curve:JERK"), "{e}");
}

/// A path in the horizontal plane z = 150 mm: a line, an arc, a line, both corners blended at
/// 15 mm; `lift_mm` raises everything after the start (the first line then climbs out of the
/// arc's plane).
fn line_arc_line(lift_mm: f64) -> String {
    let z = 150.0 + lift_mm;
    format!(
        "linterpd_path = 1\nstart = [-926.57, 535.03, 150.0]\npath_accel = \"5000mm/s2\"\n\
         [[element]]\nline = [-1050.0, 600.0, {z}]\nblend = \"15mm\"\n\
         [[element]]\narc = [-1100.0, 700.0, {z}]\nvia = [-1061.6, 643.3, {z}]\nblend = \"15mm\"\n\
         [[element]]\nline = [-1000.0, 760.0, {z}]\n"
    )
}

#[test]
fn corners_next_to_an_arc_are_blended_in_its_plane_and_refused_out_of_it() {
    let dir = std::env::temp_dir().join(format!("linterpd-arc-blend-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let flat = dir.join("flat.toml");
    std::fs::write(&flat, line_arc_line(0.0)).unwrap();
    let out = plan_path(flat.to_str().unwrap(), &["--json"]);
    let doc: Value = serde_json::from_slice(&out.stdout).expect("json");
    let pieces = doc["path"].as_array().unwrap();
    let kinds: Vec<&str> = pieces.iter().map(|p| p["kind"].as_str().unwrap()).collect();
    assert_eq!(kinds, ["line", "arc", "arc", "arc", "line"]);
    // A blend's arc, what is left of element 2's arc, a blend's arc.
    let elements: Vec<Option<u64>> = pieces.iter().map(|p| p["element"].as_u64()).collect();
    assert_eq!(elements, [Some(1), None, Some(2), None, Some(3)]);
    assert_eq!(pieces[1]["waypoint"], 1);
    assert_eq!(pieces[3]["waypoint"], 2);
    // The first line is 139.48 mm; its blend reaches 15 mm back along it.
    let first = num(&pieces[0]["length_mm"]);
    assert!((first - (139.484 - 15.0)).abs() < 0.01, "{first}");
    // One section (no stop at either corner), within the tolerance of the blended path.
    assert!(pieces.iter().all(|p| p["section"] == 1), "{doc}");
    assert!(doc["valid"].as_bool().unwrap());
    let deviation = num(&doc["path_deviation_mm"]);
    assert!(deviation <= 0.05, "{deviation} mm");

    let tilted = dir.join("tilted.toml");
    std::fs::write(&tilted, line_arc_line(30.0)).unwrap();
    let out = linterpd(&[
        "plan",
        "--config",
        CONFIG,
        "--path",
        tilted.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(
            "waypoint 1: a blend next to an arc needs both neighbours in one plane, and element \
             1 leaves the arc's plane by 12.138 deg"
        ),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The seed's move at 20 mm/s sampled every 10 ms, `extra` arguments after it.
fn long_slow_line(extra: &[&str]) -> Output {
    let mut args = vec!["plan"];
    // The seed's --from, --to and --config; its own speed and period left out.
    for pair in SEED.chunks(2) {
        if !matches!(pair[0], "--speed" | "--period") {
            args.extend(pair);
        }
    }
    args.extend(["--speed", "20", "--period", "10ms"]);
    args.extend(extra);
    linterpd(&args)
}

#[test]
fn a_line_too_long_for_one_start_is_planned_and_shown_in_parts_instead_of_refused() {
    // Issue 47: refused "channel 0 table needs 3152 words; its area holds 2000", no way out.
    let out = long_slow_line(&[]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let first = text.lines().next().unwrap_or_default();
    assert!(
        first.starts_with("cut      into ")
            && first
                .contains(" parts chained at speed, each whole in its areas: as one start, joint ")
            && first.contains(" table needs ")
            && first.ends_with("words; its area holds 2000"),
        "{text}"
    );
    let parts: usize = first["cut      into ".len()..]
        .split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{first}"));
    assert!(parts >= 2, "{first}");
    assert!(text.contains("1 (section 1, element 1): "), "{text}");
    assert!(
        text.contains(&format!(
            "{parts} (section 1, element 1), chained at speed: "
        )),
        "{text}"
    );
    assert!(text.contains("valid    yes"), "{text}");
    // The JSON lists the same starts, every one valid.
    let out = long_slow_line(&["--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(doc["sections"].as_array().unwrap().len(), parts, "{doc}");
    assert_eq!(doc["valid"], true);
}
