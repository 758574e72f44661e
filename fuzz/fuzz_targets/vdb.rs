//! Fuzz target `vdb`: see [`pn_fuzz::vdb`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::vdb(data));
