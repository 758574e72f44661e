//! Placement of the unknowns on staggered grids (docs/design.md §3).
//!
//! The staggered placement is *derived* from the coupling structure of the equations: the
//! equation of unknown r is located at r's position; a term in it that reaches unknown q
//! through an odd number of ∂_d puts q half a cell away from r along d, an even number
//! (including none) on the same grid along d. Starting from L_0^0 at the cell centre, a
//! breadth-first walk over these constraints fixes every shift and checks that no
//! constraint is violated. [`rule_shift`] is the closed-form rule of docs/design.md §3 that the
//! derived placement is tested against.

use std::collections::VecDeque;

use cas::Expr;

use crate::pde::{as_unknown, PdeSystem};
use pn_stencil::{Dim, MomentPlacement, Staggering, StencilError};

/// The shift of moment (l, m) by the rule of docs/design.md §3: shifted along axis d iff the
/// real basis function is odd under x_d → −x_d; x: (m>0, m odd) or (m<0, m even);
/// y: m<0; z: l+m odd. In 2D the z shift is always 0.
pub fn rule_shift(l: i64, m: i64, dim: Dim) -> [u8; 3] {
    let x = (m > 0 && m % 2 != 0) || (m < 0 && m % 2 == 0);
    let y = m < 0;
    let z = dim == Dim::Three && (l + m).rem_euclid(2) != 0;
    [x as u8, y as u8, z as u8]
}

/// Couplings of one expression: for every unknown reached, the parity of the number of
/// derivatives along each axis on the path to it.
pub fn couplings(e: &Expr, out: &mut Vec<((i64, i64), [u8; 3])>) {
    fn walk(e: &Expr, parity: [u8; 3], out: &mut Vec<((i64, i64), [u8; 3])>) {
        if let Some(lm) = as_unknown(e) {
            out.push((lm, parity));
            return;
        }
        match e {
            Expr::Deriv(a, c) => {
                let mut p = parity;
                p[a.index()] ^= 1;
                walk(c, p, out);
            }
            Expr::Add(ts) | Expr::Mul(ts) | Expr::Func(_, ts) => {
                ts.iter().for_each(|t| walk(t, parity, out))
            }
            Expr::Pow(b, x) => {
                walk(b, parity, out);
                walk(x, parity, out);
            }
            Expr::Conj(c) => walk(c, parity, out),
            Expr::Sum { body, .. } | Expr::Integral { body, .. } => walk(body, parity, out),
            _ => {}
        }
    }
    walk(e, [0; 3], out)
}

/// Every unknown at the cell centre.
pub fn collocated(sys: &PdeSystem) -> Vec<MomentPlacement> {
    sys.unknowns
        .iter()
        .map(|&(l, m)| MomentPlacement {
            l: l as i32,
            m: m as i32,
            shift: [0; 3],
        })
        .collect()
}

/// Derives the staggered placement from the coupling structure (see module docs). The
/// first unknown (L_0^0 for P_N and diffusion) of every connected component sits at the
/// cell centre. Errors if a constraint is violated or an equation references an unknown
/// that is not part of the system.
#[expect(
    clippy::expect_used,
    reason = "the breadth-first search sets a shift before it queues an unknown, and the outer loop starts a search from every unknown without one, so every unknown has one"
)]
pub fn derive_staggered(sys: &PdeSystem) -> Result<Vec<MomentPlacement>, StencilError> {
    let n = sys.unknowns.len();
    let index = |lm: (i64, i64)| sys.unknowns.iter().position(|&u| u == lm);
    let naxes = sys.dim.axes();
    // Edges: (row, q, parity).
    let mut adj: Vec<Vec<(usize, [u8; 3])>> = vec![Vec::new(); n];
    for eq in &sys.equations {
        let r = index((eq.l, eq.m)).ok_or_else(|| {
            StencilError::Malformed(format!(
                "equation located at L_{}^{} which is not an unknown",
                eq.l, eq.m
            ))
        })?;
        let mut cs = Vec::new();
        couplings(&eq.lhs, &mut cs);
        couplings(&eq.rhs, &mut cs);
        for ((l, m), mut p) in cs {
            let q = index((l, m)).ok_or_else(|| {
                StencilError::Malformed(format!(
                    "equation of L_{}^{} references L_{l}^{m}, which is not an unknown",
                    eq.l, eq.m
                ))
            })?;
            for (d, pd) in p.iter_mut().enumerate() {
                if d >= naxes {
                    *pd = 0;
                }
            }
            adj[r].push((q, p));
            adj[q].push((r, p));
        }
    }
    let mut shift: Vec<Option<[u8; 3]>> = vec![None; n];
    for start in 0..n {
        if shift[start].is_some() {
            continue;
        }
        shift[start] = Some([0; 3]);
        let mut queue = VecDeque::from([start]);
        while let Some(r) = queue.pop_front() {
            let sr = shift[r].expect("queued unknowns have a shift");
            for &(q, p) in &adj[r] {
                let want = [sr[0] ^ p[0], sr[1] ^ p[1], sr[2] ^ p[2]];
                match shift[q] {
                    None => {
                        shift[q] = Some(want);
                        queue.push_back(q);
                    }
                    Some(s) if s != want => {
                        let (lr, mr) = sys.unknowns[r];
                        let (lq, mq) = sys.unknowns[q];
                        return Err(StencilError::InconsistentPlacement(format!(
                            "L_{lq}^{mq} must be shifted by {want:?} (coupling with L_{lr}^{mr}) \
                             but another coupling placed it at {s:?}"
                        )));
                    }
                    Some(_) => {}
                }
            }
        }
    }
    Ok(sys
        .unknowns
        .iter()
        .zip(shift)
        .map(|(&(l, m), s)| MomentPlacement {
            l: l as i32,
            m: m as i32,
            shift: s.expect("every unknown was visited"),
        })
        .collect())
}

/// The placement of `sys` for `layout`.
pub fn place(sys: &PdeSystem, layout: Staggering) -> Result<Vec<MomentPlacement>, StencilError> {
    match layout {
        Staggering::Staggered => derive_staggered(sys),
        Staggering::Collocated => Ok(collocated(sys)),
    }
}
