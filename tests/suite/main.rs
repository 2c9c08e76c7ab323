//! The integration tests that run on real time (the daemon, its API and CLI, the mock's
//! servers, cycles, the gateway), in one binary: one compile and one link for them all. The
//! CPU-bound ones on paused time (the fault matrix, the property tests, the soaks) are in
//! tests/heavy, run after, so they never share the cores with a test that keeps time; the second
//! suite's peers (`interop_modbus`, `deploy`) stay apart. A file here is a module: run one with
//! `cargo test --test suite <module>::`.

#[path = "../common/mod.rs"]
mod common;

mod api;
mod blended_moves;
mod cell_face;
mod cli_client;
mod cli_compare;
mod cli_daemon;
mod cli_plan;
mod commission;
mod console;
mod contract_exchange;
mod cycles;
mod daemon;
mod demo;
mod first_path;
mod gateway;
mod interop_rmodbus;
mod io_cli;
mod jog_teach;
mod journal;
mod layers;
mod mock_servers;
mod modbus_face;
mod pallet_ops;
mod pallets;
mod path_progress;
mod paths;
mod permits;
mod reload;
mod try_cell;
mod upload_faults;
