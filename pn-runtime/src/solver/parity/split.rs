//! Splitting `A` into the even/odd parity blocks `A = [[D_e, B], [C, D_o]]` (DESIGN.md §5).
//!
//! The staggered transport couples even-l moments only to odd-l moments and the collision
//! term is diagonal, so the two diagonal blocks must be diagonal matrices. [`split`] checks
//! this on the assembled matrix and extracts `D_e`, `D_o`, `B` (even rows × odd columns) and
//! `C̃ = D_o⁻¹ C` (odd rows × even columns, already scaled so that the reduced operator is
//! two plain sparse products).

use sprs::CsMat;

/// Why the parity elimination does not apply to a matrix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParityError {
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
         diagonal and transport to couple even-l only to odd-l moments (DESIGN.md §5) — \
         use --solver cgnr for this system"
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
    /// A zero (or non-finite) diagonal entry in an odd row: `D_o` cannot be inverted.
    #[error(
        "odd-l row {row} has diagonal {value:e}; parity elimination divides by it \
         (σ_t must be positive everywhere: vacuum regions need a minimum σ_t, DESIGN.md §5)"
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
    /// The block-Jacobi block map does not match the matrix size.
    #[error("the block map has {len} entries but the matrix has {rows} rows")]
    BlockMapLength {
        /// Map length.
        len: usize,
        /// Matrix rows.
        rows: usize,
    },
}

/// The parity blocks of `A`.
#[derive(Clone, Debug)]
pub struct Split {
    /// Global index of each even unknown (in increasing order).
    pub even: Vec<usize>,
    /// Global index of each odd unknown (in increasing order).
    pub odd: Vec<usize>,
    /// Diagonal of the even–even block.
    pub d_e: Vec<f64>,
    /// Diagonal of the odd–odd block.
    pub d_o: Vec<f64>,
    /// Even rows × odd columns (CSR).
    pub b: CsMat<f64>,
    /// `D_o⁻¹ C`: odd rows × even columns (CSR).
    pub c_scaled: CsMat<f64>,
    /// Stored non-zeros of the original matrix.
    pub nnz_a: usize,
}

/// Splits `a` (CSR) by the parity mask `even` (`true` for even-l unknowns).
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
    // Local index of each global unknown within its parity class.
    let mut local = vec![0usize; n];
    let (mut ev, mut od) = (Vec::new(), Vec::new());
    for (g, &e) in even.iter().enumerate() {
        if e {
            local[g] = ev.len();
            ev.push(g);
        } else {
            local[g] = od.len();
            od.push(g);
        }
    }
    let mut d_e = vec![0.0; ev.len()];
    let mut d_o = vec![0.0; od.len()];
    let (mut b_ptr, mut b_idx, mut b_val) = (vec![0usize], Vec::new(), Vec::new());
    let (mut c_ptr, mut c_idx, mut c_val) = (vec![0usize], Vec::new(), Vec::new());
    for (row, vec) in a.outer_iterator().enumerate() {
        let row_even = even[row];
        let mut diag = 0.0;
        for (col, &v) in vec.iter() {
            if col == row {
                diag += v;
            } else if even[col] == row_even {
                if v != 0.0 {
                    return Err(ParityError::SameParityCoupling {
                        row,
                        col,
                        parity: if row_even { "even" } else { "odd" },
                        value: v,
                    });
                }
            } else if row_even {
                b_idx.push(local[col]);
                b_val.push(v);
            } else {
                c_idx.push(local[col]);
                c_val.push(v);
            }
        }
        if row_even {
            d_e[local[row]] = diag;
            b_ptr.push(b_idx.len());
        } else {
            if diag == 0.0 || !diag.is_finite() {
                return Err(ParityError::SingularOddDiagonal { row, value: diag });
            }
            d_o[local[row]] = diag;
            let start = *c_ptr.last().unwrap();
            c_val[start..].iter_mut().for_each(|v| *v /= diag);
            c_ptr.push(c_idx.len());
        }
    }
    // Columns within a row stay sorted: `local` is increasing in the global index.
    let b = CsMat::new((ev.len(), od.len()), b_ptr, b_idx, b_val);
    let c_scaled = CsMat::new((od.len(), ev.len()), c_ptr, c_idx, c_val);
    Ok(Split {
        even: ev,
        odd: od,
        d_e,
        d_o,
        b,
        c_scaled,
        nnz_a: a.nnz(),
    })
}

impl Split {
    /// Scatters even and odd parts back into one global vector.
    pub fn merge(&self, u_e: &[f64], u_o: &[f64]) -> Vec<f64> {
        let mut u = vec![0.0; self.even.len() + self.odd.len()];
        for (&g, &v) in self.even.iter().zip(u_e) {
            u[g] = v;
        }
        for (&g, &v) in self.odd.iter().zip(u_o) {
            u[g] = v;
        }
        u
    }

    /// Gathers the even and odd parts of a global vector.
    pub fn gather(&self, x: &[f64]) -> (Vec<f64>, Vec<f64>) {
        (
            self.even.iter().map(|&g| x[g]).collect(),
            self.odd.iter().map(|&g| x[g]).collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
