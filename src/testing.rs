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
