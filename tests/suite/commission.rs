//! `linterpd commission` against every mock variant: the listing passes every check; each
//! other variant fails exactly the check built to find it, with its hint, and nothing is left
//! running; with four X input words the checks that switch a relay are skipped. MEWTOCOL runs in process over `tokio::io::duplex` on paused time (the serial line
//! emulated at 115200 baud, replies at the end of a scan, as a real PLC answers); Modbus runs
//! over loopback TCP in real time, on one channel.

use crate::common;

use std::time::Duration;

use linterpd::commission::judge::Fit;
use linterpd::commission::{CheckReport, Report, Step, Target, Verdict, run};
use linterpd::contract::State;
use linterpd::mock::{
    MewtocolServer, MewtocolServerOptions, MockConfig, MockPlc, MockVariant, ModbusServer,
    ModbusServerOptions, SharedMock,
};
use linterpd::plc::{
    BoxedLink, HeaderChoice, LinkSettings, Parity, Protocol, SerialSettings, TcpSettings, Transport,
};
use linterpd::robot::seed_robot;
use linterpd::table::FrequencyModel;

/// Counts the mock's channels start at (any, as long as they are within the joints' ranges).
const START: [i64; 4] = [1_000, 2_000, 30_000, -400];

fn mock(variant: MockVariant) -> SharedMock {
    mock_with(MockConfig {
        variant,
        ..MockConfig::default()
    })
}

fn mock_with(config: MockConfig) -> SharedMock {
    let mut plc = MockPlc::new(config).unwrap();
    for (c, count) in START.into_iter().enumerate() {
        plc.set_count(c, count);
    }
    SharedMock::new(plc)
}

fn serial_link(header: HeaderChoice) -> LinkSettings {
    serial_link_at(header, 115_200)
}

fn serial_link_at(header: HeaderChoice, baud: u32) -> LinkSettings {
    let mut link = LinkSettings::new(
        Protocol::Mewtocol,
        Transport::Serial(SerialSettings {
            path: "/dev/ttyUSB0".into(),
            baud,
            data_bits: 8,
            parity: Parity::Odd,
            stop_bits: 1,
        }),
    );
    link.header = header;
    link
}

fn target(link: LinkSettings, model: FrequencyModel) -> Target {
    let mut robot = seed_robot();
    robot.motion.frequency_model = model;
    Target::new(robot, link)
}

/// Commission over MEWTOCOL in process; the report and the mock.
async fn commission_mewtocol(variant: MockVariant, target: &Target) -> (Report, SharedMock) {
    commission_mewtocol_on(mock(variant), target).await
}

/// Commission over MEWTOCOL in process against `shared`; the report and the mock.
async fn commission_mewtocol_on(shared: SharedMock, target: &Target) -> (Report, SharedMock) {
    let driver = tokio::spawn(shared.clone().run_scans());
    let (ours, theirs) = tokio::io::duplex(8_192);
    let options = MewtocolServerOptions {
        baud: Some(115_200),
        ..MewtocolServerOptions::default()
    };
    let server = MewtocolServer::new(shared.clone(), options);
    tokio::spawn(async move { server.serve(theirs).await });
    let link: BoxedLink = Box::new(ours);
    let report = run(link, target, &mut |c| eprintln!("{}", line(c))).await;
    driver.abort();
    (report, shared)
}

fn line(c: &CheckReport) -> String {
    format!(
        "[{}] {}: {}{}",
        c.verdict.tag(),
        c.title(),
        c.saw,
        c.hint
            .as_ref()
            .map_or(String::new(), |h| format!(" -- {h}"))
    )
}

fn find<'r>(report: &'r Report, check: &str, channel: Option<u8>) -> &'r CheckReport {
    report
        .checks
        .iter()
        .find(|c| c.check == check && c.channel == channel)
        .unwrap_or_else(|| panic!("no check {check} on {channel:?}"))
}

