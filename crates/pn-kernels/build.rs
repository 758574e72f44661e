//! Generates the compiled stencils into `OUT_DIR/stencils.rs` with
//! [`pn_codegen::codegen::Builder`] for the P_N orders in `PN_ORDERS` (default `1,2,3,4,5`).
fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if let Err(err) = pn_codegen::codegen::Builder::compile_for_build_script() {
        eprintln!("error: generating stencils: {err}");
        std::process::exit(1);
    }
}
