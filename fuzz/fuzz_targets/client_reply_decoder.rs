//! Fuzzes the host's reply decoder (`ClientCodec`, over the shared frame decoder): see the
//! harness in `src/lib.rs` for what is checked.
#![no_main]

use libfuzzer_sys::fuzz_target;
use linterpd::mewtocol::ClientCodec;

fuzz_target!(|data: &[u8]| linterpd_fuzz::fuzz(data, ClientCodec::new));