/// Every channel stopped and idle at the end, at the counts the procedure reports.
fn nothing_left_running(report: &Report, shared: &SharedMock) {
    assert!(report.all_stopped, "the final stop was not confirmed");
    shared.with(|m| {
        for c in 0..4 {
            assert!(!m.busy(c), "channel {c} still busy");
        }
        assert_ne!(m.state(), State::Running);
    });
    for counts in &report.findings.counts {
        let now = shared.with(|m| m.count(usize::from(counts.channel)));
        assert_eq!(counts.left, Some(now as i32), "channel {}", counts.channel);
    }
}

/// Asserts `c` passed, or was skipped as it must be: the multi-frame read when the procedure
/// went on with `<` frames.
fn passed(report: &Report, c: &CheckReport) {
    let angle = report.findings.header_used.as_deref() == Some("<");
    let skipped = angle && c.check == "multi-frame read";
    let verdict = if skipped {
        Verdict::Skip
    } else {
        Verdict::Pass
    };
    assert_eq!(c.verdict, verdict, "{}", line(c));
}

/// Every check passes (or is skipped where it does not apply: [`passed`]).
fn all_pass(report: &Report) {
    let failed: Vec<String> = report.failures().map(line).collect();
    assert!(failed.is_empty(), "{failed:#?}");
    assert!(report.passed && report.stopped.is_none());
    for c in &report.checks {
        passed(report, c);
    }
}

#[tokio::test(start_paused = true)]
async fn the_listing_passes_every_check_and_leaves_the_counts_as_found() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::Listing, &target).await;
    all_pass(&report);
    assert_eq!(report.checks.len(), 6 + 5 + 1 + 9 * 4);
    assert_eq!(
        report.findings.multi_frame_reads, None,
        "< carries 509 words a frame"
    );
    nothing_left_running(&report, &shared);
    for counts in &report.findings.counts {
        assert_eq!(i64::from(counts.found), START[usize::from(counts.channel)]);
        assert_eq!(counts.left, Some(counts.found));
    }
    for rate in &report.findings.rates {
        assert_eq!(rate.rate.fit, Fit::FpxDivider, "{rate:?}");
    }
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("header = \"angle\""))
    );
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("frequency_model = \"fpx-divider\""))
    );
}

/// Checks before `failed` pass, `failed` fails with a hint containing `hint` and stops the
/// procedure, everything after it is skipped; nothing is left running.
fn stops_at(report: &Report, shared: &SharedMock, failed: (&str, Option<u8>), hint: &str) {
    let at = report
        .checks
        .iter()
        .position(|c| c.check == failed.0 && c.channel == failed.1)
        .unwrap_or_else(|| panic!("no check {failed:?}"));
    let check = &report.checks[at];
    assert_eq!(check.verdict, Verdict::Fail, "{}", line(check));
    assert!(check.stopped, "{}", line(check));
    let said = check.hint.as_deref().unwrap_or_default();
    assert!(said.contains(hint), "{}", line(check));
    for c in &report.checks[..at] {
        passed(report, c);
    }
    for c in &report.checks[at + 1..] {
        assert_ne!(c.verdict, Verdict::Pass, "{}", line(c));
    }
    assert!(
        report.checks[at + 1..]
            .iter()
            .filter(|c| c.step != check.step || c.channel != check.channel)
            .all(|c| c.verdict == Verdict::Skip)
    );
    assert!(!report.passed);
    assert_eq!(report.stopped, Some(format!("{} failed", check.title())));
    nothing_left_running(report, shared);
}

/// Exactly the checks named (on every channel they apply to) fail without stopping; every other
/// check passes.
fn only_config_failures(report: &Report, shared: &SharedMock, failing: &[&str], hint: &str) {
    for c in &report.checks {
        if failing.contains(&c.check.as_str()) {
            assert_eq!(c.verdict, Verdict::Fail, "{}", line(c));
            assert!(!c.stopped, "{}", line(c));
            let said = c.hint.as_deref().unwrap_or_default();
            assert!(said.contains(hint), "{}", line(c));
        } else {
            passed(report, c);
        }
    }
    assert!(report.stopped.is_none() && !report.passed);
    nothing_left_running(report, shared);
}

