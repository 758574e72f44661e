//! Galerkin coarse operators `A_c = Pᵀ A P` for the piecewise-constant aggregation `P`.
//!
//! With `P` the aggregation of [`super::aggregate`], entry `(I, J)` of `Pᵀ A P` is the sum
//! of `A_ij` over `i ∈ I`, `j ∈ J`. For the finest level `A` is the even-parity Schur
//! complement `S = D_e − B C̃` (`C̃ = D_o⁻¹ C`, DESIGN.md §5), never formed:
//! `Pᵀ S P = Pᵀ D_e P − (Pᵀ B)(C̃ P)`: each coarse row merges its members' rows of `B`
//! (neighbouring cells share most odd neighbours) and adds the rows of `C̃` with columns
//! mapped to their aggregates, so `S` itself is never formed.

use super::aggregate::Aggregation;
use crate::solver::parity::split::Split;
use rayon::prelude::*;
use sprs::CsMat;

/// Row sums into a dense accumulator over the columns, remembering which were touched,
/// so that a row costs its number of contributions plus a sort of its distinct columns.
pub struct RowAccumulator {
    values: Vec<f64>,
    mark: Vec<bool>,
    touched: Vec<u32>,
}

impl RowAccumulator {
    fn new(n_cols: usize) -> Self {
        Self {
            values: vec![0.0; n_cols],
            mark: vec![false; n_cols],
            touched: Vec::new(),
        }
    }

    /// Adds `v` to column `j`.
    #[inline]
    pub fn add(&mut self, j: u32, v: f64) {
        let ju = j as usize;
        if !self.mark[ju] {
            self.mark[ju] = true;
            self.touched.push(j);
        }
        self.values[ju] += v;
    }

    /// Moves the row (sorted columns) into `cols`/`vals` and resets the accumulator.
    fn drain(&mut self, cols: &mut Vec<usize>, vals: &mut Vec<f64>) {
        self.touched.sort_unstable();
        for &j in &self.touched {
            let ju = j as usize;
            cols.push(ju);
            vals.push(self.values[ju]);
            self.values[ju] = 0.0;
            self.mark[ju] = false;
        }
        self.touched.clear();
    }
}

/// Builds a CSR matrix with `n_rows × n_cols` from a row generator: `row(i, acc)` adds
/// `(column, value)` contributions in any order; duplicates are summed, columns sorted.
/// Rows are split into a few large parallel tasks, each with one dense accumulator.
fn build_rows(
    n_rows: usize,
    n_cols: usize,
    row: impl Fn(usize, &mut RowAccumulator) + Sync,
) -> CsMat<f64> {
    let tasks = (4 * rayon::current_num_threads()).clamp(1, n_rows.max(1));
    let per = n_rows.div_ceil(tasks).max(1);
    let chunks: Vec<(Vec<usize>, Vec<usize>, Vec<f64>)> = (0..n_rows.div_ceil(per))
        .into_par_iter()
        .map(|c| {
            let (mut nnz, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
            let mut acc = RowAccumulator::new(n_cols);
            for i in c * per..((c + 1) * per).min(n_rows) {
                row(i, &mut acc);
                let start = cols.len();
                acc.drain(&mut cols, &mut vals);
                nnz.push(cols.len() - start);
            }
            (nnz, cols, vals)
        })
        .collect();
    let total: usize = chunks.iter().map(|c| c.1.len()).sum();
    let mut indptr = Vec::with_capacity(n_rows + 1);
    let (mut indices, mut data) = (Vec::with_capacity(total), Vec::with_capacity(total));
    indptr.push(0);
    let mut acc = 0usize;
    for (nnz, cols, vals) in chunks {
        for k in nnz {
            acc += k;
            indptr.push(acc);
        }
        indices.extend(cols);
        data.extend(vals);
    }
    CsMat::new((n_rows, n_cols), indptr, indices, data)
}

/// `Pᵀ A P` for a CSR matrix `a` (the coarse levels, or a scalar system such as CDA).
pub fn coarse_from_csr(a: &CsMat<f64>, ag: &Aggregation) -> CsMat<f64> {
    let nc = ag.coarse_len();
    let ap = a.indptr();
    let ap = ap.raw_storage();
    let (ai, av) = (a.indices(), a.data());
    build_rows(nc, nc, |ci, acc| {
        for &i in &ag.members[ag.ptr[ci]..ag.ptr[ci + 1]] {
            let i = i as usize;
            for p in ap[i]..ap[i + 1] {
                acc.add(ag.agg[ai[p]], av[p]);
            }
        }
    })
}

/// `Pᵀ S P` for the reduced operator of `split`, without forming `S`.
pub fn coarse_from_split(split: &Split, ag: &Aggregation) -> CsMat<f64> {
    let nc = ag.coarse_len();
    // C̃'s columns are mapped to aggregates on the fly: materialising C̃ P would hold
    // about as many entries as C̃ (2.6 GB at 80³ P_5) for a saving of a few adds.
    let c = &split.c_scaled;
    let cp = c.indptr();
    let cp = cp.raw_storage();
    let (ci, cv) = (c.indices(), c.data());
    let b = &split.b;
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
    use super::super::aggregate::{aggregate, Geometry};
    use super::*;
    use crate::solver::parity::reduced::form;
    use crate::solver::parity::split::split;

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
