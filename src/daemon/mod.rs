//! The `linterpd serve` daemon: the application ring around the PLC link, its API and systemd.

pub mod notify;