#[tokio::test(start_paused = true)]
async fn busy_never_rises_fails_busy_on_then_off_on_the_first_channel_and_stops() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::BusyNeverRises, &target).await;
    let busy = find(&report, "busy on then off", Some(0));
    assert!(busy.saw.contains("busy bit ON in 0 of"), "{}", line(busy));
    // The same run's other two checks are judged, and pass: the count and the rate are right.
    for check in [
        "elapsed moves by exactly the table's pulses",
        "time taken vs frequency",
    ] {
        assert_eq!(find(&report, check, Some(0)).verdict, Verdict::Pass);
    }
    let at = report
        .checks
        .iter()
        .position(|c| c.check == "busy on then off")
        .unwrap();
    let mut without_run_mates = report.clone();
    without_run_mates.checks.remove(at + 1);
    without_run_mates.checks.remove(at + 1);
    stops_at(
        &without_run_mates,
        &shared,
        ("busy on then off", Some(0)),
        "R9120",
    );
    // The timing run ended done where it should: the counts moved out by 500 and stayed.
    let counts = report.findings.counts[0];
    assert_eq!((counts.found, counts.left), (1_000, Some(500)));
}

#[tokio::test(start_paused = true)]
async fn stop_pauses_fails_the_stop_check_because_the_next_start_resumed_the_old_table() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::StopPauses, &target).await;
    let check = find(
        &report,
        "stop mid-table then a following start works",
        Some(0),
    );
    assert!(
        check.saw.contains("moved away from the new table's target"),
        "{}",
        line(check)
    );
    stops_at(
        &report,
        &shared,
        ("stop mid-table then a following start works", Some(0)),
        "only paused F174",
    );
    let counts = report.findings.counts[0];
    assert_ne!(
        counts.left,
        Some(counts.found),
        "the report says where it left channel 0"
    );
}

#[tokio::test(start_paused = true)]
async fn a_program_that_ignores_the_permit_fails_permit_refuses_fault_8_and_stops() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::IgnoresPermit, &target).await;
    // Version 3's status block: the inputs are copied, so the inputs step passes.
    assert_eq!(
        find(&report, "copied every scan", None).verdict,
        Verdict::Pass
    );
    let check = find(&report, "permit refuses fault 8", Some(0));
    assert!(
        check.saw.contains("the permit needs XD on") && check.saw.contains("the start ran"),
        "{}",
        line(check)
    );
    stops_at(
        &report,
        &shared,
        ("permit refuses fault 8", Some(0)),
        "the contract says a start whose permit does not hold is refused with fault 8",
    );
    assert!(
        check.hint.as_deref().unwrap().contains("version 2's logic"),
        "{}",
        line(check)
    );
    // The program started it: the count moved, and the report says where it was left.
    let counts = report.findings.counts[0];
    assert_ne!(counts.left, Some(counts.found));
}

