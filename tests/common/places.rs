//! The mock's record of the parts a gripper let go (issue 48's pallet tests): every write of the
//! gripper's relay, with the counts the robot stood on as it landed, and every power cut, with
//! the relays it turned off and the counts it lost. The gripper opening (by a write or by a power
//! cut) while it held a part, on a slot's counts (within a pulse), is a part left on that slot;
//! anywhere else the part is lost. Independent of the daemon: it reads only what the mock did.

use linterpd::gateway::Area;
use linterpd::mock::SharedMock;

/// Each time the gripper (relay bit `gripper`: word * 16 + bit, R100 is 160) opened holding a
/// part, in order: the slot of
/// `slots` (counts per channel) it opened on, or `None` (off every slot).
pub fn releases(shared: &SharedMock, gripper: u32, slots: &[[i64; 4]]) -> Vec<Option<usize>> {
    let on_slot = |counts: &[i64; 4]| {
        slots.iter().position(|s| {
            s.iter()
                .zip(counts)
                .all(|(want, got)| (want - got).abs() <= 1)
        })
    };
    // (command, 0 for a cut and 1 for a write: a cut fires before its command's write; the
    // gripper after it; the counts).
    let mut events: Vec<(u64, u8, bool, [i64; 4])> = shared.with(|m| {
        let writes = m
            .host_writes()
            .iter()
            .filter(|w| w.area == Area::R && w.start == gripper)
            .map(|w| (w.command, 1, w.values[0] != 0, w.counts));
        let cuts = m
            .power_cuts()
            .iter()
            .filter(|c| c.relays.contains(&gripper))
            .map(|c| (c.command, 0, false, c.counts));
        writes.chain(cuts).collect()
    });
    events.sort_by_key(|e| (e.0, e.1));
    let mut holding = false;
    let mut out = Vec::new();
    for (_, _, closed, counts) in events {
        if holding && !closed {
            out.push(on_slot(&counts));
        }
        holding = closed;
    }
    out
}

/// The slots the record has a part left on, in order.
pub fn places(shared: &SharedMock, gripper: u32, slots: &[[i64; 4]]) -> Vec<usize> {
    releases(shared, gripper, slots)
        .into_iter()
        .flatten()
        .collect()
}
