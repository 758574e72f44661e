//! Fuzz target `render_scene`: see [`pn_fuzz::render_scene`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::render_scene(data));
