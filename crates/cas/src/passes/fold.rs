//! Constant folding and canonical ordering.
//!
//! * flattens nested `Add`/`Mul`, drops neutral elements, multiplies exact numbers,
//!   reduces powers of the imaginary unit (`i·i = −1`) and of `−1` (`(−1)^{2m} = 1`);
//! * brings index arithmetic into canonical linear form (`l − (−m) + 1 → l + m + 1`);
//! * evaluates numeric powers exactly (`(3/4)^{1/2} = √3/2`), Kronecker deltas of equal or
//!   of distinct constant arguments, and pushes complex conjugation down to the leaves
//!   (real nodes are their own conjugate, `conj(i) = −i`, `conj(Y_l^m)` flips the flag).
//!
//! Factors of a product are sorted by the derived order of [`Expr`] (numbers first, then
//! `i`, fields, coefficients, derivatives), which is the canonical term shape the
//! discretizer relies on. Terms of a sum keep their order.

use crate::expr::{Expr, ShKind};
use crate::index::Linear;
use crate::number::Surd;
use num_rational::Rational64;

/// Folds constants everywhere in `e` (bottom-up, one sweep; idempotent on its output).
pub fn fold(e: &Expr) -> Expr {
    e.rewrite_bottom_up(&mut fold_node)
}

/// [`fold`] on an owned tree (no copy).
pub fn fold_owned(e: Expr) -> Expr {
    e.rewrite_owned(&mut fold_node)
}

/// Cheap structural test for index arithmetic (what [`Linear::from_expr`] accepts, up to
/// products of two non-constant forms, which it rejects).
fn is_index_like(e: &Expr) -> bool {
    match e {
        Expr::Int(_) | Expr::Index(_) => true,
        Expr::Add(ts) => ts.iter().all(is_index_like),
        Expr::Mul(fs) => {
            fs.iter().all(|f| {
                matches!(f, Expr::Int(_))
                    || f.as_number().and_then(|s| s.as_integer()).is_some()
                    || is_index_like(f)
            }) && fs
                .iter()
                .filter(|f| !matches!(f, Expr::Int(_) | Expr::Num(_)))
                .count()
                <= 1
                && Linear::from_expr(e).is_some()
        }
        _ => false,
    }
}

/// The folding rule at one node (children already folded).
pub(crate) fn fold_node(e: Expr) -> Expr {
    match e {
        Expr::Add(terms) => fold_add(terms),
        Expr::Mul(factors) => fold_mul(factors),
        Expr::Pow(b, x) => fold_pow(*b, *x),
        Expr::Conj(a) => conj(*a),
        Expr::Delta(a, b) => fold_delta(*a, *b),
        other => other,
    }
}

#[expect(
    clippy::expect_used,
    reason = "every term passed is_index_like, which is what Linear::from_expr accepts; the radicands compared equal before add_like; the pop is under len() == 1"
)]
fn fold_add(terms: Vec<Expr>) -> Expr {
    let mut flat = Vec::new();
    for t in terms {
        match t {
            Expr::Add(inner) => flat.extend(inner),
            t => flat.push(t),
        }
    }
    // Pure index arithmetic: canonical linear form.
    if flat.iter().all(is_index_like) {
        let lin = Linear::from_expr(&Expr::Add(flat)).expect("all terms are linear");
        return lin.to_expr();
    }
    // Otherwise add up the exact numbers (like radicands merge), keep the rest in order.
    let mut nums: Vec<Surd> = Vec::new();
    let mut rest = Vec::new();
    for t in flat {
        match t.as_number() {
            Some(s) => {
                if s.is_zero() {
                    continue;
                }
                match nums.iter_mut().find(|n| n.radicand == s.radicand) {
                    Some(n) => *n = n.add_like(&s).expect("same radicand"),
                    None => nums.push(s),
                }
            }
            None => rest.push(t),
        }
    }
    rest.extend(nums.into_iter().filter(|n| !n.is_zero()).map(Expr::Num));
    match rest.len() {
        0 => Expr::Num(Surd::ZERO),
        1 => rest.pop().expect("one term"),
        _ => Expr::Add(rest),
    }
}

