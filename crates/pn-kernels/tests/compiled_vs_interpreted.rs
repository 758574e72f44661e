//! Compiled (build.rs) versus interpreted stencils and the run-time fallback.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_codegen::discretize::{cda_ir, diffusion_ir, pn_ir_for_order, pn_name};
use pn_kernels::compiled;
use pn_kernels::{cda_kernel, diffusion_kernel, pn_kernel, Dim, Staggering};
use pn_stencil::{FieldContext, FieldRef, HalfOffset, StencilIr, StencilKernel};
use pn_stencil::{InterpretedKernel, TreeWalk};

/// Deterministic pseudo-random field values per (field, offset, seed) in [0.5, 1.5).
struct RandomFields(u64);

impl FieldContext for RandomFields {
    fn field(&self, field: &FieldRef, offset: HalfOffset) -> f64 {
        let mut h = self.0 ^ 0x9E37_79B9_7F4A_7C15;
        for b in format!("{field:?}{offset:?}").bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x100_0000_01B3);
            h ^= h >> 29;
        }
        0.5 + (h >> 11) as f64 / (1u64 << 53) as f64
    }
    fn inv_h(&self, axis: usize) -> f64 {
        [7.0, 11.0, 13.0][axis] * (1.0 + self.0 as f64 * 0.1)
    }
}

/// Same placement, same patterns, and weights/rhs equal up to rounding (the generated
/// code divides where the interpreter multiplies by a reciprocal: relative 1e-13).
fn assert_same_kernel(compiled: &dyn StencilKernel, interpreted: &dyn StencilKernel) {
    let name = compiled.name();
    assert_eq!(name, interpreted.name());
    assert_eq!(compiled.dim(), interpreted.dim(), "{name}");
    assert_eq!(compiled.moments(), interpreted.moments(), "{name}");
    for r in 0..compiled.moments().len() {
        assert_eq!(
            compiled.pattern(r),
            interpreted.pattern(r),
            "{name} row {r}"
        );
        let n = compiled.pattern(r).len();
        for seed in 0..3 {
            let ctx = RandomFields(seed);
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            let ra = compiled.eval_row(r, &ctx, &mut a);
            let rb = interpreted.eval_row(r, &ctx, &mut b);
            for (k, (x, y)) in a.iter().zip(&b).enumerate() {
                assert!(
                    (x - y).abs() <= 1e-13 * (x.abs() + y.abs() + 1e-300),
                    "{name} row {r} term {k}: compiled {x} vs interpreted {y}"
                );
            }
            assert!(
                (ra - rb).abs() <= 1e-13 * (ra.abs() + rb.abs() + 1e-300),
                "{name} rhs"
            );
        }
    }
}

#[test]
fn compiled_and_interpreted_stencils_agree() {
    let mut checked = Vec::new();
    let mut irs: Vec<StencilIr> = Vec::new();
    for dim in [Dim::Two, Dim::Three] {
        irs.push(cda_ir(dim).unwrap());
        irs.push(diffusion_ir(dim).unwrap());
    }
    for order in 1..=15 {
        for dim in [Dim::Two, Dim::Three] {
            for layout in [Staggering::Staggered, Staggering::Collocated] {
                if compiled::find(&pn_name(order, dim, layout)).is_some() {
                    irs.push(pn_ir_for_order(order, dim, layout).unwrap());
                }
            }
        }
    }
    // The PDE text files build.rs compiles by default (every pdes/*.pde), both dimensions.
    let pde_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../pdes");
    let mut pde_files = 0;
    for entry in std::fs::read_dir(&pde_dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|x| x == "pde") {
            pde_files += 1;
            let text = std::fs::read_to_string(&path).unwrap();
            let pde = pn_codegen::text::parse_pde(&text, &[]).unwrap();
            for dim in [Dim::Two, Dim::Three] {
                let ir = pde.ir(dim).unwrap();
                if std::env::var_os("PN_PDES").is_none() {
                    assert_eq!(compiled::fingerprint(&ir.name), Some(ir.fingerprint()));
                }
                if compiled::find(&ir.name).is_some() {
                    irs.push(ir);
                }
            }
        }
    }
    for ir in irs {
        let k = compiled::find(&ir.name).unwrap_or_else(|| panic!("{} not compiled", ir.name));
        let interpreted = InterpretedKernel::new(ir.clone());
        // Every derived stencil row has a flat program (a text PDE's row with more than
        // the program's slots, DP_N's, walks its trees: checked all the same below).
        if !ir.name.starts_with("pde_") {
            assert_eq!(interpreted.tree_walked_rows(), 0, "{}", ir.name);
        }
        assert_same_kernel(k, &interpreted);
        checked.push(ir.name);
    }
    // Every compiled kernel was compared.
    for k in compiled::KERNELS.iter() {
        assert!(
            checked.iter().any(|n| n == k.name()),
            "{} unchecked",
            k.name()
        );
    }
    // The default build (PN_ORDERS unset) compiles P_1..P_5 in 2D/3D, both layouts.
    // and the PDE files in both dimensions.
    if std::env::var_os("PN_ORDERS").is_none() && std::env::var_os("PN_PDES").is_none() {
        assert_eq!(compiled::KERNELS.len(), 5 * 2 * 2 + 4 + 2 * pde_files);
    }
}

