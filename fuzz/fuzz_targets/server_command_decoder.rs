//! Fuzzes the PLC's command decoder (`ServerCodec`, over the shared frame decoder): see the
//! harness in `src/lib.rs` for what is checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use linterpd::mewtocol::ServerCodec;

fuzz_target!(|data: &[u8]| linterpd_fuzz::fuzz(data, ServerCodec::new));
