//! The PDE text syntax: the shipped PDE files, exactness against the built-in stencils, and
//! errors with line and column.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use pn_codegen::discretize::{cda_ir, pn_ir_for_order};
use pn_codegen::text::{parse_pde, PdeTextError, TextPde};
use pn_stencil::{Dim, Staggering};

fn pde_file(name: &str) -> String {
    let path = format!("{}/../../pdes/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn parse(src: &str) -> TextPde {
    parse_pde(src, &[]).unwrap_or_else(|e| panic!("{e}"))
}

fn err(src: &str) -> PdeTextError {
    match parse_pde(src, &[]).and_then(|p| p.ir(Dim::Three).map(|_| p)) {
        Ok(_) => panic!("expected an error for:\n{src}"),
        Err(e) => e,
    }
}

/// Every source of `cases` fails at (line, column) with a message containing the text;
/// all mismatches are reported together.
fn assert_errors_at<S: AsRef<str>>(cases: &[(S, (usize, usize), &str)]) {
    let mut wrong = Vec::new();
    for (src, (line, col), what) in cases {
        let src = src.as_ref();
        let e = err(src);
        if !(e.message.contains(what) && (e.line, e.col) == (*line, *col)) {
            wrong.push(format!(
                "for\n{src}\nexpected {line}:{col} '{what}', got {e}"
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n\n"));
}

#[test]
fn cda_from_text_is_the_built_in_cda_stencil() {
    let pde = parse(&pde_file("cda.pde"));
    for dim in [Dim::Two, Dim::Three] {
        let mut ir = pde.ir(dim).unwrap();
        let built_in = cda_ir(dim).unwrap();
        assert_eq!(ir.name, format!("pde_cda_{}d", dim.axes()));
        ir.name = built_in.name.clone();
        // Same placement, same terms, same weight expressions, term for term.
        assert_eq!(ir, built_in, "{dim:?}");
    }
}

#[test]
fn included_pn_is_the_derived_pn_stencil() {
    let pde = parse("pde p2text\ninclude pn(2)\n");
    let mut ir = pde.ir(Dim::Three).unwrap();
    let built_in = pn_ir_for_order(2, Dim::Three, Staggering::Staggered).unwrap();
    ir.name = built_in.name.clone();
    assert_eq!(ir, built_in);
}

#[test]
fn sp3_places_both_unknowns_at_the_cell_centre() {
    let pde = parse(&pde_file("sp3.pde"));
    assert_eq!(pde.unknowns.len(), 2);
    assert_eq!(pde.unknowns[0].label, (0, 0));
    assert!(pde.unknowns[0].radiance && !pde.unknowns[1].radiance);
    // φ_2 gets a label beyond band 0 with l+m even.
    let (l, m) = pde.unknowns[1].label;
    assert!(l >= 1 && (l + m) % 2 == 0);
    for dim in [Dim::Two, Dim::Three] {
        let ir = pde.ir(dim).unwrap();
        assert!(ir.moments.iter().all(|m| m.shift == [0, 0, 0]));
        // 7-point Laplacians (5 in 2D): φ_0's row reaches both unknowns at 2·axes+1 offsets.
        let per = 2 * dim.axes() + 1;
        assert_eq!(ir.rows[0].terms.len(), 2 * per);
        // φ_2's row: its own Laplacian and the centred φ_0 term.
        assert_eq!(ir.rows[1].terms.len(), per + 1);
    }
}

#[test]
fn sp1_is_cda_up_to_the_spelling_of_sigma_a() {
    let sp1 = parse(&pde_file("sp1.pde")).ir(Dim::Three).unwrap();
    let cda = cda_ir(Dim::Three).unwrap();
    assert_eq!(sp1.moments, cda.moments);
    let offsets = |ir: &pn_stencil::StencilIr| {
        ir.rows[0]
            .terms
            .iter()
            .map(|t| (t.moment, t.offset))
            .collect::<Vec<_>>()
    };
    assert_eq!(offsets(&sp1), offsets(&cda));
}

#[test]
fn loops_sums_definitions_and_params() {
    let src = "pde t\nparam N = 2\nparam s = 0.5\nlet f(x) = ln(1 + x^4)\ninclude pn(N)\n\
               for l = 1..N, m = -l..l: add L(l, m): s*f(l/(N+1))*L(l, m)\n";
    let base = parse("include pn(2)\n").ir(Dim::Three).unwrap();
    let pde = parse(src);
    assert_eq!(
        pde.params,
        vec![("N".to_string(), 2.0), ("s".to_string(), 0.5)]
    );
    let ir = pde.ir(Dim::Three).unwrap();
    // The centred own-moment weight of an l > 0 row grows by s·ln(1 + (l/3)^4).
    let ctx = Uniform;
    for (row, b) in ir.rows.iter().zip(&base.rows) {
        let l = ir.moments[row.moment].l;
        let w = |r: &pn_stencil::StencilRow| {
            r.terms
                .iter()
                .find(|t| t.moment == r.moment && t.offset == [0, 0, 0])
                .map(|t| t.weight.eval(&ctx))
                .unwrap()
        };
        let expected = if l > 0 {
            0.5 * (1.0 + (l as f64 / 3.0).powi(4)).ln()
        } else {
            0.0
        };
        assert!((w(row) - w(b) - expected).abs() < 1e-14, "l = {l}");
    }
    // A parameter override changes the order.
    let pde = parse_pde(src, &[("N".into(), "3".into())]).unwrap();
    assert_eq!(pde.unknowns.len(), 16);
    // sum(…) expands: a Laplacian written as a sum of second derivatives.
    let a = parse("unknown u = L(0,0)\nequation u: -lap(u) + sigma_a*u = Q(0,0)\n");
    let c =
        parse("unknown u = L(0,0)\nequation u: -sum(k = 1..3, lap(u))/3 + sigma_a*u = Q(0,0)\n");
    assert_eq!(
        a.ir(Dim::Three).unwrap().rows,
        c.ir(Dim::Three).unwrap().rows
    );
}

/// σ_t = 2, σ_s = 1, λ_l p_l = 0.5^l, h = 1.
struct Uniform;
impl pn_stencil::FieldContext for Uniform {
    fn field(&self, f: &pn_stencil::FieldRef, _o: [i32; 3]) -> f64 {
        use pn_stencil::FieldRef::*;
        match f {
            SigmaT => 2.0,
            SigmaS => 1.0,
            SigmaA => 1.0,
            PhaseMoment(l) => 0.5f64.powi(*l as i32),
            _ => 0.0,
        }
    }
    fn inv_h(&self, _axis: usize) -> f64 {
        1.0
    }
}

#[test]
fn errors_carry_line_column_and_reason() {
    let cases: &[(&str, (usize, usize), &str)] = &[
        ("unknown u = L(0,0)\nequation u: -lap(u) + = Q(0,0)\n", (2, 23), "expected an expression"),
        ("unknown u = L(0,0)\nequation u: -lap(v) = Q(0,0)\n", (2, 18), "unknown symbol 'v'"),
        ("unknown u = L(0,0)\nequation u: foo(u) = Q(0,0)\n", (2, 13), "unknown function 'foo'"),
        ("unknown u = L(0,0)\nunknown w\nequation u: -lap(u) = Q(0,0)\n", (2, 1), "not square"),
        ("unknown u = L(0,0)\nequation u: u = 0\nequation u: u = 1\n", (3, 1), "second equation"),
        ("unknown u = L(0,0)\nequation w: u = 0\n", (2, 1), "'w' is not an unknown"),
        ("unknown u = L(0,0)\nequation u: u*u = Q(0,0)\n", (2, 1), "product of two unknowns"),
        ("unknown u = L(0,0)\nequation u: -lap(u) + sigma_a*u = Q(0,0) $\n", (2, 42), "unexpected character"),
        ("unknown u = L(0,0)\nequation u: -div(u) = Q(0,0)\n", (2, 18), "div takes a vector"),
        ("unknown u = L(0,0)\nequation u: (u = 0\n", (2, 18), "unclosed"),
        ("unknown u = L(3,5)\n", (1, 15), "not a moment"),
        ("unknown u = L(0,0)\nequation u: ln(sigma_t)*u = Q(0,0)\n", (2, 13), "constants only"),
        ("param a = 1\nlet a = 2\n", (2, 1), "already defined"),
        ("let sigma_t = 2\n", (1, 1), "built-in name"),
        ("frobnicate u\n", (1, 1), "unknown statement"),
        // u and v coupled through one derivative must be half a cell apart, and also
        // through none: no staggered placement exists.
        (
            "unknown u = L(0,0)\nunknown v\nequation u: dx(v) + u = Q(0,0)\nequation v: v + u = 0\n",
            (4, 1),
            "cannot be placed consistently",
        ),
        (
            "unknown u = L(0,0) at (0,0,0)\nunknown v at (0,0,0)\nequation u: dx(v) + u = Q(0,0)\nequation v: dx(u) + v = 0\n",
            (2, 1),
            "cannot be at",
        ),
    ];
    assert_errors_at(cases);
}

#[test]
fn explicit_placement_moves_a_whole_component() {
    // A P_1-like pair: v on the x faces. Asking for u on the faces moves v to the centre.
    let src = "unknown u = L(0,0) at (1,0,0)\nunknown v\nequation u: dx(v) + u = Q(0,0)\nequation v: dx(u) + v = 0\n";
    let p = parse(src).placement(Dim::Three).unwrap();
    assert_eq!(p[0].shift, [1, 0, 0]);
    assert_eq!(p[1].shift, [0, 0, 0]);
}

#[test]
fn unknown_parameter_overrides_are_refused() {
    let e = parse_pde("param a = 1\n", &[("b".into(), "2".into())]).unwrap_err();
    assert!(e.message.contains("no parameter 'b'"), "{e}");
    let e = parse_pde("param a = 1\n", &[("a".into(), "x".into())]).unwrap_err();
    assert!(e.message.contains("not a decimal"), "{e}");
}

/// Field values for evaluating boundary coefficients.
struct Fields;

impl pn_stencil::FieldContext for Fields {
    fn field(&self, f: &pn_stencil::FieldRef, _offset: pn_stencil::HalfOffset) -> f64 {
        use pn_stencil::FieldRef as F;
        match f {
            F::SigmaT => 2.0,
            F::SigmaS => 1.5,
            F::SigmaA => 0.5,
            F::PhaseMoment(l) => 0.3f64.powi(*l as i32),
            _ => f64::NAN,
        }
    }
    fn inv_h(&self, axis: usize) -> f64 {
        [2.0, 3.0, 5.0][axis]
    }
}

/// The shipped SP_3 Marshak conditions (pdes/sp3.pde) lower to the coefficients derived in
/// the file: `1/2 φ_0 + 5/8 φ_2 + 1/(3σ_1) ∂_n(φ_0 + 2φ_2) = 0` and
/// `−1/8 φ_0 + 5/8 φ_2 + 3/(7σ_3) ∂_nφ_2 = 0` with σ_n = σ_t − σ_s g^n (HG g = 0.3 here),
/// in 2D and 3D; SP_1's and CDA's are `1/2 φ + 1/(3σ_1) ∂_nφ = 0`.
#[test]
fn boundary_statements_lower_to_the_derived_coefficients() {
    let sigma = |n: i32| 2.0 - 1.5 * 0.3f64.powi(n);
    let pde = parse(&pde_file("sp3.pde"));
    for dim in [Dim::Two, Dim::Three] {
        let b = pde.boundary(dim, "marshak").unwrap().unwrap();
        assert_eq!(b.kind, "marshak");
        let get = |terms: &[(usize, pn_stencil::Weight)], q: usize| {
            terms
                .iter()
                .find(|t| t.0 == q)
                .map_or(0.0, |t| t.1.eval(&Fields))
        };
        let c0 = &b.conditions[b.condition_of(0).unwrap()];
        let c2 = &b.conditions[b.condition_of(1).unwrap()];
        let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
        assert!(close(get(&c0.value, 0), 0.5) && close(get(&c0.value, 1), 0.625));
        assert!(close(get(&c0.normal, 0), 1.0 / (3.0 * sigma(1))));
        assert!(close(get(&c0.normal, 1), 2.0 / (3.0 * sigma(1))));
        assert!(close(get(&c2.value, 0), -0.125) && close(get(&c2.value, 1), 0.625));
        assert!(close(get(&c2.normal, 0), 0.0));
        assert!(close(get(&c2.normal, 1), 3.0 / (7.0 * sigma(3))));
    }
    for file in ["sp1.pde", "cda.pde"] {
        let b = parse(&pde_file(file))
            .boundary(Dim::Three, "marshak")
            .unwrap()
            .unwrap();
        assert_eq!(b.conditions.len(), 1, "{file}");
        let c = &b.conditions[0];
        assert!((c.value[0].1.eval(&Fields) - 0.5).abs() < 1e-15, "{file}");
        assert!(
            (c.normal[0].1.eval(&Fields) - 1.0 / (3.0 * sigma(1))).abs() < 1e-15,
            "{file}"
        );
    }
    // A PDE without boundary statements states none.
    assert!(parse(&pde_file("fpn.pde"))
        .boundary(Dim::Three, "marshak")
        .unwrap()
        .is_none());
}

/// Bad `boundary` statements: errors with line, column and reason, never a panic.
#[test]
fn boundary_errors_carry_line_column_and_reason() {
    let sp = "unknown u = L(0,0)\nunknown w\nequation u: -lap(u + 2*w) + u = Q(0,0)\nequation w: -lap(w) + w - u = 0\n";
    let cases: Vec<(String, (usize, usize), &str)> = vec![
        // A condition on an unknown that does not exist (column of its name).
        (
            format!("{sp}boundary marshak u: u/2 + dn(u) = 0\nboundary marshak v: w + dn(w) = 0\n"),
            (6, 18),
            "'v' is not an unknown",
        ),
        (
            format!("{sp}boundary marshak L(1, 0): u/2 + dn(u) = 0\n"),
            (5, 18),
            "L(1, 0) is not an unknown",
        ),
        // Malformed statements.
        (format!("{sp}boundary marshak u u/2 + dn(u) = 0\n"), (5, 20), "expected ':'"),
        (format!("{sp}boundary marshak u: u/2 + dn(u)\n"), (5, 32), "expected '='"),
        (format!("{sp}boundary\n"), (5, 9), "expected the boundary kind"),
        (format!("{sp}boundary robin u: u + dn(u) = 0\n"), (5, 10), "unknown boundary kind 'robin'"),
        (format!("{sp}boundary marshak u: u/2 + dn(u = 0\n"), (5, 34), "unclosed"),
        (format!("{sp}boundary marshak u: u/2 + dn(u, w) = 0\n"), (5, 27), "dn takes 1 argument"),
        // What a condition may contain.
        (format!("{sp}boundary marshak u: u/2 + dn(u) = 1\nboundary marshak w: dn(w) = 0\n"), (5, 1), "homogeneous"),
        (format!("{sp}boundary marshak u: u/2 = 0\nboundary marshak w: dn(w) = 0\n"), (5, 1), "needs a normal derivative"),
        (format!("{sp}boundary marshak u: u/2 + dx(u) = 0\nboundary marshak w: dn(w) = 0\n"), (5, 1), "written dn(…)"),
        (format!("{sp}boundary marshak u: u*dn(u) = 0\nboundary marshak w: dn(w) = 0\n"), (5, 1), "product of unknowns"),
        (format!("{sp}boundary marshak u: dn(dn(u)) = 0\nboundary marshak w: dn(w) = 0\n"), (5, 1), "first normal derivatives"),
        (format!("{sp}boundary marshak u: dn(sigma_t*u) = 0\nboundary marshak w: dn(w) = 0\n"), (5, 1), "constant coefficients"),
        (format!("{sp}boundary marshak u: dn(sigma_t) + dn(u) = 0\nboundary marshak w: dn(w) = 0\n"), (5, 1), "applies to unknowns"),
        (format!("{sp}boundary marshak u: exp(u) + dn(u) = 0\nboundary marshak w: dn(w) = 0\n"), (5, 21), "constants only"),
        // dn outside a boundary statement.
        ("unknown u = L(0,0)\nequation u: dn(u) + u = Q(0,0)\n".to_string(), (2, 13), "boundary statements only"),
        // Square: one condition per unknown, no second one.
        (format!("{sp}boundary marshak u: u/2 + dn(u) = 0\n"), (2, 1), "unknown w has no `boundary marshak` condition"),
        (
            format!("{sp}boundary marshak u: u/2 + dn(u) = 0\nboundary marshak w: dn(w) = 0\nboundary marshak u: dn(u) = 0\n"),
            (7, 1),
            "a second `boundary marshak` condition for u",
        ),
    ];
    assert_errors_at(&cases);
}

/// `eliminate`: solving P_1's band 1 from its own equations and substituting gives CDA's
/// stencil — the same terms (unknown, offset) with the same weights (evaluated with fields
/// that differ per band), 2D and 3D; the right-hand side keeps the band-1 source, which CDA
/// drops (it gains −∇·(Q_1/(√3 σ_1))-type terms).
#[test]
fn eliminating_p1s_first_band_gives_cda() {
    let pde = parse("pde d0\ninclude pn(1)\nfor m = -1..1: eliminate L(1, m)\n");
    assert_eq!(pde.unknowns.len(), 1);
    for dim in [Dim::Two, Dim::Three] {
        let ir = pde.ir(dim).unwrap();
        let cda = cda_ir(dim).unwrap();
        assert_eq!(ir.moments, cda.moments);
        let (a, b) = (&ir.rows[0].terms, &cda.rows[0].terms);
        assert_eq!(a.len(), b.len(), "{dim:?}");
        for (x, y) in a.iter().zip(b) {
            assert_eq!((x.moment, x.offset), (y.moment, y.offset));
            let (wx, wy) = (x.weight.eval(&Fields), y.weight.eval(&Fields));
            assert!(
                (wx - wy).abs() < 1e-13 * wy.abs().max(1.0),
                "{dim:?} {wx} vs {wy}"
            );
        }
    }
}

/// Bad `eliminate` statements: line, column and reason.
#[test]
fn eliminate_errors_carry_line_column_and_reason() {
    let p1 = "unknown u = L(0,0)\nunknown v\nequation u: dx(v) + u = Q(0,0)\n";
    let cases: Vec<(String, (usize, usize), &str)> = vec![
        (format!("{p1}equation v: dx(u) + v = 0\neliminate w\n"), (5, 11), "'w' is not an unknown"),
        (
            format!("{p1}equation v: dx(u) + dx(v) + v = 0\neliminate v\n"),
            (5, 11),
            "differentiated in its own equation",
        ),
        (format!("{p1}equation v: dx(u) = 0\neliminate v\n"), (5, 11), "does not contain it"),
        (format!("{p1}equation v: dx(u) + u*v = 0\neliminate v\n"), (5, 11), "coefficient contains an unknown"),
        (format!("{p1}equation v: dx(u) + v = 0\neliminate v\neliminate v\n"), (6, 11), "eliminated twice"),
        (
            format!("{p1}equation v: dx(u) + v = 0\neliminate v\nboundary marshak u: u/2 + dn(u) = 0\nboundary marshak v: dn(v) = 0\n"),
            (7, 18),
            "v was eliminated",
        ),
        (format!("{p1}equation v: dx(u) + v = 0\neliminate\n"), (5, 10), "expected an unknown"),
    ];
    assert_errors_at(&cases);
}
