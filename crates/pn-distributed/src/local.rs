//! One process's part of the parity-reduced system `S u_e = f` (docs/design.md §5):
//! its rows of `A = [[D_e, B], [C, D_o]]`, assembled for the unknowns its box owns, and the
//! ghost unknowns those rows reach.
//!
//! Applying `S x = D_e x − B (D_o⁻¹ C x)` takes two ghost exchanges: the kept values `x` that
//! the owned eliminated rows (`C̃ = D_o⁻¹ C`) reach, then the values `t = C̃ x` that the owned
//! kept rows (`B`) reach. Each row sums its entries in ascending storage order of the
//! columns — the order [`pn_runtime::assemble::assemble`] stores them in — so that a row's
//! value is the same, bit for bit, whichever process computes it and however the grid is
//! split.

use crate::numbering::Numbering;
use crate::partition::Decomposition;
use anyhow::Context;
use pn_runtime::assemble::{assemble_row_subset, RowSet};
use pn_runtime::problem::Problem;
use pn_runtime::solver::pn_layout::Retained;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Rows of a block in compressed form; columns index an extended local vector (owned
/// unknowns, then ghosts), kept in the storage order of the global columns.
#[derive(Clone, Debug, Default)]
pub struct LocalRows {
    indptr: Vec<usize>,
    cols: Vec<u32>,
    vals: Vec<f64>,
}

impl LocalRows {
    /// Stored entries.
    pub fn nnz(&self) -> usize {
        self.vals.len()
    }

    /// `y_i = Σ_j a_ij x_j` in stored order.
    fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let r = self.indptr[i]..self.indptr[i + 1];
        self.cols[r.clone()]
            .iter()
            .zip(&self.vals[r])
            .fold(0.0, |s, (&j, &v)| s + v * x[j as usize])
    }
}

/// The unknowns of one class a process owns and the ghosts its rows reach.
#[derive(Clone, Debug, Default)]
pub struct Part {
    /// Owned storage indices, ascending (the process's local order).
    pub owned: Vec<usize>,
    /// Ghost storage indices (owned elsewhere), ascending; local index `owned.len() + k`.
    pub ghosts: Vec<usize>,
}

impl Part {
    /// The extended local index of storage index `g` (owned or ghost).
    fn local(&self, g: usize) -> Option<usize> {
        match self.owned.binary_search(&g) {
            Ok(k) => Some(k),
            Err(_) => self
                .ghosts
                .binary_search(&g)
                .ok()
                .map(|k| self.owned.len() + k),
        }
    }

    /// Owned plus ghost unknowns.
    pub fn extended_len(&self) -> usize {
        self.owned.len() + self.ghosts.len()
    }
}

/// One process's rows of the reduced system (see the module documentation).
#[derive(Clone, Debug)]
pub struct LocalReduced {
    /// The process.
    pub rank: usize,
    /// Kept unknowns (the "even" class of the parity solvers).
    pub kept: Part,
    /// Eliminated unknowns.
    pub elim: Part,
    /// Diagonal of the owned kept rows.
    pub d_e: Vec<f64>,
    /// Diagonal of the owned eliminated rows.
    pub d_o: Vec<f64>,
    /// Right-hand side of the owned kept rows.
    pub b_e: Vec<f64>,
    /// Right-hand side of the owned eliminated rows.
    pub b_o: Vec<f64>,
    /// `B`: owned kept rows × eliminated columns (extended local).
    b: LocalRows,
    /// `C̃ = D_o⁻¹ C`: owned eliminated rows × kept columns (extended local).
    c: LocalRows,
    /// Stored entries of this process's rows of `A` (diagonals included).
    pub nnz_a: usize,
}

/// The moments the parity solvers keep on `layout` ([`Retained::for_layout`]).
pub fn kept_moments(layout: &Layout) -> Vec<bool> {
    let retained = Retained::for_layout(layout);
    layout
        .moments
        .iter()
        .map(|m| retained.keeps(m.l as usize))
        .collect()
}

/// An off-diagonal entry: local row, global column, value.
type Entry = (usize, usize, f64);

/// Splits assembled rows into their diagonal and the off-diagonal entries, checking that
/// every off-diagonal entry couples to the other class (docs/design.md §5).
fn split_rows(
    rows: &RowSet,
    owned: &[usize],
    other: &mut dyn FnMut(usize) -> bool,
) -> anyhow::Result<(Vec<f64>, Vec<Entry>)> {
    let mut diag = vec![0.0; owned.len()];
    let mut off = Vec::with_capacity(rows.cols.len());
    for (i, &g) in owned.iter().enumerate() {
        for k in rows.indptr[i]..rows.indptr[i + 1] {
            let (col, v) = (rows.cols[k], rows.vals[k]);
            if col == g {
                diag[i] = v;
            } else {
                anyhow::ensure!(
                    other(col),
                    "row {g} couples to unknown {col} of its own parity off the diagonal \
                     (value {v:e}); the distributed solve needs the parity structure \
                     (docs/design.md §5)"
                );
                off.push((i, col, v));
            }
        }
    }
    Ok((diag, off))
}

