//! The first Galerkin operator `Pᵀ S P` of the multigrid hierarchy for the reduced
//! operator `S = D_e − B C̃` (`C̃ = D_o⁻¹ C`, docs/design.md §5), from the parity blocks:
//! `Pᵀ S P = Pᵀ D_e P − (Pᵀ B)(C̃ P)`: each coarse row merges its members' rows of `B`
//! (neighbouring cells share most odd neighbours) and adds the rows of `C̃` with columns
//! mapped to their aggregates, so `S` itself is never formed.

use super::split::Split;
use crate::solver::multigrid::aggregate::Aggregation;
use crate::solver::multigrid::galerkin::build_rows;
use sprs::CsMat;

/// `Pᵀ S P` for the reduced operator of `split`, without forming `S`.
pub fn coarse_from_split(split: &Split, ag: &Aggregation) -> CsMat<f64> {
    let nc = ag.coarse_len();
    // C̃'s columns are mapped to aggregates on the fly: materialising C̃ P would hold
    // about as many entries as C̃ (2.6 GB at 80³ P_5) for a saving of a few adds.
    if let Some(st) = &split.stencil {
        return st.coarse(&split.d_e, &split.d_o, ag);
    }
    let (b, c) = split.blocks();
    let c = &*c;
    let cp = c.indptr();
    let cp = cp.raw_storage();
    let (ci, cv) = (c.indices(), c.data());
    let b = &*b;
    let bp = b.indptr();
    let bp = bp.raw_storage();
    let (bi, bv) = (b.indices(), b.data());
    build_rows(nc, nc, |row, acc| {
        // Row `row` of Pᵀ B (members' rows merged: neighbouring fine rows share most odd
        // neighbours, so merging first cuts the product's work), then times C̃ P.
        let mut pb: Vec<(usize, f64)> = Vec::new();
        for &i in &ag.members[ag.ptr[row]..ag.ptr[row + 1]] {
            let i = i as usize;
            acc.add(row as u32, split.d_e[i]);
            pb.extend((bp[i]..bp[i + 1]).map(|p| (bi[p] as usize, bv[p])));
        }
        pb.sort_unstable_by_key(|e| e.0);
        let mut q = 0;
        while q < pb.len() {
            let (k, mut v) = pb[q];
            q += 1;
            while q < pb.len() && pb[q].0 == k {
                v += pb[q].1;
                q += 1;
            }
            for t in cp[k]..cp[k + 1] {
                acc.add(ag.agg[ci[t] as usize], -v * cv[t]);
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::super::reduced::form;
    use super::super::split::split;
    use super::*;
    use crate::solver::multigrid::aggregate::{aggregate, Geometry};
    use crate::solver::multigrid::galerkin::coarse_from_csr;

    /// A 1D P_1-like staggered chain: centres (even) e0..e3, faces (odd) between them.
    fn chain() -> (CsMat<f64>, Vec<bool>) {
        let n_e = 4;
        let n = 2 * n_e - 1;
        let mut tri = sprs::TriMat::new((n, n));
        for i in 0..n {
            tri.add_triplet(
                i,
                i,
                if i % 2 == 0 {
                    0.5 + 0.1 * i as f64
                } else {
                    2.0
                },
            );
        }
        for k in (1..n).step_by(2) {
            tri.add_triplet(k - 1, k, 1.0);
            tri.add_triplet(k + 1, k, -1.0);
            tri.add_triplet(k, k - 1, -1.0);
            tri.add_triplet(k, k + 1, 1.0);
        }
        (tri.to_csr(), (0..n).map(|i| i % 2 == 0).collect())
    }

    #[test]
    fn split_route_equals_formed_triple_product() {
        let (a, mask) = chain();
        let sp = split(&a, &mask).unwrap();
        let geom = Geometry {
            class: vec![0; 4],
            coords: (0..4).map(|i| [i, 0, 0]).collect(),
        };
        let ag = aggregate(&geom);
        assert_eq!(ag.coarse_len(), 2);
        let via_split = coarse_from_split(&sp, &ag);
        let via_csr = coarse_from_csr(&form(&sp), &ag);
        // Dense Pᵀ S P by hand from the formed S.
        let s = form(&sp).to_dense();
        for ci in 0..2 {
            for cj in 0..2 {
                let mut want = 0.0;
                for i in 0..4 {
                    for j in 0..4 {
                        if i / 2 == ci && j / 2 == cj {
                            want += s[[i, j]];
                        }
                    }
                }
                let g1 = via_split.get(ci, cj).copied().unwrap_or(0.0);
                let g2 = via_csr.get(ci, cj).copied().unwrap_or(0.0);
                assert!((g1 - want).abs() < 1e-14 && (g2 - want).abs() < 1e-14);
            }
        }
    }
}