#[tokio::test(start_paused = true)]
async fn with_four_x_input_words_the_relay_checks_are_skipped_as_needing_wiring() {
    let words = ["WX0", "WX1", "WX2", "WX3"].map(|w| w.parse().unwrap());
    let mut link = serial_link(HeaderChoice::Auto);
    link.layout.inputs = words;
    let target = target(link, FrequencyModel::FpxDivider);
    let mut config = MockConfig::default();
    config.layout.inputs = words;
    let shared = mock_with(config);
    // X1D on: channel 1's refused start asks it off, its running start on.
    shared.with(|m| m.set_input(16 + 0xD, true).unwrap());
    let (report, shared) = commission_mewtocol_on(shared, &target).await;
    let needs_wiring = |c: &CheckReport| {
        c.verdict == Verdict::Skip && c.saw.contains("X words") && c.saw.contains("needs wiring")
    };
    let copied = find(&report, "copied every scan", None);
    assert!(needs_wiring(copied), "{}", line(copied));
    assert!(
        copied.saw.contains("WX1 0x2000 (X1D on)"),
        "{}",
        line(copied)
    );
    for c in 0..4 {
        let held = find(&report, "permit drop holds within one scan", Some(c));
        assert!(needs_wiring(held), "{}", line(held));
    }
    let refused = find(&report, "permit refuses fault 8", Some(1));
    assert!(
        refused.saw.contains("the permit needs X1D off"),
        "{}",
        line(refused)
    );
    for c in report.checks.iter().filter(|c| !needs_wiring(c)) {
        passed(&report, c);
    }
    assert!(report.passed, "skips that need wiring are not failures");
    nothing_left_running(&report, &shared);
    for counts in &report.findings.counts {
        assert_eq!(counts.left, Some(counts.found));
    }
}

#[tokio::test(start_paused = true)]
async fn angle_refused_with_header_auto_passes_and_says_percent() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::AngleRefused, &target).await;
    all_pass(&report);
    nothing_left_running(&report, &shared);
    let headers = find(&report, "headers %, <", None);
    assert!(
        headers.saw.contains("< no reply within 3"),
        "{}",
        line(headers)
    );
    assert_eq!(report.findings.header_used.as_deref(), Some("%"));
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("header = \"percent\"  # < got no answer")),
        "{:?}",
        report.config_lines
    );
}

#[tokio::test(start_paused = true)]
async fn angle_refused_with_header_angle_fails_the_header_check_and_goes_on_with_percent() {
    let target = target(serial_link(HeaderChoice::Angle), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::AngleRefused, &target).await;
    only_config_failures(
        &report,
        &shared,
        &["headers %, <"],
        "set header = \"percent\"",
    );
}

#[tokio::test(start_paused = true)]
async fn under_percent_the_listing_answers_a_multi_frame_read_and_the_lines_say_true() {
    let target = target(
        serial_link(HeaderChoice::Percent),
        FrequencyModel::FpxDivider,
    );
    let (report, shared) = commission_mewtocol(MockVariant::Listing, &target).await;
    all_pass(&report);
    nothing_left_running(&report, &shared);
    let multi = find(&report, "multi-frame read", None);
    assert!(
        multi.saw.contains("54-word read came back"),
        "{}",
        line(multi)
    );
    assert_eq!(report.findings.multi_frame_reads, Some(true));
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("multi_frame_reads = true")),
        "{:?}",
        report.config_lines
    );
}

#[tokio::test(start_paused = true)]
async fn a_plc_without_multi_frame_replies_fails_only_the_multi_frame_check_and_says_false() {
    let target = target(
        serial_link(HeaderChoice::Percent),
        FrequencyModel::FpxDivider,
    );
    let (report, shared) = commission_mewtocol(MockVariant::OneFrameReplies, &target).await;
    only_config_failures(
        &report,
        &shared,
        &["multi-frame read"],
        "set multi_frame_reads = false",
    );
    let multi = find(&report, "multi-frame read", None);
    assert!(multi.saw.contains("got no answer"), "{}", line(multi));
    assert_eq!(report.findings.multi_frame_reads, Some(false));
    // The check's read was the only one left unanswered: the rest of the commission read one
    // frame at a time, as the check had found.
    assert_eq!(shared.with(|m| m.unanswered_multi_frame()), 1);
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("multi_frame_reads = false")),
        "{:?}",
        report.config_lines
    );
}

