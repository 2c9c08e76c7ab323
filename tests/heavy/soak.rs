//! A short soak in the test suite (the full one is `cargo bench --bench soak`): 100 moves over
//! MEWTOCOL-COM on paused time through replies corrupted, dropped and delayed at random.

use crate::common;

#[path = "../../benches/soak.rs"]
#[allow(dead_code, unreachable_pub)]
mod bench;

#[test]
fn a_hundred_moves_through_a_lossy_link_keep_every_invariant() {
    common::paused(async {
        let summary = bench::soak(bench::SoakLink::Mewtocol, 100).await;
        let text = bench::report(bench::SoakLink::Mewtocol, &summary);
        println!("{text}");
        assert!(bench::clean(&summary), "{text}");
        assert!(summary.starts > 50, "most moves ran: {text}");
    });
}
