//! The CPU-bound integration tests, on paused time or none: the fault matrix, the property
//! tests and the short soaks, in one binary (the tests that keep real time are in tests/suite,
//! so the two never share the cores). A file here is a module: run one with
//! `cargo test --test heavy <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod bounded_properties;
mod cycle_soak;
mod drive_properties;
mod fault_matrix;
mod joint_properties;
mod path_properties;
mod planner_properties;
mod soak;
