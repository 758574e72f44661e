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
use pn_runtime::assemble_split::has_parity_structure;
use pn_runtime::problem::Problem;
use pn_runtime::solver::pn_layout::Retained;
use pn_runtime::Layout;
use pn_stencil::StencilKernel;
use rayon::prelude::*;

/// Rows of a block in compressed form; columns index an extended local vector (owned
/// unknowns, then ghosts), kept in the storage order of the global columns.
#[derive(Clone, Debug, Default)]
pub struct LocalRows {
    pub(crate) indptr: Vec<usize>,
    pub(crate) cols: Vec<u32>,
    pub(crate) vals: Vec<f64>,
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
    /// Owned plus ghost unknowns.
    pub fn extended_len(&self) -> usize {
        self.owned.len() + self.ghosts.len()
    }
}

/// Rows of the assembled `S` (see [`LocalReduced::formed_rows`]).
#[derive(Clone, Debug, Default)]
pub struct FormedRows {
    /// Entries of each row.
    pub row_len: Vec<u32>,
    /// Column numbers, row after row.
    pub cols: Vec<i32>,
    /// Values, row after row.
    pub vals: Vec<f64>,
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
    pub(crate) b: LocalRows,
    /// `C̃ = D_o⁻¹ C`: owned eliminated rows × kept columns (extended local).
    pub(crate) c: LocalRows,
    /// A system without the parity structure, solved as it stands: the off-diagonal
    /// entries of the owned rows (kept columns, extended local); `b` and `c` are then empty.
    pub(crate) direct: Option<LocalRows>,
    /// Stored entries of this process's rows of `A` (diagonals included).
    pub nnz_a: usize,
}

/// The moments the parity solvers keep on `layout` ([`Retained::for_layout`]); every
/// moment when `kernel`'s system lacks the parity structure (CDA, most text PDEs), which is
/// then solved as it stands ([`LocalReduced::is_direct`]).
pub fn kept_moments(layout: &Layout, kernel: &dyn StencilKernel) -> Vec<bool> {
    kept_moments_retaining(layout, kernel, Retained::for_layout(layout))
}

/// [`kept_moments`] with the kept parity given: [`Retained::Even`] is the fallback where
/// keeping the odd moments (even N) meets a zero absorption ([`ZeroEliminatedDiagonal`]),
/// as in `pn solve`'s parity solver.
pub fn kept_moments_retaining(
    layout: &Layout,
    kernel: &dyn StencilKernel,
    retained: Retained,
) -> Vec<bool> {
    let parity = has_parity_structure(kernel);
    layout
        .moments
        .iter()
        .map(|m| !parity || retained.keeps(m.l as usize))
        .collect()
}

/// An eliminated row with a zero (or non-finite) diagonal: parity elimination divides by
/// it. Where the odd moments are kept (even N) this is a zero absorption, and keeping the
/// even ones instead works ([`kept_moments_retaining`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "row {row} of the eliminated parity has diagonal {value:e}; parity elimination divides by \
     it (σ_t must be positive everywhere, docs/design.md §5)"
)]
pub struct ZeroEliminatedDiagonal {
    /// The row (storage index).
    pub row: usize,
    /// Its diagonal.
    pub value: f64,
}

/// One class's rows split into the diagonal and the off-diagonal block.
struct SplitRows {
    diag: Vec<f64>,
    rhs: Vec<f64>,
    block: LocalRows,
    /// The off-diagonal columns owned elsewhere (the other class's ghosts), ascending.
    ghosts: Vec<usize>,
}

/// Where a column of the other class lives: owned here (its local index) or a ghost.
struct OtherClass<'a> {
    layout: &'a Layout,
    dec: &'a Decomposition,
    num: &'a Numbering,
    rank: usize,
}

impl OtherClass<'_> {
    /// `None`: `g` is not of the other class; `Some(Some(l))`: owned, local index `l`;
    /// `Some(None)`: a ghost.
    fn classify(&self, g: usize) -> Option<Option<usize>> {
        let (q, idx) = self.layout.locate(g);
        if !self.num.contains_moment(q) {
            return None;
        }
        Some((self.dec.owner(idx) == self.rank).then(|| self.num.local(self.rank, q, idx)))
    }
}

