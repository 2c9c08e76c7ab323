//! `linterpd demo`: the library function end to end (the daemon against the in-process mock PLC
//! at 115200 baud), and the binary.

use std::process::Command;

use linterpd::daemon::Stage;
use linterpd::demo::{CYCLE_TOLERANCE_MM, Demo, DemoOptions, run};

/// How far the measured path deviation of the seed's move may be from the prediction, mm.
///
/// The mock plays the tables with the planner's own execution model (`sim`), pulse for pulse;
/// the one difference is the scan gap between segments: the mock starts a channel's next
/// segment at the first 2 ms scan after the previous one ends, the planner at once, so the rest
/// of that channel runs up to one scan late (about that joint's speed x 2 ms off the line). The
/// seed's move has one segment per channel, so no gap enters and the two agree to rounding
/// (checked exactly below); 5 um is a tenth of the move's pulse-grid deviation (0.05 mm per
/// theta1 pulse), room for a plan that splits a slow joint's table, not for a row played late.
const AGREEMENT_MM: f64 = 0.005;

async fn demo(svg: bool) -> Demo {
    let options = DemoOptions {
        svg,
        ..DemoOptions::default()
    };
    run(options).await.expect("the demo runs")
}

#[tokio::test(flavor = "multi_thread")]
async fn every_move_ends_on_target_and_the_trace_agrees_with_the_plan() {
    let d = demo(true).await;
    assert_eq!(d.moves.len(), 7);
    for m in &d.moves {
        assert_eq!(m.report.stage, Stage::Done, "{}: {:?}", m.name, m.report);
        let (error, _) = m.final_error_pulses(&d.robot);
        assert!(error.iter().all(|e| e.abs() <= 1), "{}: {error:?}", m.name);
    }
    for m in &d.moves {
        let one_segment = m.plan.tables.iter().all(|t| t.segments.len() <= 1);
        let gap = (m.played.figures.path_deviation_mm - m.plan.figures.path_deviation_mm).abs();
        assert!(!one_segment || gap < 1e-9, "{}: {gap} mm", m.name);
    }
    let seed = &d.moves[0];
    assert!(seed.name.contains("seed"), "{}", seed.name);
    let predicted = seed.report.predicted.unwrap().path_deviation_mm;
    let measured = seed.played.figures.path_deviation_mm;
    assert!(
        (measured - predicted).abs() <= AGREEMENT_MM,
        "measured {measured} mm, predicted {predicted} mm"
    );
    // A chained move's end is read by the daemon only if a status read falls between its last
    // pulse and the PLC taking the waiting start (within two scans); on a loaded machine one
    // sometimes does (seen once in a full `cargo test`, move 5), and then its counts were
    // checked on target above. The last move's end is always read.
    assert!(d.moves[4].chained && d.moves[5].chained);
    assert!(d.moves[6].chained && d.moves[6].report.final_error_pulses.is_some());
    // At 115200 baud every queued move is uploaded long before the one before it ends: its
    // start waits in the PLC, which takes it within two scans of that move's last pulse.
    for m in &d.moves[4..] {
        let chain = m
            .chain
            .unwrap_or_else(|| panic!("{}: no chain measured", m.name));
        assert!(chain.seen_after_s < 0.0, "{}: {chain:?}", m.name);
        assert!(
            (0.0..=2.0 * d.scan_s + 1e-9).contains(&chain.started_after_s),
            "{}: {chain:?}",
            m.name
        );
    }
    assert!(d.moves[..4].iter().all(|m| m.chain.is_none()));
    // The pick-and-place cycle: blended, the lift's section runs as two starts, the second
    // chained at speed from exactly the counts the first ended on; both cycles end on P2's
    // counts, within the tolerance as planned, and the blended one is shorter on the trace.
    let [blended, stopped] = d.cycles.as_slice() else {
        panic!("two cycles: {:?}", d.cycles.len());
    };
    assert!(
        blended
            .starts
            .iter()
            .any(|m| m.plan.window.begins_at_speed())
    );
    assert!(
        stopped
            .starts
            .iter()
            .all(|m| !m.plan.window.begins_at_speed())
    );
    for cycle in [blended, stopped] {
        for pair in cycle.starts.windows(2) {
            assert_eq!(pair[1].plan.start_counts(), pair[0].played.end_counts);
        }
        for m in &cycle.starts {
            assert_eq!(
                m.report.stage,
                Stage::Done,
                "{}: {:?}",
                cycle.name,
                m.report
            );
            assert_eq!(m.played.end_counts, m.plan.end_counts(), "{}", cycle.name);
            assert!(m.plan.figures.path_deviation_mm <= CYCLE_TOLERANCE_MM);
        }
    }
    assert_eq!(
        blended.starts.last().unwrap().played.end_counts,
        stopped.starts.last().unwrap().played.end_counts
    );
    assert!(
        blended.cycle_s < stopped.cycle_s,
        "{} s blended, {} s stopped",
        blended.cycle_s,
        stopped.cycle_s
    );
    let svg = d.svg.as_deref().expect("asked for");
    assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(80)]);
    assert!(svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("the seed&apos;s move") || svg.contains("the seed's move"));
}

#[test]
fn the_binary_runs_the_demo_and_names_the_seeds_move() {
    let out = Command::new(env!("CARGO_BIN_EXE_linterpd"))
        .args(["demo", "--no-svg"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("the seed's move, P1 -> P2"), "{stdout}");
    assert!(stdout.contains("7 moves done"), "{stdout}");
    assert!(
        stdout.contains("s on the trace (planned 1.400 s; the daemon saw it end after"),
        "{stdout}"
    );
    assert!(stdout.contains("no idle time"), "{stdout}");
    assert!(!stdout.contains("the PLC idled"), "{stdout}");
    assert!(!stdout.contains("Picture:"), "{stdout}");
}

#[test]
fn readme_quick_start_says_what_the_demo_runs() {
    // It said "the seed paper's move and four others" while the demo ran seven moves, a
    // pick-and-place path and a drive-limits comparison.
    let readme = include_str!("../../README.md");
    let quick = readme
        .split("## Quick start")
        .nth(1)
        .and_then(|s| s.split("cargo run --release -- demo").next())
        .unwrap();
    let moves: usize = linterpd::demo::steps().iter().map(Vec::len).sum();
    assert_eq!(moves, 7);
    let last_batch = linterpd::demo::steps().last().unwrap().len();
    assert_eq!(last_batch, 4);
    for said in [
        "seven moves",
        "the last four queued at\n# once and three of them chained",
        "pick-and-place path",
        "drive-limits comparison",
    ] {
        assert!(quick.contains(said), "{said:?} in\n{quick}");
    }
    assert!(!quick.contains("four others"), "{quick}");
}
