//! Rewrite passes over [`Expr`] trees, one concept per module.
//!
//! Every pass is a pure function `&Expr -> Expr`; passes that need to know index signs
//! take [`Assumptions`](crate::index::Assumptions). [`normalize`] runs the structural
//! passes (fold, expand, split, pull) to a fixed point.

pub mod collect;
pub mod delta;
pub mod expand;
pub mod fold;
pub mod funk_hecke;
pub mod orthonormality;
pub mod pull;
pub mod sh_convert;
pub mod sh_recursion;
pub mod split;
pub mod subst;

use crate::expr::Expr;

/// Fold, expand, split over sums/integrals/derivatives and pull constant factors out,
/// repeated until nothing changes (at most `64` rounds).
///
/// "Nothing changes" is detected with a structural hash instead of a copy of the tree;
/// a hash collision could only stop the rounds early (leaving a less simplified tree),
/// never change the value of the expression.
pub fn normalize(e: &Expr) -> Expr {
    use std::hash::{Hash, Hasher};
    let hash = |e: &Expr| {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        e.hash(&mut h);
        h.finish()
    };
    let mut cur = fold::fold(e);
    let mut h = hash(&cur);
    for _ in 0..64 {
        cur = fold::fold_owned(pull::pull_owned(split::split_owned(expand::expand_owned(
            cur,
        ))));
        let h2 = hash(&cur);
        if h2 == h {
            break;
        }
        h = h2;
    }
    cur
}