#[tokio::test(start_paused = true)]
async fn small_requests_over_mewtocol_fail_the_size_check_for_angle_frames() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::SmallRequests, &target).await;
    only_config_failures(
        &report,
        &shared,
        &["largest frame/read/write"],
        "set header = \"percent\"",
    );
    let angle = report
        .findings
        .sizes
        .iter()
        .find(|s| s.framing == "<")
        .unwrap();
    assert_eq!(
        (
            angle.read_words,
            angle.read_refused,
            angle.write_words,
            angle.write_refused
        ),
        (64, Some(65), 64, Some(65))
    );
    let percent = report
        .findings
        .sizes
        .iter()
        .find(|s| s.framing == "%")
        .unwrap();
    assert_eq!((percent.read_words, percent.write_words), (27, 24));
    assert_eq!(report.findings.header_used.as_deref(), Some("%"));
}

#[tokio::test(start_paused = true)]
async fn a_divider_clock_under_an_ideal_config_fails_time_taken_on_every_channel() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::Ideal);
    let (report, shared) = commission_mewtocol(MockVariant::DividerClock, &target).await;
    only_config_failures(
        &report,
        &shared,
        &["time taken vs frequency"],
        "set frequency_model = \"fpx-divider\"",
    );
    assert_eq!(report.findings.rates.len(), 4);
    for rate in &report.findings.rates {
        let r = rate.rate;
        assert_eq!(r.fit, Fit::FpxDivider);
        assert!(
            (r.measured_hz - r.divider_hz).abs() <= r.tolerance_hz,
            "{r:?}"
        );
        assert!(
            (r.measured_hz - r.ideal_hz).abs() > 3.0 * r.tolerance_hz,
            "{r:?}"
        );
    }
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("frequency_model = \"fpx-divider\"")),
        "{:?}",
        report.config_lines
    );
}

#[tokio::test(start_paused = true)]
async fn an_ideal_clock_under_a_divider_config_fails_time_taken_and_says_ideal() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::FpxDivider);
    let (report, shared) = commission_mewtocol(MockVariant::IdealClock, &target).await;
    only_config_failures(
        &report,
        &shared,
        &["time taken vs frequency"],
        "set frequency_model = \"ideal\"",
    );
    for rate in &report.findings.rates {
        assert_eq!(rate.rate.fit, Fit::Ideal, "{rate:?}");
    }
}

#[tokio::test(start_paused = true)]
async fn an_ideal_clock_under_an_ideal_config_passes_and_picks_ideal() {
    let target = target(serial_link(HeaderChoice::Auto), FrequencyModel::Ideal);
    let (report, shared) = commission_mewtocol(MockVariant::IdealClock, &target).await;
    all_pass(&report);
    nothing_left_running(&report, &shared);
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("frequency_model = \"ideal\"  # fits")),
        "{:?}",
        report.config_lines
    );
}

#[tokio::test(start_paused = true)]
async fn a_slow_serial_line_still_tells_the_models_apart() {
    let target = target(
        serial_link_at(HeaderChoice::Auto, 19_200),
        FrequencyModel::Ideal,
    );
    let shared = mock(MockVariant::DividerClock);
    let driver = tokio::spawn(shared.clone().run_scans());
    let (ours, theirs) = tokio::io::duplex(8_192);
    let options = MewtocolServerOptions {
        baud: Some(19_200),
        ..MewtocolServerOptions::default()
    };
    let server = MewtocolServer::new(shared.clone(), options);
    tokio::spawn(async move { server.serve(theirs).await });
    let mut target = target;
    target.channels = vec![2];
    let report = run(Box::new(ours), &target, &mut |c| eprintln!("{}", line(c))).await;
    driver.abort();
    // At 19200 baud a full < frame takes 1.2 s on the wire, past the 300 ms timeout.
    only_config_failures(
        &report,
        &shared,
        &["largest frame/read/write", "time taken vs frequency"],
        "",
    );
    let hints: Vec<&str> = report
        .failures()
        .filter_map(|c| c.hint.as_deref())
        .collect();
    assert!(hints[0].contains("set header = \"percent\""), "{hints:?}");
    assert!(
        hints[1].contains("set frequency_model = \"fpx-divider\""),
        "{hints:?}"
    );
    let rate = report.findings.rates[0].rate;
    assert!(rate.samples >= 30, "{rate:?}");
}

