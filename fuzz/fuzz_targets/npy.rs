//! Fuzz target `npy`: see [`pn_fuzz::npy`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| pn_fuzz::npy(data));
