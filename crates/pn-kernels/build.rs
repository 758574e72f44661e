//! Generates the compiled stencils into `OUT_DIR/stencils.rs` with
//! [`pn_codegen::codegen::Builder`] for the P_N orders in `PN_ORDERS` (default `1,2,3,4,5`)
//! and the PDE text files in `PN_PDES` (default: every `*.pde` in the workspace's `pdes/`).
//! The environment is read and the file written here, not in the library: the builder takes
//! plain values and returns the source.
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if let Err(err) = generate() {
        eprintln!("error: generating stencils: {err}");
        std::process::exit(1);
    }
}

fn generate() -> Result<(), String> {
    println!("cargo:rerun-if-env-changed=PN_ORDERS");
    println!("cargo:rerun-if-env-changed=PN_PDES");
    let out = std::env::var_os("OUT_DIR").ok_or("OUT_DIR is not set")?;
    // The workspace's pdes/ folder, two levels above this crate.
    let pde_dir = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(|d| PathBuf::from(d).join("../../pdes"))
        .unwrap_or_else(|| PathBuf::from("pdes"));
    // Unset is `None`; a value that is not Unicode counts as unset, as `env::var(..).ok()` did.
    let orders = std::env::var("PN_ORDERS").ok();
    let pdes = std::env::var("PN_PDES").ok();
    let output = pn_codegen::codegen::Builder::compile_for_build_script(
        orders.as_deref(),
        pdes.as_deref(),
        &pde_dir,
    )
    .map_err(|e| e.to_string())?;
    let stencils = PathBuf::from(out).join("stencils.rs");
    std::fs::write(&stencils, output.source)
        .map_err(|e| format!("writing {}: {e}", stencils.display()))?;
    for path in &output.rerun_if_changed {
        println!("cargo:rerun-if-changed={}", path.display());
    }
    Ok(())
}