// ---- Modbus, over loopback TCP in real time, on one channel --------------------------------

async fn commission_modbus(variant: MockVariant) -> (Report, SharedMock) {
    let shared = mock(variant);
    let driver = tokio::spawn(shared.clone().run_scans());
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let server = ModbusServer::new(shared.clone(), ModbusServerOptions::default());
    tokio::spawn(server.serve_tcp(listener));
    let mut link = LinkSettings::new(
        Protocol::ModbusTcp,
        Transport::Tcp(TcpSettings {
            address: address.clone(),
            connect_timeout: Duration::from_secs(2),
        }),
    );
    link.timeout = Duration::from_secs(1);
    let mut target = target(link, FrequencyModel::FpxDivider);
    target.channels = vec![1];
    let stream = linterpd::plc::open_tcp(&TcpSettings {
        address,
        connect_timeout: Duration::from_secs(2),
    })
    .await
    .unwrap();
    let report = run(stream, &target, &mut |c| eprintln!("{}", line(c))).await;
    driver.abort();
    (report, shared)
}

#[tokio::test]
async fn modbus_listing_passes_every_check_that_applies() {
    let (report, shared) = commission_modbus(MockVariant::Listing).await;
    let mewtocol_only = ["headers %, <", "multi-frame read"];
    for check in mewtocol_only {
        assert_eq!(find(&report, check, None).verdict, Verdict::Skip);
    }
    for c in report
        .checks
        .iter()
        .filter(|c| !mewtocol_only.contains(&c.check.as_str()))
    {
        assert_eq!(c.verdict, Verdict::Pass, "{}", line(c));
    }
    assert!(report.passed);
    nothing_left_running(&report, &shared);
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("modbus_max_read = 125"))
    );
}

#[tokio::test]
async fn modbus_small_requests_fail_the_size_check_and_say_100() {
    let (report, shared) = commission_modbus(MockVariant::SmallRequests).await;
    let sizes = find(&report, "largest frame/read/write", None);
    assert_eq!(sizes.verdict, Verdict::Fail, "{}", line(sizes));
    assert!(!sizes.stopped);
    assert!(
        sizes
            .hint
            .as_deref()
            .unwrap()
            .contains("set modbus_max_read = 100 and modbus_max_write = 100"),
        "{}",
        line(sizes)
    );
    for c in report.checks.iter().filter(|c| c.step == Step::Pulses) {
        assert_eq!(c.verdict, Verdict::Pass, "{}", line(c));
    }
    nothing_left_running(&report, &shared);
    assert!(
        report
            .config_lines
            .iter()
            .any(|l| l.starts_with("modbus_max_write = 100"))
    );
}

// ---- The command line: a real `linterpd mock-plc` on loopback TCP, in real time ------------

mod cli {
    use std::io::Write;
    use std::process::{Command, Stdio};
    use std::time::Duration;

    use super::common::process::{Spawned, TempDir};
    use super::common::serve;
    use linterpd::commission::{Report, Verdict};

    const BIN: &str = env!("CARGO_BIN_EXE_linterpd");
    const LONG: Duration = Duration::from_secs(60);

    /// `linterpd mock-plc --variant NAME` on a free port; the process and its address.
    fn mock_plc(variant: &str) -> (Spawned, String) {
        let mut command = Command::new(BIN);
        command.args(["mock-plc", "--listen", "127.0.0.1:0", "--variant", variant]);
        let mut mock = Spawned::spawn("linterpd mock-plc", command);
        let address = mock.first_line_after("listening on ", serve::READY);
        (mock, address)
    }

    /// A config file for the shipped robot with a MEWTOCOL TCP link to `address`.
    fn config(dir: &TempDir, address: &str) -> std::path::PathBuf {
        let path = dir.path().join("linterpd.toml");
        let socket = dir.path().join("api.sock");
        std::fs::write(&path, serve::config_for(address, &socket)).unwrap();
        path
    }

