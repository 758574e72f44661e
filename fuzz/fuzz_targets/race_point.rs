//! Fuzz target `race_point`: see [`pn_fuzz::race_point`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::race_point(data));
