//! The seed's move as command-line arguments.

/// The seed's move, as `linterpd plan` arguments, on the shipped config.
pub const SEED: [&str; 12] = [
    "--from",
    "-926.57,535.03,50",
    "--to",
    "-1144.43,659.60,186.60",
    "--speed",
    "240",
    "--accel-time",
    "200ms",
    "--period",
    "50ms",
    "--config",
    concat!(env!("CARGO_MANIFEST_DIR"), "/config/linterpd.toml"),
];
