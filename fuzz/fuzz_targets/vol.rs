//! Fuzz target `vol`: see [`pn_fuzz::vol`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::vol(data));
