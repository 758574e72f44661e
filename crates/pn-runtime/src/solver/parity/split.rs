//! Splitting `A` into the even/odd parity blocks `A = [[D_e, B], [C, D_o]]` (docs/design.md §5).
//!
//! The staggered transport couples even-l moments only to odd-l moments and the collision
//! term is diagonal, so the two diagonal blocks must be diagonal matrices. [`split`] checks
//! this on the assembled matrix and extracts `D_e`, `D_o`, `B` (even rows × odd columns) and
//! `C̃ = D_o⁻¹ C` (odd rows × even columns, already scaled so that the reduced operator is
//! two plain sparse products).

use super::stencil_s::StencilReduced;
use pn_krylov::linalg::{split_runs, spmv};
use rayon::prelude::*;
use sprs::CsMat;
use std::borrow::Cow;

/// Why the parity elimination does not apply to a matrix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParityError {
    /// A start guess does not have one value per unknown.
    #[error("a start guess has {got} values but the system has {expected} unknowns")]
    GuessLength {
        /// Unknowns of the system.
        expected: usize,
        /// Values of the guess.
        got: usize,
    },
    /// The even/odd mask does not match the matrix size.
    #[error("the even/odd mask has {mask} entries but the matrix has {rows} rows")]
    MaskLength {
        /// Mask length.
        mask: usize,
        /// Matrix rows.
        rows: usize,
    },
    /// The matrix is not square.
    #[error("the matrix is {rows}×{cols}, not square")]
    NotSquare {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
    },
    /// An even–even or odd–odd coupling off the diagonal.
    #[error(
        "row {row} couples to unknown {col} of the same parity ({parity}) off the diagonal \
         (value {value:e}); parity elimination needs the collision/scattering part to be \
         diagonal and transport to couple even-l only to odd-l moments (docs/design.md §5)"
    )]
    SameParityCoupling {
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// `even` or `odd`.
        parity: &'static str,
        /// The offending entry.
        value: f64,
    },
    /// A zero (or non-finite) diagonal entry in a row of the eliminated parity (odd l, or
    /// even l for even N): `D_o` cannot be inverted.
    #[error(
        "row {row} of the eliminated parity has diagonal {value:e}; parity elimination divides \
         by it (σ_t must be positive everywhere: vacuum regions need a minimum σ_t; where the \
         even-l moments are eliminated, also the absorption σ_t − σ_s, docs/design.md §5)"
    )]
    SingularOddDiagonal {
        /// Row index.
        row: usize,
        /// Diagonal value.
        value: f64,
    },
    /// A block of the block-Jacobi preconditioner could not be inverted.
    #[error("block-Jacobi block {block} of the reduced operator is singular")]
    SingularBlock {
        /// Block id.
        block: usize,
    },
    /// The multigrid preconditioner could not be built.
    #[error(transparent)]
    Multigrid(#[from] crate::solver::multigrid::MgError),
    /// More unknowns of one parity than 32-bit block indices can address.
    #[error(
        "{unknowns} unknowns of one parity exceed the 32-bit indices of the parity blocks \
         (at most {max}); lower --res or --order, or use --solver cgnr-mf"
    )]
    TooManyUnknowns {
        /// Unknowns of the larger class.
        unknowns: usize,
        /// The limit.
        max: usize,
    },
    /// The block-Jacobi block map does not match the matrix size.
    #[error("the block map has {len} entries but the matrix has {rows} rows")]
    BlockMapLength {
        /// Map length.
        len: usize,
        /// Matrix rows.
        rows: usize,
    },
}

pub use super::block_mat::BlockMat;

/// Checks that both parity classes fit [`BlockMat`]'s 32-bit column indices.
pub fn check_index_range(even: usize, odd: usize) -> Result<(), ParityError> {
    let max = u32::MAX as usize;
    match even.max(odd) {
        k if k > max => Err(ParityError::TooManyUnknowns { unknowns: k, max }),
        _ => Ok(()),
    }
}

/// The unknowns of each parity class and every unknown's index within its class.
pub struct Classes {
    /// Index of each global unknown within its class (increasing in the global index, so
    /// block columns stay sorted within a row).
    pub local: Vec<u32>,
    /// Global indices of the even unknowns, increasing.
    pub even: Vec<usize>,
    /// Global indices of the odd unknowns, increasing.
    pub odd: Vec<usize>,
}