#[expect(
    clippy::expect_used,
    reason = "fold_pow of (−1)^k returns either a Pow or the number ±1 (as_number succeeds), and the last pop is under rest.len() == 1"
)]
fn fold_mul(factors: Vec<Expr>) -> Expr {
    let mut flat = Vec::new();
    for f in factors {
        match f {
            Expr::Mul(inner) => flat.extend(inner),
            f => flat.push(f),
        }
    }
    if flat.iter().any(|f| f.is_zero()) {
        // Keep index arithmetic integral.
        return if flat.iter().all(is_index_like) {
            Expr::Int(0)
        } else {
            Expr::Num(Surd::ZERO)
        };
    }
    let index_only = flat.iter().all(is_index_like);
    if index_only {
        if let Some(lin) = Linear::from_expr(&Expr::Mul(flat.clone())) {
            return lin.to_expr();
        }
    }
    let mut num = Surd::ONE;
    let mut i_count = 0u32;
    let mut minus_one_exp: Option<Expr> = None;
    let mut rest = Vec::new();
    for f in flat {
        if let Some(s) = f.as_number() {
            num = num.mul(&s);
            continue;
        }
        match f {
            Expr::I => i_count += 1,
            Expr::Pow(b, x) if b.as_number() == Some(Surd::from_int(-1)) => {
                minus_one_exp = Some(match minus_one_exp {
                    None => *x,
                    Some(prev) => fold_add(vec![prev, *x]),
                });
            }
            f => rest.push(f),
        }
    }
    if let Some(x) = minus_one_exp {
        match fold_pow(Expr::Num(Surd::from_int(-1)), x) {
            p @ Expr::Pow(..) => rest.push(p),
            other => num = num.mul(&other.as_number().expect("(−1)^k folds to ±1")),
        }
    }
    match i_count % 4 {
        2 => num = num.neg(),
        3 => {
            num = num.neg();
            rest.push(Expr::I);
        }
        1 => rest.push(Expr::I),
        _ => {}
    }
    if num.is_zero() {
        return Expr::Num(Surd::ZERO);
    }
    rest.sort();
    if !num.is_one() || rest.is_empty() {
        let n = match num.as_integer() {
            Some(k) if index_only => Expr::Int(k),
            _ => Expr::Num(num),
        };
        rest.insert(0, n);
    }
    if rest.len() == 1 {
        rest.pop().expect("one factor")
    } else {
        Expr::Mul(rest)
    }
}

#[expect(
    clippy::expect_used,
    reason = "Expr::index(n) is linear by definition of Linear::from_expr"
)]
fn fold_pow(b: Expr, x: Expr) -> Expr {
    if x.is_one() {
        return b;
    }
    if x.is_zero() {
        return Expr::Num(Surd::ONE);
    }
    // (−1)^k for integer k (concrete or a linear form in indices).
    if b.as_number() == Some(Surd::from_int(-1)) {
        if let Some(lin) = Linear::from_expr(&x) {
            let mut red = Linear::constant(lin.constant.rem_euclid(2));
            for (n, k) in &lin.coeffs {
                red = red.add(
                    &Linear::from_expr(&Expr::index(n))
                        .expect("index")
                        .scale(k.rem_euclid(2)),
                );
            }
            return match red.as_constant() {
                Some(0) => Expr::Num(Surd::ONE),
                Some(_) => Expr::Num(Surd::from_int(-1)),
                None => Expr::Pow(
                    Box::new(Expr::Num(Surd::from_int(-1))),
                    Box::new(red.to_expr()),
                ),
            };
        }
    }
    if b == Expr::I {
        if let Some(k) = x.as_number().and_then(|s| s.as_integer()) {
            let factors = vec![Expr::I; k.rem_euclid(4) as usize];
            return fold_mul(factors);
        }
    }
    if let (Some(base), Some(ex)) = (b.as_number(), x.as_number()) {
        if ex.is_rational() {
            let r: Rational64 = ex.coeff;
            let (p, q) = (*r.numer(), *r.denom());
            let root = match q {
                1 => Some(base),
                2 => base.sqrt(),
                _ => None,
            };
            if let Some(v) = root.and_then(|rt| rt.powi(p)) {
                return Expr::Num(v);
            }
        }
    }
    Expr::Pow(Box::new(b), Box::new(x))
}

