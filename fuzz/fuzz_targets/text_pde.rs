//! Fuzz target `text_pde`: see [`pn_fuzz::text_pde`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::text_pde(data));