/// [`Classes`] of the mask `even`, after checking that they fit [`BlockMat`]'s indices.
pub fn classes(even: &[bool]) -> Result<Classes, ParityError> {
    // Block by block in parallel: each block's even count gives where its unknowns go
    // in the two lists.
    const BLOCK: usize = 1 << 16;
    let counts: Vec<usize> = even
        .par_chunks(BLOCK)
        .map(|b| b.iter().filter(|&&e| e).count())
        .collect();
    let evens: usize = counts.iter().sum();
    check_index_range(evens, even.len() - evens)?;
    let mut local = vec![0u32; even.len()];
    let (mut ev, mut od) = (vec![0usize; evens], vec![0usize; even.len() - evens]);
    // Each block's runs of the two lists, and its first even index (its first odd index is
    // then the block's start minus that).
    let odds = counts
        .iter()
        .enumerate()
        .map(|(k, &c)| BLOCK.min(even.len() - k * BLOCK) - c);
    let (e_runs, o_runs) = (
        split_runs(&mut ev, counts.iter().copied()),
        split_runs(&mut od, odds),
    );
    let e_firsts: Vec<usize> = counts
        .iter()
        .scan(0, |before, &c| {
            *before += c;
            Some(*before - c)
        })
        .collect();
    local
        .par_chunks_mut(BLOCK)
        .zip(even.par_chunks(BLOCK))
        .zip(e_runs.into_par_iter().zip(o_runs))
        .zip(e_firsts)
        .enumerate()
        .for_each(|(k, (((loc, mask), (e, o)), e0))| {
            let o0 = k * BLOCK - e0;
            let (mut ne, mut no) = (0, 0);
            for (i, (l, &is_even)) in loc.iter_mut().zip(mask).enumerate() {
                let g = k * BLOCK + i;
                // In range: checked above.
                if is_even {
                    *l = (e0 + ne) as u32;
                    e[ne] = g;
                    ne += 1;
                } else {
                    *l = (o0 + no) as u32;
                    o[no] = g;
                    no += 1;
                }
            }
        });
    Ok(Classes {
        local,
        even: ev,
        odd: od,
    })
}

/// The parity blocks of `A`.
///
/// "Even" names the class that is kept in the reduced system and "odd" the eliminated
/// one: the even-l and odd-l moments for odd N, the other way round for even N
/// ([`crate::solver::pn_layout::Retained`]).
#[derive(Clone, Debug)]
pub struct Split {
    /// Global index of each kept ("even") unknown (in increasing order).
    pub even: Vec<usize>,
    /// Global index of each eliminated ("odd") unknown (in increasing order).
    pub odd: Vec<usize>,
    /// Diagonal of the even–even block.
    pub d_e: Vec<f64>,
    /// Diagonal of the odd–odd block.
    pub d_o: Vec<f64>,
    /// Even rows × odd columns (CSR, 32-bit columns); empty when [`Split::stencil`] holds
    /// the blocks ([`Split::blocks`] gives them either way).
    pub b: BlockMat,
    /// `D_o⁻¹ C`: odd rows × even columns (CSR, 32-bit columns); empty when
    /// [`Split::stencil`] holds the blocks.
    pub c_scaled: BlockMat,
    /// Stored non-zeros of the original matrix.
    pub nnz_a: usize,
    /// `B` and `C` as per-moment stencils plus corrections, when the system was assembled
    /// straight into them ([`crate::assemble_split::assemble_split_stencil`]): then `b` and
    /// `c_scaled` are not stored.
    pub stencil: Option<std::sync::Arc<StencilReduced>>,
}

