//! Fuzz target `exr`: see [`pn_fuzz::exr`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::exr(data));
