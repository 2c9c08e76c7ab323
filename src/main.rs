//! The `linterpd` binary.
fn main() {}