/// Compresses `(row, global column, value)` triples (rows ascending, columns ascending
/// within a row) with the columns mapped to `part`'s extended local indices.
fn compress(n_rows: usize, entries: &[Entry], part: &Part) -> LocalRows {
    let mut indptr = vec![0; n_rows + 1];
    for &(i, _, _) in entries {
        indptr[i + 1] += 1;
    }
    for i in 0..n_rows {
        indptr[i + 1] += indptr[i];
    }
    let cols = entries
        .iter()
        .map(|&(_, g, _)| part.local(g).map_or(u32::MAX, |l| l as u32))
        .collect();
    let vals = entries.iter().map(|e| e.2).collect();
    LocalRows { indptr, cols, vals }
}

/// The sorted, deduplicated columns of `entries` that `owned` does not contain.
fn ghosts_of(entries: &[Entry], owned: &[usize]) -> Vec<usize> {
    let mut g: Vec<usize> = entries
        .iter()
        .map(|e| e.1)
        .filter(|c| owned.binary_search(c).is_err())
        .collect();
    g.par_sort_unstable();
    g.dedup();
    g
}

impl LocalReduced {
    /// Assembles `rank`'s rows of `kernel` for `problem` on `layout` split by `dec`.
    /// Fails like the serial parity split: an eliminated row with a zero diagonal (σ_t = 0),
    /// or a coupling between unknowns of one class.
    pub fn build(
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        dec: &Decomposition,
        rank: usize,
    ) -> anyhow::Result<Self> {
        let keep = kept_moments(layout);
        let kept_num = Numbering::new(layout, dec, keep.clone());
        let elim_num = Numbering::new(layout, dec, keep.iter().map(|k| !k).collect());
        let kept_owned = kept_num.owned(layout, rank);
        let elim_owned = elim_num.owned(layout, rank);
        let is_kept = |g: usize| keep[layout.locate(g).0];

        let rows_e = assemble_row_subset(problem, kernel, layout, &kept_owned)
            .context("assembling the kept rows")?;
        let rows_o = assemble_row_subset(problem, kernel, layout, &elim_owned)
            .context("assembling the eliminated rows")?;
        let nnz_a = rows_e.vals.len() + rows_o.vals.len();
        let (d_e, b_entries) = split_rows(&rows_e, &kept_owned, &mut |g| !is_kept(g))?;
        let (d_o, mut c_entries) = split_rows(&rows_o, &elim_owned, &mut |g| is_kept(g))?;
        if let Some((i, &v)) = d_o
            .iter()
            .enumerate()
            .find(|(_, v)| **v == 0.0 || !v.is_finite())
        {
            anyhow::bail!(
                "row {} of the eliminated parity has diagonal {v:e}; parity elimination divides \
                 by it (σ_t must be positive everywhere, docs/design.md §5)",
                elim_owned[i]
            );
        }
        for e in &mut c_entries {
            e.2 /= d_o[e.0];
        }
        let kept = Part {
            ghosts: ghosts_of(&c_entries, &kept_owned),
            owned: kept_owned,
        };
        let elim = Part {
            ghosts: ghosts_of(&b_entries, &elim_owned),
            owned: elim_owned,
        };
        let b = compress(kept.owned.len(), &b_entries, &elim);
        let c = compress(elim.owned.len(), &c_entries, &kept);
        Ok(Self {
            rank,
            kept,
            elim,
            d_e,
            d_o,
            b_e: rows_e.rhs,
            b_o: rows_o.rhs,
            b,
            c,
            nnz_a,
        })
    }

    /// `t = C̃ x` on the owned eliminated rows; `x_ext` holds the owned kept values, then
    /// the kept ghosts.
    pub fn apply_c(&self, x_ext: &[f64], t: &mut [f64]) {
        t.par_iter_mut()
            .enumerate()
            .for_each(|(i, t)| *t = self.c.row_dot(i, x_ext));
    }

    /// `y = D_e x − B t` on the owned kept rows; `t_ext` holds the owned values of `t`,
    /// then the eliminated ghosts.
    pub fn apply_b(&self, x: &[f64], t_ext: &[f64], y: &mut [f64]) {
        y.par_iter_mut()
            .enumerate()
            .for_each(|(i, y)| *y = self.d_e[i] * x[i] - self.b.row_dot(i, t_ext));
    }

    /// `D_o⁻¹ b_o` on the owned eliminated rows: the `t` whose `B`-product gives the reduced
    /// right-hand side `f = b_e − B D_o⁻¹ b_o`.
    pub fn scaled_odd_rhs(&self) -> Vec<f64> {
        self.b_o.iter().zip(&self.d_o).map(|(b, d)| b / d).collect()
    }

    /// `f = b_e − B s` on the owned kept rows, with `s_ext` the owned and ghost values of
    /// [`Self::scaled_odd_rhs`].
    pub fn reduced_rhs(&self, s_ext: &[f64]) -> Vec<f64> {
        (0..self.b_e.len())
            .into_par_iter()
            .map(|i| self.b_e[i] - self.b.row_dot(i, s_ext))
            .collect()
    }