/// Splits the assembled rows `rows` of the unknowns `owned` into their diagonal and the
/// off-diagonal block, whose columns must all be unknowns of the other class (`other`) —
/// the parity structure of docs/design.md §5. With `scale_by_diag` the block's rows are
/// divided by their diagonal (`C̃ = D_o⁻¹ C`), which must then be non-zero. The block's
/// columns index the other class's extended local vector (owned, then ghosts) and keep the
/// assembled order.
fn split_rows(
    rows: RowSet,
    owned: &[usize],
    other: &OtherClass<'_>,
    scale_by_diag: bool,
) -> anyhow::Result<SplitRows> {
    // One pass classifies every entry: owned columns get their local index at once, ghosts
    // theirs once the ghost list is sorted (`pending`).
    let mut diag = vec![0.0; owned.len()];
    let mut ghosts = Vec::new();
    let mut pending = Vec::new();
    let mut block = LocalRows {
        indptr: Vec::with_capacity(owned.len() + 1),
        cols: Vec::with_capacity(rows.cols.len().saturating_sub(owned.len())),
        vals: Vec::with_capacity(rows.cols.len().saturating_sub(owned.len())),
    };
    block.indptr.push(0);
    for (i, &g) in owned.iter().enumerate() {
        for k in rows.indptr[i]..rows.indptr[i + 1] {
            let (col, v) = (rows.cols[k], rows.vals[k]);
            if col == g {
                diag[i] = v;
                continue;
            }
            match other.classify(col) {
                None => anyhow::bail!(
                    "row {g} couples to unknown {col} of its own parity off the diagonal \
                     (value {v:e}); the distributed solve needs the parity structure \
                     (docs/design.md §5)"
                ),
                Some(None) => {
                    pending.push((block.cols.len(), col));
                    ghosts.push(col);
                    block.cols.push(u32::MAX);
                }
                Some(Some(l)) => block.cols.push(l as u32),
            }
            block.vals.push(v);
        }
        block.indptr.push(block.cols.len());
    }
    if scale_by_diag {
        if let Some((i, &v)) = diag
            .iter()
            .enumerate()
            .find(|(_, v)| **v == 0.0 || !v.is_finite())
        {
            return Err(ZeroEliminatedDiagonal {
                row: owned[i],
                value: v,
            }
            .into());
        }
        for (i, d) in diag.iter().enumerate() {
            for v in &mut block.vals[block.indptr[i]..block.indptr[i + 1]] {
                *v /= d;
            }
        }
    }
    ghosts.par_sort_unstable();
    ghosts.dedup();
    let n_other = other.num.local_len(other.rank);
    for (at, col) in pending {
        let k = ghosts.binary_search(&col).unwrap_or(usize::MAX - n_other);
        block.cols[at] = (n_other + k) as u32;
    }
    Ok(SplitRows {
        diag,
        rhs: rows.rhs,
        block,
        ghosts,
    })
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
        Self::build_keeping(
            problem,
            kernel,
            layout,
            dec,
            rank,
            &kept_moments(layout, kernel),
        )
    }

    /// [`Self::build`] keeping the moments `keep` (from [`kept_moments_retaining`]).
    pub fn build_keeping(
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        dec: &Decomposition,
        rank: usize,
        keep: &[bool],
    ) -> anyhow::Result<Self> {
        let keep = keep.to_vec();
        let kept_num = Numbering::new(layout, dec, keep.clone());
        let elim_num = Numbering::new(layout, dec, keep.iter().map(|k| !k).collect());
        let kept_owned = kept_num.owned(layout, rank);
        let elim_owned = elim_num.owned(layout, rank);
        if keep.iter().all(|&k| k) {
            return Self::build_direct(problem, kernel, layout, dec, &kept_num, rank);
        }
        let class = |num| OtherClass {
            layout,
            dec,
            num,
            rank,
        };
        // One class at a time, so that only one class's assembled rows are held.
        let rows = assemble_row_subset(problem, kernel, layout, &kept_owned)
            .context("assembling the kept rows")?;
        let mut nnz_a = rows.vals.len();
        let e = split_rows(rows, &kept_owned, &class(&elim_num), false)?;
        let rows = assemble_row_subset(problem, kernel, layout, &elim_owned)
            .context("assembling the eliminated rows")?;
        nnz_a += rows.vals.len();
        let o = split_rows(rows, &elim_owned, &class(&kept_num), true)?;
        Ok(Self {
            rank,
            kept: Part {
                owned: kept_owned,
                ghosts: o.ghosts,
            },
            elim: Part {
                owned: elim_owned,
                ghosts: e.ghosts,
            },
            d_e: e.diag,
            d_o: o.diag,
            b_e: e.rhs,
            b_o: o.rhs,
            b: e.block,
            c: o.block,
            direct: None,
            nnz_a,
        })
    }

    /// [`Self::build`] for a system without eliminated unknowns (every moment kept).
    fn build_direct(
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        dec: &Decomposition,
        num: &Numbering,
        rank: usize,
    ) -> anyhow::Result<Self> {
        let owned = num.owned(layout, rank);
        let rows =
            assemble_row_subset(problem, kernel, layout, &owned).context("assembling the rows")?;
        let nnz_a = rows.vals.len();
        let all = OtherClass {
            layout,
            dec,
            num,
            rank,
        };
        let a = split_rows(rows, &owned, &all, false)?;
        let n = owned.len();
        Ok(Self {
            rank,
            kept: Part {
                owned,
                ghosts: a.ghosts,
            },
            elim: Part::default(),
            d_e: a.diag,
            d_o: Vec::new(),
            b_e: a.rhs,
            b_o: Vec::new(),
            b: LocalRows {
                indptr: vec![0; n + 1],
                ..LocalRows::default()
            },
            c: LocalRows {
                indptr: vec![0],
                ..LocalRows::default()
            },
            direct: Some(a.block),
            nnz_a,
        })
    }

    /// Whether the system is solved as it stands (no parity elimination): the operator is
    /// `A` itself, [`Self::apply_direct`].
    pub fn is_direct(&self) -> bool {
        self.direct.is_some()
    }

    /// `y = A x` on the owned rows of a system without elimination (`x_ext`: owned values,
    /// then the ghosts); `y = D_e x` when there is no such system.
    pub fn apply_direct(&self, x_ext: &[f64], y: &mut [f64]) {
        let direct = self.direct.as_ref();
        y.par_iter_mut().enumerate().for_each(|(i, y)| {
            *y = self.d_e[i] * x_ext[i] + direct.map_or(0.0, |a| a.row_dot(i, x_ext));
        });
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
                let direct = self.direct.as_ref().map_or(0.0, |a| a.row_dot(i, ue_ext));
                let r = self.b_e[i] - self.d_e[i] * ue_ext[i] - direct - self.b.row_dot(i, uo_ext);
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

    /// The rows of `S = D_e − B C̃` this process owns, for an algebraic or Galerkin
    /// multigrid: `c_ghost` holds the `C̃` rows of the eliminated ghosts (from
    /// [`Self::ghost_c_rows`]) and `column` numbers a kept storage index (the distributed
    /// numbering). Columns ascend within a row.
    pub fn formed_rows(
        &self,
        c_ghost: &RowSet,
        column: &(dyn Fn(usize) -> anyhow::Result<i32> + Sync),
    ) -> anyhow::Result<FormedRows> {
        const ROWS_PER_TASK: usize = 4096;
        let n_o = self.elim.owned.len();
        let n_e = self.kept.owned.len();
        // The numbers of the owned kept unknowns and their ghosts, found once.
        let numbers: Vec<i32> = self
            .kept
            .owned
            .par_iter()
            .chain(self.kept.ghosts.par_iter())
            .map(|&g| column(g))
            .collect::<anyhow::Result<_>>()?;
        let chunks: Vec<FormedRows> = (0..n_e)
            .collect::<Vec<_>>()
            .par_chunks(ROWS_PER_TASK)
            .map(|rows| {
                let mut out = FormedRows::default();
                // The row's products, then sorted by column (stable: equal columns keep
                // the order they were made in, the same on any split) and summed.
                let mut row: Vec<(i32, f64)> = Vec::new();
                for &i in rows {
                    row.clear();
                    row.push((numbers[i], self.d_e[i]));
                    if let Some(a) = &self.direct {
                        for k in a.indptr[i]..a.indptr[i + 1] {
                            row.push((numbers[a.cols[k] as usize], a.vals[k]));
                        }
                    }
                    for k in self.b.indptr[i]..self.b.indptr[i + 1] {
                        let (slot, bw) = (self.b.cols[k] as usize, self.b.vals[k]);
                        if slot < n_o {
                            for m in self.c.indptr[slot]..self.c.indptr[slot + 1] {
                                row.push((
                                    numbers[self.c.cols[m] as usize],
                                    -(bw * self.c.vals[m]),
                                ));
                            }
                        } else {
                            let r = slot - n_o;
                            for m in c_ghost.indptr[r]..c_ghost.indptr[r + 1] {
                                row.push((column(c_ghost.cols[m])?, -(bw * c_ghost.vals[m])));
                            }
                        }
                    }
                    row.sort_by_key(|e| e.0);
                    let mut len = 0u32;
                    let mut k = 0;
                    while k < row.len() {
                        let (n, mut v) = row[k];
                        k += 1;
                        while k < row.len() && row[k].0 == n {
                            v += row[k].1;
                            k += 1;
                        }
                        out.cols.push(n);
                        out.vals.push(v);
                        len += 1;
                    }
                    out.row_len.push(len);
                }
                Ok(out)
            })
            .collect::<anyhow::Result<_>>()?;
        let mut all = FormedRows::default();
        for c in chunks {
            all.row_len.extend(c.row_len);
            all.cols.extend(c.cols);
            all.vals.extend(c.vals);
        }
        Ok(all)
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

    /// The diagonal of `S` on the owned kept rows: `D_e − Σ_k B_ik C̃_ki` (`A`'s diagonal
    /// for a system without elimination), with `c_ghost` the `C̃` rows of the eliminated
    /// ghosts ([`Self::ghost_c_rows`]). For Jacobi smoothing without forming `S`.
    pub fn diagonal_of_s(&self, c_ghost: &RowSet) -> Vec<f64> {
        let n_o = self.elim.owned.len();
        (0..self.kept.owned.len())
            .into_par_iter()
            .map(|i| {
                let mut d = self.d_e[i];
                for k in self.b.indptr[i]..self.b.indptr[i + 1] {
                    let (slot, bw) = (self.b.cols[k] as usize, self.b.vals[k]);
                    if slot < n_o {
                        for m in self.c.indptr[slot]..self.c.indptr[slot + 1] {
                            if self.c.cols[m] as usize == i {
                                d -= bw * self.c.vals[m];
                            }
                        }
                    } else {
                        let (r, g) = (slot - n_o, self.kept.owned[i]);
                        for m in c_ghost.indptr[r]..c_ghost.indptr[r + 1] {
                            if c_ghost.cols[m] == g {
                                d -= bw * c_ghost.vals[m];
                            }
                        }
                    }
                }
                d
            })
            .collect()
    }

    /// Bytes this process receives per application of `S` (both ghost exchanges).
    pub fn halo_bytes_per_application(&self) -> usize {
        8 * (self.kept.ghosts.len() + self.elim.ghosts.len())
    }

    /// Stored entries of `B` and `C̃` (or of `A`'s off-diagonal part) on this process.
    pub fn nnz_blocks(&self) -> usize {
        self.b.nnz() + self.c.nnz() + self.direct.as_ref().map_or(0, LocalRows::nnz)
    }
}