#[test]
fn kernels_come_compiled_or_interpreted() {
    let k = cda_kernel(Dim::Three).unwrap();
    assert!(k.compiled);
    assert_eq!(k.note, None);
    assert_eq!(k.kernel.name(), "cda_3d");
    let k = diffusion_kernel(Dim::Two).unwrap();
    assert!(k.compiled);
    assert_eq!(k.kernel.moments().len(), 1);
    // An order that is not compiled falls back to the interpreter.
    let order = (1..=8)
        .find(|&n| compiled::find(&pn_name(n, Dim::Two, Staggering::Staggered)).is_none())
        .expect("some order up to 8 is not compiled");
    let k = pn_kernel(order, Dim::Two, Staggering::Staggered).unwrap();
    assert!(!k.compiled);
    assert_eq!(
        k.note.as_deref(),
        Some(
            format!(
                "note: stencil {} was not compiled in (see PN_ORDERS); interpreting it at run time",
                pn_name(order, Dim::Two, Staggering::Staggered)
            )
            .as_str()
        )
    );
    assert_eq!(k.kernel.moments().len(), (order + 1) * (order + 2) / 2);
    if let Some(c) = compiled::find(&pn_name(1, Dim::Three, Staggering::Staggered)) {
        let k = pn_kernel(1, Dim::Three, Staggering::Staggered).unwrap();
        assert!(k.compiled);
        assert_same_kernel(c, k.kernel.as_ref());
    }
    assert!(pn_kernel(0, Dim::Three, Staggering::Staggered).is_err());
}

/// Beyond the compiled orders the interpreter's flat row programs are all there is: every
/// row of P_6–P_9 (3D staggered, 2D collocated) has one, and it gives the tree walk's
/// weights and right-hand side to rounding (1e-13 relative; constants are folded).
#[test]
fn flat_programs_match_the_tree_walk_beyond_the_compiled_orders() {
    for order in 6..=9 {
        for (dim, layout) in [
            (Dim::Three, Staggering::Staggered),
            (Dim::Two, Staggering::Collocated),
        ] {
            let k = InterpretedKernel::new(pn_ir_for_order(order, dim, layout).unwrap());
            assert_eq!(k.tree_walked_rows(), 0, "{}", k.name());
            assert_same_kernel(&TreeWalk(&k), &k);
        }
    }
}

/// A text PDE's stencil is the compiled one only for the IR it was compiled from; other
/// parameters give the interpreted IR and a note saying why (the library prints nothing).
#[test]
fn pde_kernel_notes_a_compiled_stencil_from_other_parameters() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../pdes/fpn.pde");
    let text = std::fs::read_to_string(path).unwrap();
    let default = pn_codegen::text::parse_pde(&text, &[]).unwrap();
    let name = default.ir(Dim::Three).unwrap().name;
    if compiled::fingerprint(&name) != Some(default.ir(Dim::Three).unwrap().fingerprint()) {
        return; // PN_PDES compiled another set of files
    }
    let k = pn_kernels::pde_kernel(&default, Dim::Three).unwrap();
    assert!(k.compiled);
    assert_eq!(k.note, None);
    let other = pn_codegen::text::parse_pde(&text, &[("f_eff".into(), "7".into())]).unwrap();
    let k = pn_kernels::pde_kernel(&other, Dim::Three).unwrap();
    assert!(!k.compiled);
    assert_eq!(
        k.note.as_deref(),
        Some(
            format!(
                "note: the compiled stencil {name} was built from a different text or other \
                 parameters; interpreting this one"
            )
            .as_str()
        )
    );
}