    /// The owned eliminated unknowns from the kept ones: `u_o = D_o⁻¹ b_o − C̃ u_e`
    /// (`u_ext`: owned kept values, then the kept ghosts).
    pub fn recover_odd(&self, u_ext: &[f64]) -> Vec<f64> {
        (0..self.b_o.len())
            .into_par_iter()
            .map(|i| self.b_o[i] / self.d_o[i] - self.c.row_dot(i, u_ext))
            .collect()
    }

    /// Squares of the residual `b − A u` of the owned rows: kept rows
    /// `b_e − D_e u_e − B u_o`, eliminated rows `b_o − D_o (C̃ u_e + u_o)`; `ue_ext` and
    /// `uo_ext` are the owned values and the ghosts of each class. Returns
    /// `(‖r‖², ‖b‖²)` of this process.
    pub fn residual_squares(&self, ue_ext: &[f64], uo_ext: &[f64]) -> (f64, f64) {
        let n_e = self.b_e.len();
        let r_e: f64 = (0..n_e)
            .map(|i| {
                let r = self.b_e[i] - self.d_e[i] * ue_ext[i] - self.b.row_dot(i, uo_ext);
                r * r
            })
            .sum();
        let r_o: f64 = (0..self.b_o.len())
            .map(|i| {
                let r = self.b_o[i] - self.d_o[i] * (self.c.row_dot(i, ue_ext) + uo_ext[i]);
                r * r
            })
            .sum();
        let b2: f64 = self.b_e.iter().chain(&self.b_o).map(|v| v * v).sum();
        (r_e + r_o, b2)
    }

    /// The rows of `S = D_e − B C̃` this process owns, columns as storage indices ascending:
    /// `c_ghost` holds the `C̃` rows of the eliminated ghosts (from
    /// [`Self::ghost_c_rows`]). For an algebraic multigrid preconditioner.
    pub fn formed_rows(&self, c_ghost: &RowSet) -> Vec<Vec<(usize, f64)>> {
        let n_o = self.elim.owned.len();
        (0..self.kept.owned.len())
            .into_par_iter()
            .map(|i| {
                let mut row: BTreeMap<usize, f64> = BTreeMap::new();
                row.insert(self.kept.owned[i], self.d_e[i]);
                for k in self.b.indptr[i]..self.b.indptr[i + 1] {
                    let (slot, bw) = (self.b.cols[k] as usize, self.b.vals[k]);
                    if slot < n_o {
                        for m in self.c.indptr[slot]..self.c.indptr[slot + 1] {
                            let g = self.kept_global(self.c.cols[m] as usize);
                            *row.entry(g).or_insert(0.0) -= bw * self.c.vals[m];
                        }
                    } else {
                        let r = slot - n_o;
                        for m in c_ghost.indptr[r]..c_ghost.indptr[r + 1] {
                            *row.entry(c_ghost.cols[m]).or_insert(0.0) -= bw * c_ghost.vals[m];
                        }
                    }
                }
                row.into_iter().collect()
            })
            .collect()
    }

    /// The storage index of extended local kept index `l`.
    fn kept_global(&self, l: usize) -> usize {
        let n = self.kept.owned.len();
        if l < n {
            self.kept.owned[l]
        } else {
            self.kept.ghosts[l - n]
        }
    }

    /// The `C̃` rows of the eliminated ghosts (columns: kept storage indices), assembled
    /// here (the rows of the neighbours' boxes next to this one).
    pub fn ghost_c_rows(
        &self,
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
    ) -> anyhow::Result<RowSet> {
        let mut rows = assemble_row_subset(problem, kernel, layout, &self.elim.ghosts)?;
        let mut out = RowSet {
            indptr: vec![0],
            ..RowSet::default()
        };
        for (i, &g) in self.elim.ghosts.iter().enumerate() {
            let r = rows.indptr[i]..rows.indptr[i + 1];
            let d = r
                .clone()
                .find(|&k| rows.cols[k] == g)
                .map_or(0.0, |k| rows.vals[k]);
            anyhow::ensure!(
                d != 0.0 && d.is_finite(),
                "row {g} of the eliminated parity has diagonal {d:e} (σ_t must be positive)"
            );
            for k in r {
                if rows.cols[k] != g {
                    out.cols.push(rows.cols[k]);
                    out.vals.push(rows.vals[k] / d);
                }
            }
            out.indptr.push(out.cols.len());
        }
        rows.rhs.clear();
        Ok(out)
    }

    /// Bytes this process receives per application of `S` (both ghost exchanges).
    pub fn halo_bytes_per_application(&self) -> usize {
        8 * (self.kept.ghosts.len() + self.elim.ghosts.len())
    }

    /// Stored entries of `B` and `C̃` on this process.
    pub fn nnz_blocks(&self) -> usize {
        self.b.nnz() + self.c.nnz()
    }
}
