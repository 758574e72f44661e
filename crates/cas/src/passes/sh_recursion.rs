//! The recursion relations for `ω_x Y_l^m`, `ω_y Y_l^m`, `ω_z Y_l^m` (complex basis with
//! the Condon–Shortley phase, docs/design.md §2.1).
//!
//! The coefficients are emitted as named functions `a_{l,m}` … `f_{l,m}`
//! (`Expr::Func("a", [l, m])`); [`define_coefficients`] replaces them by their closed
//! forms, e.g. `a_{l,m} = √((l−m+1)(l+m+1)/((2l+3)(2l+1)))`.

use crate::expr::{Axis, DirVar, Expr, ShKind};
use crate::passes::subst::replace;

fn add(a: &Expr, k: i64) -> Expr {
    Expr::Add(vec![a.clone(), Expr::Int(k)])
}

fn coef(name: &str, l: &Expr, m: &Expr) -> Expr {
    Expr::Func(name.into(), vec![l.clone(), m.clone()])
}

/// `ω_axis · Y_l^m(dir)` for the complex `Y` (not conjugated) as a sum of complex `Y`s.
pub fn recursion(axis: Axis, l: &Expr, m: &Expr, dir: DirVar) -> Expr {
    let y = |dl: i64, dm: i64| Expr::sh(ShKind::Complex, add(l, dl), add(m, dm), dir);
    let t = |c: Expr, name: &str, dl: i64, dm: i64| Expr::Mul(vec![c, coef(name, l, m), y(dl, dm)]);
    let half = Expr::rational(1, 2);
    let q = |p: i64| Expr::rational(p, 2);
    match axis {
        // ω_z Y_l^m = a Y_{l+1}^m + b Y_{l−1}^m
        Axis::Z => Expr::Add(vec![
            t(Expr::int(1), "a", 1, 0),
            t(Expr::int(1), "b", -1, 0),
        ]),
        // ω_x Y = ½(−c Y_{l+1}^{m+1} + d Y_{l−1}^{m+1} + e Y_{l+1}^{m−1} − f Y_{l−1}^{m−1})
        Axis::X => Expr::Add(vec![
            t(q(-1), "c", 1, 1),
            t(half.clone(), "d", -1, 1),
            t(half, "e", 1, -1),
            t(q(-1), "f", -1, -1),
        ]),
        // ω_y Y = (1/2i)(−c Y_{l+1}^{m+1} + d Y_{l−1}^{m+1} − e Y_{l+1}^{m−1} + f Y_{l−1}^{m−1}),
        // 1/(2i) = −i/2.
        Axis::Y => {
            let mi = |s: i64| Expr::Mul(vec![Expr::rational(-s, 2), Expr::I]);
            Expr::Add(vec![
                t(mi(-1), "c", 1, 1),
                t(mi(1), "d", -1, 1),
                t(mi(-1), "e", 1, -1),
                t(mi(1), "f", -1, -1),
            ])
        }
    }
}

/// Replaces each product `ω_d · Y_l^m(ω)` (complex `Y`, same direction variable) by the
/// recursion. A conjugated `Y` uses `ω_d conj(Y) = conj(ω_d Y)`.
pub fn apply_recursion(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut |n| match n {
        Expr::Mul(fs) => rewrite_product(fs),
        other => other,
    })
}

fn rewrite_product(mut fs: Vec<Expr>) -> Expr {
    let found = fs.iter().enumerate().find_map(|(i, f)| match f {
        Expr::DirComp(v, axis) => fs.iter().enumerate().find_map(|(j, g)| match g {
            Expr::Sh {
                kind: ShKind::Complex,
                dir,
                ..
            } if dir == v => Some((i, j, *axis)),
            _ => None,
        }),
        _ => None,
    });
    let Some((i, j, axis)) = found else {
        return Expr::Mul(fs);
    };
    let Expr::Sh {
        l, m, dir, conj, ..
    } = fs[j].clone()
    else {
        unreachable!("index j is a complex Sh")
    };
    let mut r = recursion(axis, &l, &m, dir);
    if conj {
        r = Expr::Conj(Box::new(r));
    }
    let (hi, lo) = (i.max(j), i.min(j));
    fs.remove(hi);
    fs.remove(lo);
    fs.insert(lo, r);
    Expr::Mul(fs)
}

/// The closed form of a recursion coefficient (docs/design.md §2.1) for index expressions.
pub fn coefficient_definition(name: &str, l: &Expr, m: &Expr) -> Option<Expr> {
    let lin = |a: i64, b: i64, k: i64| {
        // a·l + b·m + k
        Expr::Add(vec![
            Expr::Mul(vec![Expr::Int(a), l.clone()]),
            Expr::Mul(vec![Expr::Int(b), m.clone()]),
            Expr::Int(k),
        ])
    };
    let two_l = |k: i64| Expr::Add(vec![Expr::Mul(vec![Expr::Int(2), l.clone()]), Expr::Int(k)]);
    let frac = |n1: Expr, n2: Expr, d1: Expr, d2: Expr| {
        Expr::Mul(vec![n1, n2, d1.recip(), d2.recip()]).sqrt()
    };
    Some(match name {
        "a" => frac(lin(1, -1, 1), lin(1, 1, 1), two_l(3), two_l(1)),
        "b" => frac(lin(1, -1, 0), lin(1, 1, 0), two_l(1), two_l(-1)),
        "c" => frac(lin(1, 1, 1), lin(1, 1, 2), two_l(3), two_l(1)),
        "d" => frac(lin(1, -1, 0), lin(1, -1, -1), two_l(1), two_l(-1)),
        "e" => frac(lin(1, -1, 1), lin(1, -1, 2), two_l(3), two_l(1)),
        "f" => frac(lin(1, 1, 0), lin(1, 1, -1), two_l(1), two_l(-1)),
        _ => return None,
    })
}

/// Replaces the named coefficients `a…f` by their closed forms.
pub fn define_coefficients(e: &Expr) -> Expr {
    replace(e, &|n| match n {
        Expr::Func(name, args) if args.len() == 2 => {
            coefficient_definition(name, &args[0], &args[1])
        }
        _ => None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::passes::fold::fold;

    #[test]
    fn recursion_replaces_direction_times_complex_sh() {
        let y = Expr::sh(ShKind::Complex, Expr::Int(1), Expr::Int(0), DirVar::Omega);
        let e = Expr::Mul(vec![Expr::DirComp(DirVar::Omega, Axis::Z), y]);
        let r = fold(&define_coefficients(&apply_recursion(&e)));
        // ω_z Y_1^0 = a_{1,0} Y_2^0 + b_{1,0} Y_0^0 = √(4/15) Y_2^0 + √(1/3) Y_0^0
        let Expr::Add(ts) = r else {
            panic!("sum expected")
        };
        assert_eq!(ts.len(), 2);
        let c0 = ts[0].clone();
        let Expr::Mul(f) = c0 else { panic!() };
        assert!((f[0].as_number().unwrap().to_f64() - (4.0f64 / 15.0).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn real_sh_or_other_direction_is_unchanged() {
        let e = Expr::Mul(vec![
            Expr::DirComp(DirVar::Omega, Axis::X),
            Expr::sh(ShKind::Real, Expr::Int(1), Expr::Int(0), DirVar::Omega),
            Expr::sh(
                ShKind::Complex,
                Expr::Int(1),
                Expr::Int(0),
                DirVar::OmegaPrime,
            ),
        ]);
        assert_eq!(apply_recursion(&e), e);
    }
}
