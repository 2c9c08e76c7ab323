//! The lease machine on its own: every way a jog ends stops the robot first, and nothing is
//! asked for beyond the pieces in flight or after the lease.

use super::*;

fn start(at: Instant) -> (Lease, Vec<Action>) {
    let mut lease = Lease::default();
    let actions = lease.on(
        Event::Start {
            session: 1,
            axis: JogAxis::X,
            positive: true,
            seq: 1,
        },
        at,
        &LeaseSettings::default(),
    );
    (lease, actions)
}

fn submit() -> Action {
    Action::Submit {
        axis: JogAxis::X,
        positive: true,
    }
}

fn ended(by: EndedBy) -> Vec<Action> {
    vec![Action::Stop, Action::Ended { session: 1, by }]
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A jog with its two pieces queued as moves 10 and 11.
fn running(t0: Instant) -> Lease {
    let (mut lease, _) = start(t0);
    let s = LeaseSettings::default();
    lease.on(Event::Queued { id: 10 }, t0, &s);
    lease.on(Event::Queued { id: 11 }, t0, &s);
    lease
}

#[test]
fn a_start_asks_for_one_running_and_one_waiting_piece() {
    let (lease, actions) = start(Instant::now());
    assert_eq!(actions, vec![submit(), submit()]);
    assert_eq!(lease.jogging().unwrap().asked, 2);
}

#[test]
fn a_piece_that_ends_done_is_followed_by_one_more_while_the_lease_is_fresh() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    assert_eq!(
        lease.on(Event::PieceEnded { id: 10, done: true }, t0 + ms(150), &s),
        // The lease began at t0 and no keep-alive came: 150 ms < 300 ms, still fresh.
        vec![submit()]
    );
    // Never more than two in flight, however many pieces end.
    lease.on(Event::Queued { id: 12 }, t0 + ms(160), &s);
    assert_eq!(lease.jogging().unwrap().pieces, vec![11, 12]);
}

#[test]
fn nothing_more_is_asked_for_while_two_pieces_are_in_flight() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    for k in 2..10 {
        let actions = lease.on(Event::KeepAlive { session: 1, seq: k }, t0 + ms(k * 50), &s);
        assert!(actions.is_empty(), "{actions:?}");
    }
}

#[test]
fn the_lease_expires_300_ms_after_the_last_keep_alive_and_stops_the_robot() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    lease.on(Event::KeepAlive { session: 1, seq: 2 }, t0 + ms(100), &s);
    assert_eq!(lease.deadline(), Some(t0 + ms(400)));
    assert!(lease.on(Event::Tick, t0 + ms(399), &s).is_empty());
    assert_eq!(
        lease.on(Event::Tick, t0 + ms(400), &s),
        ended(EndedBy::Expired)
    );
    assert_eq!(lease, Lease::Idle);
}

#[test]
fn no_piece_is_asked_for_after_the_lease_ran_out() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    // The tick has not come yet, but a piece ending after the lease's end asks for nothing
    // more: it ends the jog.
    assert_eq!(
        lease.on(Event::PieceEnded { id: 10, done: true }, t0 + ms(300), &s),
        ended(EndedBy::Expired)
    );
}

#[test]
fn release_close_hide_seat_and_fault_each_stop_the_jog_first() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let cases = [
        (Event::Release { session: 1 }, EndedBy::Released),
        (Event::Closed { session: 1 }, EndedBy::Closed),
        (Event::Hidden { session: 1 }, EndedBy::Hidden),
        (Event::SeatTaken, EndedBy::SeatTaken),
        (
            Event::Fault {
                reason: "fault 3".into(),
            },
            EndedBy::Fault {
                reason: "fault 3".into(),
            },
        ),
        (
            Event::Refused {
                reason: "joint d3 limit".into(),
            },
            EndedBy::Refused {
                reason: "joint d3 limit".into(),
            },
        ),
    ];
    for (event, by) in cases {
        let mut lease = running(t0);
        assert_eq!(
            lease.on(event.clone(), t0 + ms(50), &s),
            ended(by),
            "{event:?}"
        );
        assert_eq!(lease, Lease::Idle, "{event:?}");
    }
}

#[test]
fn a_piece_that_ends_short_ends_the_jog() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    let actions = lease.on(
        Event::PieceEnded {
            id: 10,
            done: false,
        },
        t0 + ms(20),
        &s,
    );
    assert_eq!(actions[0], Action::Stop);
    assert_eq!(lease, Lease::Idle);
}

#[test]
fn another_sessions_release_or_keep_alive_changes_nothing() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    let before = lease.clone();
    assert!(lease.on(Event::Release { session: 2 }, t0, &s).is_empty());
    assert!(lease.on(Event::Closed { session: 2 }, t0, &s).is_empty());
    assert!(lease.on(Event::Hidden { session: 2 }, t0, &s).is_empty());
    assert!(
        lease
            .on(
                Event::KeepAlive {
                    session: 2,
                    seq: 99
                },
                t0 + ms(200),
                &s
            )
            .is_empty()
    );
    assert_eq!(
        lease, before,
        "the lease was not extended by another session"
    );
}

#[test]
fn a_late_or_repeated_keep_alive_does_not_extend_the_lease() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    lease.on(Event::KeepAlive { session: 1, seq: 5 }, t0 + ms(100), &s);
    lease.on(Event::KeepAlive { session: 1, seq: 5 }, t0 + ms(200), &s);
    lease.on(Event::KeepAlive { session: 1, seq: 4 }, t0 + ms(250), &s);
    assert_eq!(lease.deadline(), Some(t0 + ms(400)));
}

#[test]
fn a_second_start_while_jogging_changes_nothing() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = running(t0);
    let before = lease.clone();
    let again = Event::Start {
        session: 2,
        axis: JogAxis::Y,
        positive: false,
        seq: 50,
    };
    assert!(lease.on(again, t0, &s).is_empty());
    assert_eq!(lease, before);
}

#[test]
fn an_idle_lease_ignores_everything_but_a_start() {
    let t0 = Instant::now();
    let s = LeaseSettings::default();
    let mut lease = Lease::Idle;
    for event in [
        Event::Tick,
        Event::Release { session: 1 },
        Event::KeepAlive { session: 1, seq: 3 },
        Event::PieceEnded { id: 3, done: true },
        Event::SeatTaken,
    ] {
        assert!(lease.on(event, t0, &s).is_empty());
    }
    assert_eq!(lease, Lease::Idle);
}

#[test]
fn the_plc_never_holds_more_than_the_lease_covers() {
    let s = LeaseSettings::default();
    assert!(
        s.committed() <= s.lease,
        "{:?} > {:?}",
        s.committed(),
        s.lease
    );
}

#[test]
fn jogging_is_refused_until_homed_during_a_cycle_in_remote_mode_and_while_faulted() {
    let ok = JogFacts {
        link_up: true,
        homed: true,
        ..JogFacts::default()
    };
    assert_eq!(ok.refusal(), None);
    for (facts, word) in [
        (JogFacts { homed: false, ..ok }, "not homed"),
        (
            JogFacts {
                faulted: true,
                ..ok
            },
            "fault",
        ),
        (
            JogFacts {
                cycle_under_way: true,
                ..ok
            },
            "cycle",
        ),
        (JogFacts { remote: true, ..ok }, "remote"),
        (
            JogFacts {
                link_up: false,
                ..ok
            },
            "link",
        ),
    ] {
        assert!(facts.refusal().unwrap().contains(word), "{facts:?}");
    }
}