#[expect(
    clippy::expect_used,
    reason = "guarded by diff.coeffs.len() == 1 on the line before"
)]
fn fold_delta(a: Expr, b: Expr) -> Expr {
    if a == b {
        return Expr::Num(Surd::ONE);
    }
    if let (Some(la), Some(lb)) = (Linear::from_expr(&a), Linear::from_expr(&b)) {
        let diff = la.add(&lb.scale(-1));
        match diff.as_constant() {
            Some(0) => return Expr::Num(Surd::ONE),
            Some(_) => return Expr::Num(Surd::ZERO),
            None => {}
        }
        // δ_{m−1,0} → δ_{m,1}: one index with coefficient ±1 against a constant.
        if diff.coeffs.len() == 1 {
            let (name, k) = diff.coeffs.iter().next().expect("one index");
            if k.abs() == 1 {
                return Expr::Delta(
                    Box::new(Expr::Index(name.clone())),
                    Box::new(Expr::Int(-diff.constant * k)),
                );
            }
        }
    }
    let (a, b) = if b < a { (b, a) } else { (a, b) };
    Expr::Delta(Box::new(a), Box::new(b))
}

/// Complex conjugate of an already folded expression, pushed to the leaves.
pub fn conj(e: Expr) -> Expr {
    match e {
        Expr::I => Expr::Mul(vec![Expr::Num(Surd::from_int(-1)), Expr::I]),
        Expr::Conj(a) => *a,
        Expr::Add(v) => fold_add(v.into_iter().map(conj).collect()),
        Expr::Mul(v) => fold_mul(v.into_iter().map(conj).collect()),
        Expr::Sh {
            kind: ShKind::Complex,
            l,
            m,
            dir,
            conj: c,
        } => Expr::Sh {
            kind: ShKind::Complex,
            l,
            m,
            dir,
            conj: !c,
        },
        // Real by construction: numbers, indices, deltas, real basis functions, fields,
        // real coefficients, direction components, powers of real numbers.
        e @ (Expr::Num(_)
        | Expr::Int(_)
        | Expr::Index(_)
        | Expr::Delta(..)
        | Expr::Field(_)
        | Expr::DirComp(..)
        | Expr::Sh {
            kind: ShKind::Real, ..
        }
        | Expr::Coeff {
            kind: ShKind::Real, ..
        }) => e,
        Expr::Pow(b, x) if !b.any(&|n| matches!(n, Expr::I | Expr::Sh { .. })) => Expr::Pow(b, x),
        Expr::Deriv(a, body) => Expr::Deriv(a, Box::new(conj(*body))),
        other => Expr::Conj(Box::new(other)),
    }
}

/// True if `e` is the exact number `v`.
pub fn is_number(e: &Expr, v: Surd) -> bool {
    e.as_number() == Some(v)
}

