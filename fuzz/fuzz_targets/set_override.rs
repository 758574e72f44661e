//! Fuzz target `set_override`: see [`pn_fuzz::set_override`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::set_override(data));
