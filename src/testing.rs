//! Helpers for the unit tests: input, a seed; output, a repeatable
//! sequence of numbers.

/// Numbers in `[0, 1)` from a xorshift generator seeded with `seed`: the
/// same sequence on every run, so a failing case can be run again.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}
