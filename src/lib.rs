//! linterpd: straight-line moves for PLC-driven robots.
//!
//! A robot whose controller is a motion PLC (a Panasonic FP-X) can output pulses per channel but
//! cannot interpolate several joints along a line. linterpd plans the line on a PC with the
//! constant time period method (LI, HE, WU 2015) or a bounded-error method, turns every joint's
//! motion into F174 pulse tables, judges each table by simulating what the PLC will do with it,
//! and runs it on the PLC through a register contract with a small PLC program.
//!
//! The documents the code cites by name are in the crate's `docs/`: `CONTRACT.md` (the register
//! contract with the PLC program), `PLC.md` (the FP-X, MEWTOCOL-COM, Modbus and F174 facts, by
//! section number) and `ACCURACY.md` (how a table is played and judged).
//!
//! # Layout
//! Rings pointing inward: the pure core does no IO and reads no clock.
//! ```text
//! geometry/    PURE  poses, the line P1P2, the polyline of a curved tool path, the trapezoidal
//!                    profile s(t), the pace along a path, the time-optimal speed (TOPP-RA)
//! kinematics/  PURE  trait Kinematics { fk, ik, check_line }; cylindrical, cartesian, scara; Arm: a
//!                    model with its tool offset (every pose the tool centre's)
//! robot/       PURE  a robot as planned for: model, joints and channels, drive limits, motion
//!                    defaults
//! plan/        PURE  move request (a line, a path section, a line in joint space) -> the
//!                    strategy's candidate timings as values (as asked, time-optimal, averaged or
//!                    slowed S-curve), the fastest plan every drive follows kept (strategy.rs) ->
//!                    joint samples -> pulse tables (constant-period, seed-exact,
//!                    bounded-error), limits and over-speed policy; what the drives follow: the
//!                    time-optimal timing and every row checked (plan/dynamics)
//! table/       PURE  Row, Segment, ControlCode, FrequencyRange, frequency models; validation;
//!                    the DT word image (encode, decode)
//! sim/         PURE  executes a start as ACCURACY.md says -> pulse events and accuracy figures
//! config/      PURE  strict TOML -> validated robots (errors name the file, line, key path and
//!                    value, and the nearest valid key of a misspelt one)
//! gateway/     PURE  the register gateway's addresses (DT, X, Y, R), access lists, and who may use
//!                    its Modbus face (IPs, CIDR networks)
//! contract/    PURE  the register contract (version 3): DT layout, status and command blocks,
//!                    the cell's input words and a start's permit, and the host's side as one
//!                    state machine over the status block (machine/)
//! cycle/       PURE  cycle programs: the document, conditions, the check that flattens a program
//!                    into ops, the runner that steps through them (events in, actions out)
//!                    (and the loading of a programs directory, and whether a program is there)
//! console/     PURE  the operator's console's decisions: the jog lease machine, the control seat
//!                    and roles, a snapshot's changes as a merge patch, failed logins
//!                    rate-limited, a jog's pieces and worst-case travel
//! pallet/      PURE  palletising: a pattern's slots in fill order with their approach and retreat,
//!                    what happens between layers and when full; user frames; the pallet tables
//!                    (grid, layer kinds, fill order) laid out and checked against the reach
//! cell/        PURE  the robot in its press line: the mode (local/remote) and the cell face's
//!                    registers, command edges, strobe and check word, refusals, status words
//! mewtocol/    SANS-IO  MEWTOCOL-COM frames, BCC, typed commands and replies, tokio-util codecs
//! mock/        the mock PLC: DT/R memory, the contract's PLC program, F174 engines on sim's model,
//!                    fault injection, pulse trace (a synchronous core, time is an argument), a
//!                    simulated cell driving its inputs (cell/, PURE: press, stack, sensors);
//!                    around it the MEWTOCOL and Modbus servers, the serial-line emulation and
//!                    the control socket that forces inputs by hand
//! plc/         IO  trait Plc; MEWTOCOL-COM and Modbus clients; links; the contract's exchanges
//!                    (`plc::exchange`: status reads, verified banks, a start written once)
//! plot/        PURE  the SVG of a move planned one or more ways (plotters, SVG backend only), and
//!                    of a pallet's layers (plot/pallet.rs)
//! cli/         the `linterpd` subcommands (one module each) and their output formats
//! journal/     IO  the cell's journal on disk: a writer thread fed over a bounded channel,
//!                    segments in the state directory rotated by size and number, fsync'd
//!                    where it matters, read by number, time and robot
//! daemon/      `linterpd serve`: a worker task per robot owning its PLC link, the move flow,
//!                    handles, taught positions, permits, the cycle driver (cycle/), the mode and
//!                    the cell face's actions (cell/, served on the Modbus face or mirrored in the
//!                    PLC), the HTTP/JSON API, the register gateway and its Modbus TCP face,
//!                    systemd notification, the operator's console's server (console/: the live
//!                    stream, a control task per robot for the seat and the jog lease, the page,
//!                    its WebSocket and logins)
//! demo/        `linterpd demo`: the daemon driving the mock PLC in process, measured from its trace
//!                    (`--console`: the console on the mock in the press cell, the console
//!                    tests' rig)
//! commission/  `linterpd commission`: link, contract and pulse checks of a real unit, judged by
//!                    a pure part (rate fits, frequency models), reported with config lines
//! ```

pub mod cell;
pub mod cli;
pub mod commission;
pub mod config;
pub mod console;
pub mod contract;
pub mod cycle;
pub mod daemon;
pub mod demo;
pub mod gateway;
pub mod geometry;
pub mod journal;
pub mod kinematics;
pub mod mewtocol;
pub mod mock;
pub mod order;
pub mod pallet;
pub mod plan;
pub mod plc;
pub mod plot;
pub mod robot;
pub mod sim;
pub mod table;
#[cfg(test)]
mod testing;
pub mod wire;