/// Splits `a` (CSR) by the parity mask `even` (`true` for the unknowns kept in the
/// reduced system, the even-l ones unless [`crate::solver::pn_layout::Retained::Odd`]).
pub fn split(a: &CsMat<f64>, even: &[bool]) -> Result<Split, ParityError> {
    let n = a.rows();
    if a.cols() != n {
        return Err(ParityError::NotSquare {
            rows: n,
            cols: a.cols(),
        });
    }
    if even.len() != n {
        return Err(ParityError::MaskLength {
            mask: even.len(),
            rows: n,
        });
    }
    let a = if a.is_csr() {
        std::borrow::Cow::Borrowed(a)
    } else {
        std::borrow::Cow::Owned(a.to_csr())
    };
    let Classes {
        local,
        even: ev,
        odd: od,
    } = classes(even)?;
    let ap = a.indptr();
    let ap = ap.raw_storage();
    let (ai, av) = (a.indices(), a.data());
    // Pass 1 (parallel): diagonal, count of off-parity entries per row, and the first
    // offending entry in row order.
    let scan: Vec<(f64, usize)> = (0..n)
        .into_par_iter()
        .map(|row| {
            let (mut diag, mut count) = (0.0, 0usize);
            for p in ap[row]..ap[row + 1] {
                if ai[p] == row {
                    diag += av[p];
                } else if even[ai[p]] != even[row] {
                    count += 1;
                }
            }
            (diag, count)
        })
        .collect();
    // The first offending row (in row order, as a sequential scan would report it).
    let bad = (0..n).into_par_iter().find_first(|&row| {
        (!even[row] && (scan[row].0 == 0.0 || !scan[row].0.is_finite()))
            || (ap[row]..ap[row + 1])
                .any(|p| ai[p] != row && even[ai[p]] == even[row] && av[p] != 0.0)
    });
    if let Some(row) = bad {
        for p in ap[row]..ap[row + 1] {
            let col = ai[p];
            if col != row && even[col] == even[row] && av[p] != 0.0 {
                return Err(ParityError::SameParityCoupling {
                    row,
                    col,
                    parity: if even[row] { "even" } else { "odd" },
                    value: av[p],
                });
            }
        }
        return Err(ParityError::SingularOddDiagonal {
            row,
            value: scan[row].0,
        });
    }
    let d_e: Vec<f64> = ev.iter().map(|&g| scan[g].0).collect();
    let d_o: Vec<f64> = od.iter().map(|&g| scan[g].0).collect();
    let prefix = |rows: &[usize]| {
        let mut ptr = Vec::with_capacity(rows.len() + 1);
        ptr.push(0usize);
        for &g in rows {
            ptr.push(ptr[ptr.len() - 1] + scan[g].1);
        }
        ptr
    };
    let (b_ptr, c_ptr) = (prefix(&ev), prefix(&od));
    drop(scan);
    // Pass 2 (parallel): fill both blocks, each task owning a contiguous range of rows
    // and hence disjoint slices of the outputs (no second copy of the blocks).
    let (mut b_idx, mut b_val) = (vec![0u32; b_ptr[ev.len()]], vec![0.0; b_ptr[ev.len()]]);
    let (mut c_idx, mut c_val) = (vec![0u32; c_ptr[od.len()]], vec![0.0; c_ptr[od.len()]]);
    // Each chunk of rows and its entries' counts in `B` and `C̃` (from the even and odd rows
    // before it = the local index of the next row of each parity).
    let mut spans = Vec::new();
    let (mut row, mut e0, mut o0) = (0, 0, 0);
    while row < n {
        let end = (row + SPLIT_CHUNK).min(n);
        let evens = even[row..end].iter().filter(|&&e| e).count();
        let (e1, o1) = (e0 + evens, o0 + (end - row - evens));
        spans.push((row, end, b_ptr[e1] - b_ptr[e0], c_ptr[o1] - c_ptr[o0]));
        (row, e0, o0) = (end, e1, o1);
    }
    let (nbs, ncs) = (spans.iter().map(|s| s.2), spans.iter().map(|s| s.3));
    let (bis, bvs) = (
        split_runs(&mut b_idx, nbs.clone()),
        split_runs(&mut b_val, nbs),
    );
    let (cis, cvs) = (
        split_runs(&mut c_idx, ncs.clone()),
        split_runs(&mut c_val, ncs),
    );
    let tasks = spans
        .iter()
        .zip(bis.into_iter().zip(bvs))
        .zip(cis.into_iter().zip(cvs));
    let tasks: Vec<_> = tasks
        .map(|(((r0, r1, _, _), (bi, bv)), (ci, cv))| (*r0, *r1, bi, bv, ci, cv))
        .collect();
    tasks.into_par_iter().for_each(|(r0, r1, bi, bv, ci, cv)| {
        let (mut pb, mut pc) = (0usize, 0usize);
        for row in r0..r1 {
            let row_even = even[row];
            for p in ap[row]..ap[row + 1] {
                let col = ai[p];
                if col == row || even[col] == row_even {
                    continue;
                }
                if row_even {
                    bi[pb] = local[col];
                    bv[pb] = av[p];
                    pb += 1;
                } else {
                    ci[pc] = local[col];
                    cv[pc] = av[p] / d_o[local[row] as usize];
                    pc += 1;
                }
            }
        }
    });
    // Columns within a row stay sorted: `local` is increasing in the global index.
    let b = BlockMat::new((ev.len(), od.len()), b_ptr, b_idx, b_val);
    let c_scaled = BlockMat::new((od.len(), ev.len()), c_ptr, c_idx, c_val);
    Ok(Split {
        even: ev,
        odd: od,
        d_e,
        d_o,
        b,
        c_scaled,
        nnz_a: a.nnz(),
        stencil: None,
    })
}

