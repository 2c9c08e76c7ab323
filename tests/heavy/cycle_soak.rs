//! A short cycle soak in the test suite (the full one is `cargo bench --bench cycle_soak`, 1000
//! cycles): the press program through a lossy link on paused time, every invariant checked.

use crate::common;

#[path = "../../benches/cycle_soak.rs"]
#[allow(dead_code, unreachable_pub)]
mod bench;

#[test]
fn fifty_press_cycles_through_a_lossy_link_keep_every_invariant() {
    common::paused(async {
        let summary = bench::cycle_soak(50).await;
        let text = bench::report(&summary);
        println!("{text}");
        assert!(bench::clean(&summary), "{text}");
        assert_eq!(summary.done, 50, "{text}");
    });
}
