//! The instruction-set check: the workspace builds for x86-64-v3 (`.cargo/config.toml`), and
//! a binary that uses AVX2 or FMA on a CPU without them dies of an illegal instruction
//! somewhere. `pn` and the Python module call [`missing_features`] first and stop with its
//! message instead.

/// The CPU features this build was compiled to use that the running CPU lacks, as a message
/// naming them and the way out; `None` when the CPU has them all (or the build assumes none).
pub fn missing_features() -> Option<String> {
    #[allow(unused_mut)]
    let mut missing: Vec<&str> = Vec::new();
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    if !std::arch::is_x86_feature_detected!("avx2") {
        missing.push("avx2");
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "fma"))]
    if !std::arch::is_x86_feature_detected!("fma") {
        missing.push("fma");
    }
    #[cfg(all(target_arch = "x86_64", target_feature = "bmi2"))]
    if !std::arch::is_x86_feature_detected!("bmi2") {
        missing.push("bmi2");
    }
    (!missing.is_empty()).then(|| {
        format!(
            "this build of pnsolver uses the CPU features {} (x86-64-v3, .cargo/config.toml), \
             which this CPU lacks; rebuild with RUSTFLAGS=\"-C target-cpu=x86-64\"",
            missing.join(", ")
        )
    })
}
