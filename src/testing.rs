//! Helpers shared by the crate's unit tests.

/// Uniform values in `[0, 1)` from a fixed seed (xorshift64): the same sequence on every run,
/// so a test's random cases are the same cases each time.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The tool's largest jerk along `plan`'s course, mm/s^3: the third difference of its distance
/// along the course over 10 ms, at every millisecond.
pub(crate) fn course_jerk(plan: &crate::plan::Plan) -> f64 {
    let tau = 0.01;
    let (mut peak, mut t) = (0.0_f64, 0.0);
    while t + 3.0 * tau <= plan.duration_s() {
        let at = |k: f64| plan.course_mm(plan.window.from_s + t + k * tau);
        let third = at(3.0) - 3.0 * at(2.0) + 3.0 * at(1.0) - at(0.0);
        peak = peak.max(third.abs() / tau.powi(3));
        t += 0.001;
    }
    peak
}

/// An empty directory for a test: `linterpd-{name}-{pid}` under the system's temporary
/// directory, emptied first if a run before left it.
pub(crate) fn fresh_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("linterpd-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A status block the contract's machine reads as sound: the contract's magic and version,
/// homed and ready, `host`'s word, no fault.
pub(crate) fn status(
    state: crate::contract::State,
    seq: u16,
    heartbeat: u16,
    elapsed: [i32; crate::contract::CHANNELS],
    host: u16,
) -> crate::contract::machine::Status {
    use crate::contract::{Fault, MAGIC, StatusBlock, VERSION};
    crate::contract::machine::Status {
        block: StatusBlock {
            magic: MAGIC,
            version: VERSION,
            heartbeat,
            state: state.word(),
            seq,
            ready: 0b111,
            elapsed,
            host,
            ..StatusBlock::default()
        },
        state,
        fault: Fault::None,
    }
}
