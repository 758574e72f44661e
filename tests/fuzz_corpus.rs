//! The fuzz targets (fuzz/, docs/fuzzing.md) on their committed inputs: every seed of
//! fuzz/corpus and every crash the fuzzer found (fuzz/regressions, one file per finding,
//! fixed since) runs through the same function the libFuzzer binary calls, here without
//! libFuzzer, so that `cargo test` keeps them fixed. A panic fails the test; so would an
//! abort or a stack overflow (the test binary dies).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

#[path = "../fuzz/src/lib.rs"]
#[allow(dead_code, missing_docs)]
mod pn_fuzz;

use std::path::Path;

#[test]
fn every_seed_and_regression_input_runs_cleanly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut ran = 0;
    for target in pn_fuzz::TARGETS {
        for kind in ["corpus", "regressions"] {
            let dir = root.join(kind).join(target);
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for e in entries {
                let path = e.unwrap().path();
                let data = std::fs::read(&path).unwrap();
                assert!(pn_fuzz::run(target, &data), "{target}");
                ran += 1;
            }
        }
        assert!(
            std::fs::read_dir(root.join("corpus").join(target))
                .unwrap()
                .next()
                .is_some(),
            "{target} has no seed"
        );
    }
    assert!(ran >= 20, "only {ran} inputs");
}
