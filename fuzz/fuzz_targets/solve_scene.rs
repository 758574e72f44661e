//! Fuzz target `solve_scene`: see [`pn_fuzz::solve_scene`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::solve_scene(data));