/// Rows per parallel task in [`split`].
const SPLIT_CHUNK: usize = 16_384;

impl Split {
    /// Scatters even and odd parts back into one global vector.
    pub fn merge(&self, u_e: &[f64], u_o: &[f64]) -> Vec<f64> {
        // Block by block in parallel: both index lists increase, so a block's even and odd
        // unknowns are a run of each list, taken in order.
        const BLOCK: usize = 1 << 16;
        let mut u = vec![0.0; self.even.len() + self.odd.len()];
        u.par_chunks_mut(BLOCK).enumerate().for_each(|(k, out)| {
            let g0 = k * BLOCK;
            let mut e = self.even.partition_point(|&g| g < g0);
            let mut o = self.odd.partition_point(|&g| g < g0);
            for (g, v) in (g0..).zip(out) {
                if self.even.get(e) == Some(&g) {
                    *v = u_e[e];
                    e += 1;
                } else if self.odd.get(o) == Some(&g) {
                    *v = u_o[o];
                    o += 1;
                }
            }
        });
        u
    }

    /// `‖b − A u‖₂` from the blocks, with `u` and `b` given by parity:
    /// `r_e = b_e − D_e u_e − B u_o`, `r_o = b_o − D_o (u_o + C̃ u_e)`. Equal to the norm of
    /// the residual of the assembled `A` up to rounding, so a solve can check its result
    /// after `A` itself has been dropped (or was never assembled, [`crate::assemble_split::assemble_split`]).
    pub fn residual_norm(&self, u_e: &[f64], u_o: &[f64], b_e: &[f64], b_o: &[f64]) -> f64 {
        // Σ r² over one parity: `coupling` times the other parity's unknowns gives `t`;
        // the odd rows hold C̃ = D_o⁻¹C, so their coupling is scaled by the diagonal too.
        let part = |t: Vec<f64>, b: &[f64], d: &[f64], u: &[f64], scaled| {
            (t.par_iter(), b.par_iter(), d.par_iter(), u.par_iter())
                .into_par_iter()
                .map(|(t, b, d, u)| {
                    let r = if scaled {
                        b - d * (u + t)
                    } else {
                        b - d * u - t
                    };
                    r * r
                })
                .sum::<f64>()
        };
        let (mut bt, mut ct) = (vec![0.0; b_e.len()], vec![0.0; b_o.len()]);
        match &self.stencil {
            Some(st) => {
                st.apply_b(u_o, &mut bt);
                st.apply_c_scaled(&self.d_o, u_e, &mut ct);
            }
            None => {
                spmv(&self.b, u_o, &mut bt);
                spmv(&self.c_scaled, u_e, &mut ct);
            }
        }
        (part(bt, b_e, &self.d_e, u_e, false) + part(ct, b_o, &self.d_o, u_o, true)).sqrt()
    }

