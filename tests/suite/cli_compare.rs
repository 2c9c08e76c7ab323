//! `linterpd plan --compare` and `--svg` as a user runs them on the seed's move.

use crate::common;

use common::cli::SEED;
use std::process::{Command, Output};

use serde_json::Value;

fn linterpd(extra: &[&str]) -> Output {
    plan(&SEED, extra)
}

/// `linterpd plan` with `args` and `extra`, which must succeed.
fn plan(args: &[&str], extra: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .arg("plan")
        .args(args)
        .args(extra)
        .output()
        .expect("linterpd runs");
    assert!(
        out.status.success(),
        "{extra:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn compare_json(extra: &[&str]) -> Value {
    let mut args = vec!["--compare", "--format", "json"];
    args.extend(extra);
    serde_json::from_slice(&linterpd(&args).stdout).expect("one json document")
}

fn path_deviation(plan: &Value) -> f64 {
    plan["figures"]["path_deviation_mm"]
        .as_f64()
        .unwrap_or_else(|| panic!("no path deviation in {plan}"))
}

/// The plan of `doc` made with `method` (`seed-exact` for the seed-exact one) under `model`.
fn find<'a>(doc: &'a Value, method: &str, model: &str) -> &'a Value {
    doc["plans"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| {
            let name = if p["seed_exact"] == true {
                "seed-exact"
            } else {
                p["method"].as_str().unwrap()
            };
            name == method && p["frequency_model"] == model
        })
        .unwrap_or_else(|| panic!("no {method} under {model}"))
}

#[test]
fn compare_plans_six_ways_and_the_methods_rank_as_promised() {
    let doc = compare_json(&[]);
    assert_eq!(doc["linterpd_compare"], 1);
    assert_eq!(doc["plans"].as_array().unwrap().len(), 6);
    for model in ["ideal", "fpx-divider"] {
        let seed = find(&doc, "seed-exact", model);
        let constant = find(&doc, "constant-period", model);
        let bounded = find(&doc, "bounded-error", model);
        assert_eq!(seed["valid"], false);
        assert_eq!(constant["valid"], true);
        assert_eq!(bounded["valid"], true);
        let tolerance = bounded["tolerance_mm"].as_f64().unwrap();
        assert!((tolerance - 0.05).abs() < 1e-12);
        assert!(path_deviation(bounded) <= tolerance);
        assert!(path_deviation(constant) <= path_deviation(seed));
        for plan in [seed, constant, bounded] {
            assert!(
                plan["upload_bytes"].as_u64().unwrap()
                    > plan["figures"]["words"].as_u64().unwrap() * 4
            );
        }
    }
}

#[test]
fn a_tolerance_below_the_floor_fails_only_its_own_rows() {
    let doc = compare_json(&["--tolerance", "0.01mm"]);
    for model in ["ideal", "fpx-divider"] {
        let bounded = find(&doc, "bounded-error", model);
        assert_eq!(bounded["valid"], false);
        assert!(bounded.get("figures").is_none());
        let error = bounded["error"].as_str().unwrap();
        assert!(error.contains("tolerance 0.01 mm is below"), "{error}");
        assert_eq!(find(&doc, "constant-period", model)["valid"], true);
    }
    let text = String::from_utf8(linterpd(&["--compare", "--tolerance", "0.01mm"]).stdout).unwrap();
    assert_eq!(
        text.matches("error: tolerance 0.01 mm is below").count(),
        2,
        "{text}"
    );
    assert!(text.contains("constant-period"), "{text}");
}

/// Checks that `svg` is one SVG document and returns it.
fn well_formed(svg: &str) -> &str {
    let body = svg.trim();
    assert!(
        body.starts_with("<svg") || body.starts_with("<?xml"),
        "{}",
        &body[..60]
    );
    assert!(body.ends_with("</svg>"));
    assert_eq!(body.matches("<svg").count(), 1);
    // Every element opened with `<` and not self-closed is closed again.
    for tag in ["text", "svg"] {
        assert_eq!(
            body.matches(&format!("<{tag}")).count(),
            body.matches(&format!("</{tag}>")).count(),
            "<{tag}> unbalanced"
        );
    }
    body
}

fn svg_of(extra: &[&str]) -> String {
    let dir = std::env::temp_dir().join(format!("linterpd-svg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("{}.svg", extra.len()));
    let path_text = path.to_str().unwrap().to_owned();
    let mut args = extra.to_vec();
    args.extend(["--svg", &path_text]);
    linterpd(&args);
    let svg = std::fs::read_to_string(&path).expect("the svg was written");
    std::fs::remove_file(&path).ok();
    svg
}

#[test]
fn svg_of_a_comparison_draws_every_plan_in_every_panel() {
    let svg = svg_of(&["--compare"]);
    let svg = well_formed(&svg);
    // Six plans in three panels, plus the planned line in two and a legend sample each.
    assert!(
        svg.matches("<polyline").count() >= 6 * 3,
        "{}",
        svg.matches("<polyline").count()
    );
    for text in [
        "X (mm)",
        "Y (mm)",
        "Z (mm)",
        "distance along the line (mm)",
        "deviation (mm)",
        "seed-exact, ideal",
        "constant-period, fpx-divider",
        "bounded-error 0.05 mm, fpx-divider",
        "tolerance 0.05 mm",
    ] {
        assert!(svg.contains(text), "no {text:?}");
    }
}

#[test]
fn svg_of_one_plan_draws_only_that_plan() {
    let svg = svg_of(&["--method", "bounded-error", "--tolerance", "0.05mm"]);
    let svg = well_formed(&svg);
    assert!(svg.matches("<polyline").count() >= 3);
    assert!(svg.contains("bounded-error 0.05 mm, fpx-divider"));
    assert!(!svg.contains("constant-period"));
}

/// `linterpd plan` on a line from the seed's P1, turned 30 degrees about the robot's axis: it
/// passes the point nearest the axis halfway, where the radial joint d3 reverses.
fn past_the_axis(extra: &[&str]) -> Output {
    let mut args = SEED;
    args[3] = "-534.92,926.63,50";
    plan(&args, extra)
}

#[test]
fn a_line_past_a_reversal_is_shown_as_the_starts_it_runs_as() {
    let text = String::from_utf8(past_the_axis(&["--tolerance", "0.05"]).stdout).unwrap();
    assert!(
        text.starts_with("cut      where joint d3 reverses, 2"),
        "{text}"
    );
    assert!(text.contains("chained at speed"), "{text}");
    let doc: Value =
        serde_json::from_slice(&past_the_axis(&["--tolerance", "0.05", "--json"]).stdout).unwrap();
    let starts = doc["starts"].as_array().unwrap();
    assert_eq!(starts.len(), 2, "{doc}");
    assert!(doc["path_deviation_mm"].as_f64().unwrap() <= 0.05, "{doc}");
    // --compare: each row but the paper's own is the two starts together.
    let doc: Value =
        serde_json::from_slice(&past_the_axis(&["--compare", "--format", "json"]).stdout).unwrap();
    for model in ["ideal", "fpx-divider"] {
        let bounded = find(&doc, "bounded-error", model);
        assert_eq!(bounded["valid"], true, "{bounded}");
        assert_eq!(bounded["starts"], 2, "{bounded}");
        assert!(path_deviation(bounded) <= 0.05, "{bounded}");
        assert_eq!(find(&doc, "constant-period", model)["starts"], 2);
        assert!(find(&doc, "seed-exact", model).get("starts").is_none());
    }
}