/// Real and imaginary parts of a folded numeric coefficient `Num`, `i`, `Num·i` or sums of
/// them; `None` for anything else.
pub fn complex_parts(e: &Expr) -> Option<(Vec<Surd>, Vec<Surd>)> {
    match e {
        Expr::I => Some((vec![], vec![Surd::ONE])),
        Expr::Mul(fs) if fs.len() == 2 && fs[1] == Expr::I => {
            Some((vec![], vec![fs[0].as_number()?]))
        }
        Expr::Add(ts) => {
            let mut re = Vec::new();
            let mut im = Vec::new();
            for t in ts {
                let (r, i) = complex_parts(t)?;
                re.extend(r);
                im.extend(i);
            }
            Some((re, im))
        }
        e => Some((vec![e.as_number()?], vec![])),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::expr::DirVar;

    fn n(p: i64, q: i64) -> Expr {
        Expr::rational(p, q)
    }

    #[test]
    fn numbers_fold_exactly() {
        // √(1/2)·√2 = 1
        let e = Expr::Mul(vec![n(1, 2).sqrt(), n(2, 1).sqrt()]);
        assert_eq!(fold(&e), n(1, 1));
        // √8 = 2√2
        let e = n(8, 1).sqrt();
        assert_eq!(
            fold(&e),
            Expr::Num(Surd::sqrt_of(Rational64::from_integer(8)).unwrap())
        );
        // (3·5/(7·9))^{1/2} with index arithmetic inside
        let e = Expr::Mul(vec![
            Expr::Add(vec![Expr::Int(1), Expr::Int(2)]),
            Expr::Int(5),
            Expr::Pow(Box::new(Expr::Int(63)), Box::new(n(-1, 1))),
        ])
        .sqrt();
        let v = fold(&e).as_number().unwrap().to_f64();
        assert!((v - (15.0f64 / 63.0).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn imaginary_unit_and_sign_powers() {
        let e = Expr::Mul(vec![Expr::I, n(1, 2), Expr::I]);
        assert_eq!(fold(&e), n(-1, 2));
        let m = Expr::index("m");
        let e = Expr::Mul(vec![
            Expr::int(-1).pow(m.clone()),
            Expr::int(-1).pow(m.clone()),
        ]);
        assert_eq!(fold(&e), n(1, 1));
        let e = Expr::int(-1).pow(Expr::Add(vec![
            Expr::Mul(vec![Expr::Int(3), m.clone()]),
            Expr::Int(2),
        ]));
        assert_eq!(fold(&e), Expr::int(-1).pow(m));
        assert_eq!(
            fold(&Expr::Conj(Box::new(Expr::I))),
            Expr::Mul(vec![n(-1, 1), Expr::I])
        );
    }

    #[test]
    fn deltas_and_indices() {
        let l = Expr::index("l");
        let lp1 = Expr::Add(vec![l.clone(), Expr::Int(1)]);
        assert_eq!(fold(&Expr::delta(lp1.clone(), lp1.clone())), n(1, 1));
        assert_eq!(fold(&Expr::delta(lp1.clone(), l.clone())), n(0, 1));
        assert_eq!(fold(&Expr::delta(Expr::Int(2), Expr::Int(3))), n(0, 1));
        // δ_{m−1,0} = δ_{m,1}
        let m = Expr::index("m");
        let e = Expr::delta(Expr::Add(vec![m.clone(), Expr::Int(-1)]), Expr::Int(0));
        assert_eq!(fold(&e), Expr::delta(m, Expr::Int(1)));
        // −(−l − 1) = l + 1
        let e = Expr::Mul(vec![
            Expr::Int(-1),
            Expr::Add(vec![
                Expr::Mul(vec![Expr::Int(-1), l.clone()]),
                Expr::Int(-1),
            ]),
        ]);
        assert_eq!(fold(&e), lp1);
    }

    #[test]
    fn folded_tree_is_left_unchanged() {
        // A tree with nothing to fold must come back identical.
        let e = Expr::Mul(vec![
            n(1, 3),
            Expr::field(crate::expr::FieldName::SigmaT),
            Expr::sh(
                ShKind::Real,
                Expr::index("l"),
                Expr::index("m"),
                DirVar::Omega,
            ),
        ]);
        assert_eq!(fold(&e), e);
        assert_eq!(fold(&fold(&e)), fold(&e));
    }
}