    /// `B` and `C̃`: the stored blocks, or built from [`Split::stencil`] (for the routes
    /// that read the blocks entry by entry: ILU, block-Jacobi, the block Galerkin product).
    pub fn blocks(&self) -> (Cow<'_, BlockMat>, Cow<'_, BlockMat>) {
        match &self.stencil {
            Some(st) => {
                let (b, c) = st.to_blocks(&self.d_o);
                (Cow::Owned(b), Cow::Owned(c))
            }
            None => (Cow::Borrowed(&self.b), Cow::Borrowed(&self.c_scaled)),
        }
    }

    /// Gathers the even and odd parts of a global vector.
    pub fn gather(&self, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
        (
            self.even.par_iter().map(|&g| x[g]).collect(),
            self.odd.par_iter().map(|&g| x[g]).collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_range_is_checked() {
        let max = u32::MAX as usize;
        assert!(check_index_range(max, max).is_ok());
        let err = check_index_range(10, max + 1).unwrap_err();
        assert!(
            matches!(err, ParityError::TooManyUnknowns { unknowns, .. } if unknowns == max + 1)
        );
        assert!(err.to_string().contains("cgnr-mf"), "{err}");
    }

    #[test]
    fn splits_and_rejects() {
        // Unknowns 0 (even), 1 (odd), 2 (even): A = [[2, 1, 0], [-1, 3, 1], [0, -1, 4]].
        let a = CsMat::new(
            (3, 3),
            vec![0, 2, 5, 7],
            vec![0, 1, 0, 1, 2, 1, 2],
            vec![2.0, 1.0, -1.0, 3.0, 1.0, -1.0, 4.0],
        );
        let s = split(&a, &[true, false, true]).unwrap();
        assert_eq!(s.d_e, vec![2.0, 4.0]);
        assert_eq!(s.d_o, vec![3.0]);
        assert_eq!((s.b.get(0, 0), s.b.get(1, 0)), (Some(&1.0), Some(&-1.0)));
        assert_eq!(
            (s.c_scaled.get(0, 0), s.c_scaled.get(0, 1)),
            (Some(&(-1.0 / 3.0)), Some(&(1.0 / 3.0)))
        );
        // Marking 0 and 1 both even makes the (0,1) entry a same-parity coupling.
        assert!(matches!(
            split(&a, &[true, true, false]),
            Err(ParityError::SameParityCoupling { row: 0, col: 1, .. })
        ));
        assert!(matches!(
            split(&a, &[true]),
            Err(ParityError::MaskLength { .. })
        ));
    }

    /// The block-parallel `classes` against the plain walk, on a mask of several blocks
    /// whose class runs cross the block boundaries; the block-parallel `merge` inverts
    /// `gather` there.
    #[test]
    fn classes_equal_the_sequential_walk_and_merge_inverts_gather() {
        let mut state = 7u64;
        let even: Vec<bool> = (0..200_003)
            .map(|g| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                // Long runs (as in a moment-by-moment layout) and scattered flips.
                (g / 30_000) % 2 == 0 || (state >> 60) == 0
            })
            .collect();
        let c = classes(&even).unwrap();
        let (mut ev, mut od, mut local) = (Vec::new(), Vec::new(), Vec::new());
        for (g, &e) in even.iter().enumerate() {
            let list = if e { &mut ev } else { &mut od };
            local.push(list.len() as u32);
            list.push(g);
        }
        assert_eq!(c.even, ev);
        assert_eq!(c.odd, od);
        assert_eq!(c.local, local);
        let none = classes(&[]).unwrap();
        assert!(none.even.is_empty() && none.odd.is_empty() && none.local.is_empty());
        // Gathering by parity and merging back (block by block) returns every value.
        let split = Split {
            even: c.even,
            odd: c.odd,
            d_e: Vec::new(),
            d_o: Vec::new(),
            b: BlockMat::zero((0, 0)),
            c_scaled: BlockMat::zero((0, 0)),
            nnz_a: 0,
            stencil: None,
        };
        let x: Vec<f64> = (0..even.len()).map(|g| g as f64 * 0.5 - 7.0).collect();
        let (x_e, x_o) = split.gather(&x);
        assert_eq!(split.merge(&x_e, &x_o), x);
    }
}
