//! The procedure's bookkeeping: skipped checks after a stop, the plan of checks.

use super::*;
use crate::plc::{SerialSettings, Transport};

fn target() -> Target {
    let link = LinkSettings::new(
        Protocol::Mewtocol,
        Transport::Serial(SerialSettings {
            path: "/dev/ttyUSB0".into(),
            baud: 19_200,
            data_bits: 8,
            parity: crate::plc::Parity::Odd,
            stop_bits: 1,
        }),
    );
    Target::new(crate::robot::seed_robot(), link)
}

#[test]
fn a_stop_skips_every_later_check_and_names_the_failure() {
    let target = target();
    let mut seen = Vec::new();
    let mut observe = |c: &CheckReport| seen.push(c.title());
    let mut s = Session {
        target: &target,
        checks: Vec::new(),
        findings: Findings::default(),
        stopped: None,
        observe: &mut observe,
    };
    let c = Check::new(Step::Link, "headers %, <", "x");
    assert_eq!(s.record(c.pass("fine")), Ok(()));
    let c = Check::new(Step::Link, "largest frame/read/write", "x");
    assert_eq!(s.record(c.config("small", "set it")), Ok(()));
    let c = Check::new(Step::Link, "multi-frame read", "x");
    assert_eq!(s.record(c.skip("< frames")), Ok(()));
    let c = Check::new(Step::Link, "round trip", "x");
    assert_eq!(s.record(c.fail("dead", "fix it")), Err(Halt));
    s.skip_the_rest();
    let planned = 6 + 5 + 1 + 9 * 4;
    assert_eq!(s.checks.len(), planned);
    assert!(s.checks[4..].iter().all(|c| c.verdict == Verdict::Skip));
    assert!(
        s.checks[4].saw.contains("link: round trip failed"),
        "{}",
        s.checks[4].saw
    );
    assert_eq!(s.stopped.as_deref(), Some("link: round trip failed"));
    assert!(!s.checks[1].stopped && s.checks[3].stopped);
    drop(s);
    assert_eq!(seen.len(), planned);
    assert_eq!(seen[11], "inputs: copied every scan");
    assert_eq!(seen[12], "pulses: busy on then off (channel 0)");
}

#[test]
fn the_link_is_described_with_its_transport_and_station() {
    assert_eq!(
        describe_link(&target().link),
        "mewtocol over /dev/ttyUSB0 at 19200 baud, station 1"
    );
}
