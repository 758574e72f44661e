//! The generated stencil code depends on `pn-stencil` only (docs/architecture.md): every
//! path it names starts at `pn_stencil`, the standard library or the module itself, so the
//! generated code could be compiled with `pn-stencil` as its one dependency.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

/// The code `build.rs` generated for this build.
const GENERATED: &str = include_str!(concat!(env!("OUT_DIR"), "/stencils.rs"));

/// The roots a path in the generated code may start with.
const ALLOWED_ROOTS: [&str; 6] = ["pn_stencil", "std", "core", "crate", "self", "super"];

/// Every lower-case identifier directly followed by `::` at the start of a path: after
/// whitespace, `(`, `<`, `&`, `{`, `,`, `!` or at a line start (not after another `::`).
fn path_roots(src: &str) -> Vec<String> {
    let bytes = src.as_bytes();
    let mut roots = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        if c.is_ascii_lowercase() || c == b'_' {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            let preceded_by_path = start >= 2 && &src[start - 2..start] == "::";
            let preceded_by_ident = start >= 1
                && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_');
            if !preceded_by_path && !preceded_by_ident && src[i..].starts_with("::") {
                roots.push(src[start..i].to_string());
            }
        } else {
            i += 1;
        }
    }
    roots
}

#[test]
fn generated_code_names_no_crate_but_pn_stencil() {
    assert!(GENERATED.len() > 1000, "no generated code found");
    // Lints (`#[allow(clippy::...)]`) are attributes, not dependencies.
    let code: String = GENERATED
        .lines()
        .filter(|l| !l.trim_start().starts_with("#"))
        .collect::<Vec<_>>()
        .join("\n");
    let mut foreign: Vec<String> = path_roots(&code)
        .into_iter()
        .filter(|r| !ALLOWED_ROOTS.contains(&r.as_str()))
        // The lint tool's namespace in attributes that span lines.
        .filter(|r| r != "clippy")
        // Modules the generated file defines itself (one per stencil, e.g. `p3_3d_staggered`).
        .filter(|r| !code.contains(&format!("pub mod {r}")))
        .collect();
    foreign.sort();
    foreign.dedup();
    assert!(foreign.is_empty(), "the generated code names {foreign:?}");
    assert!(
        code.contains("pn_stencil::"),
        "the generated code names no pn_stencil path"
    );
}

#[test]
fn the_path_scan_finds_a_foreign_crate() {
    let roots = path_roots("use pn_codegen::x;\nfn f() { std::mem::swap(a, b); cas::Expr::new() }");
    assert_eq!(roots, ["pn_codegen", "std", "cas"]);
}
