//! Fuzz the `.fbgm` decoder (the checks are in `src/lib.rs`, shared with the corpus replay).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| fbg_shared_fuzz::decode_input(data));