    fn commission(config: &std::path::Path, extra: &[&str]) -> Spawned {
        let mut command = Command::new(BIN);
        command
            .arg("commission")
            .arg("--config")
            .arg(config)
            .args(extra);
        Spawned::spawn("linterpd commission", command)
    }

    #[test]
    fn json_report_parses_and_names_the_stop_that_pauses() {
        let (_mock, address) = mock_plc("stop-pauses");
        let dir = TempDir::new("commission-json");
        let config = config(&dir, &address);
        let done = commission(&config, &["--yes", "--json", "--channels", "0"]).finish(LONG);
        assert_eq!(done.status.code(), Some(1), "{}", done.describe());
        let value: serde_json::Value = serde_json::from_str(&done.stdout).unwrap();
        assert_eq!(value["passed"], false);
        let report: Report = serde_json::from_value(value).unwrap();
        let failed: Vec<&str> = report.failures().map(|c| c.check.as_str()).collect();
        assert_eq!(failed, ["stop mid-table then a following start works"]);
        assert!(report.all_stopped);
        assert!(
            done.stderr.contains("[FAIL] pulses: stop mid-table"),
            "{}",
            done.describe()
        );
    }

    #[test]
    fn text_report_passes_on_the_listing_with_config_lines() {
        let (_mock, address) = mock_plc("listing");
        let dir = TempDir::new("commission-text");
        let config = config(&dir, &address);
        let done = commission(&config, &["--yes", "--channels", "1"]).finish(LONG);
        assert_eq!(done.status.code(), Some(0), "{}", done.describe());
        assert!(
            done.stdout
                .contains("result: 21 checks: 20 pass, 0 FAIL, 1 skipped")
        );
        assert!(
            done.stdout
                .contains("channel 1: found at 0, left at 0 (as found)")
        );
        assert!(done.stdout.contains("  [robots.press-loader.motion]"));
        assert!(done.stdout.contains("  frequency_model = \"fpx-divider\""));
    }

    #[test]
    fn without_yes_it_asks_and_an_answer_other_than_yes_sends_nothing() {
        let dir = TempDir::new("commission-ask");
        // Nothing listens there: the command must not even try.
        let config = config(&dir, "127.0.0.1:9");
        let mut child = Command::new(BIN)
            .arg("commission")
            .arg("--config")
            .arg(&config)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        child.stdin.take().unwrap().write_all(b"no\n").unwrap();
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("switch the drives' power OFF"), "{stderr}");
        assert!(stderr.contains("stop `linterpd serve`"), "{stderr}");
        assert!(
            stderr.contains("not confirmed: nothing was sent"),
            "{stderr}"
        );
        assert!(out.stdout.is_empty());
    }

    #[test]
    fn a_running_daemon_on_the_same_plc_fails_the_host_echo() {
        let running = serve::start();
        let address = {
            let config =
                std::fs::read_to_string(running.socket.parent().unwrap().join("linterpd.toml"))
                    .unwrap();
            let at = config.find("address = \"").unwrap() + "address = \"".len();
            config[at..].split('"').next().unwrap().to_owned()
        };
        let dir = TempDir::new("commission-daemon");
        let config = config(&dir, &address);
        let done = commission(&config, &["--yes", "--json", "--channels", "0"]).finish(LONG);
        assert_eq!(done.status.code(), Some(1), "{}", done.describe());
        let report: Report = serde_json::from_str(&done.stdout).unwrap();
        let host = report
            .checks
            .iter()
            .find(|c| c.check == "host echo")
            .unwrap();
        assert_eq!(host.verdict, Verdict::Fail, "{host:?}");
        assert!(
            host.hint.as_deref().unwrap().contains("another host"),
            "{host:?}"
        );
        assert!(
            report
                .checks
                .iter()
                .filter(|c| c.step == linterpd::commission::Step::Pulses)
                .all(|c| c.verdict == Verdict::Skip)
        );
    }
}
