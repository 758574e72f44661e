//! Assembly straight into the parity blocks `A = [[D_e, B], [C, D_o]]` (docs/design.md §5),
//! without ever holding `A` itself.
//!
//! The parity solvers only need `D_e`, `D_o`, `B` and `C̃ = D_o⁻¹ C`
//! ([`crate::solver::parity::split::Split`]); building them from an assembled `A` holds both
//! at once, about twice the matrix (on the 80³ P_5 point source 3.8 GB each). Here the rows
//! are assembled block by block ([`crate::assemble::assemble_rows`], the same row code as
//! [`crate::assemble::assemble`]) and each block is split and appended before the next is
//! assembled, so the peak is the blocks plus one block of rows. The capacity of `B` and
//! `C̃` is reserved up front from the stencil pattern (an upper bound: boundary closure only
//! removes entries, and a Marshak face row counts with its own length), so they are never reallocated; each block of rows is copied into them in
//! parallel.

use crate::assemble::{assemble_rows, check_kernel, face_closures, Chunk, CHUNK};
use crate::layout::Layout;
use crate::marshak::MarshakRows;
use crate::problem::Problem;
use crate::solver::parity::split::{classes, BlockMat, Classes, ParityError, Split};
use crate::solver::pn_layout::{retained_mask, Retained};
use pn_krylov::linalg::split_runs;
use pn_stencil::StencilKernel;
use rayon::prelude::*;

mod stencil;

/// Rows assembled before they are split and appended (about 3.4 M entries, ~100 MB of
/// transient buffers, for P_5 in 3D; 128 parallel chunks).
const ROWS_PER_BLOCK: usize = 1 << 18;

/// The system in parity-block form.
pub struct SplitSystem {
    /// The blocks of `A`.
    pub split: Split,
    /// Right-hand side in storage order.
    pub rhs: Vec<f64>,
    /// Largest magnitude of an entry of `A`.
    pub max_entry: f64,
    /// Seconds spent forming the rows (in parallel).
    pub seconds_rows: f64,
    /// Seconds spent appending the rows to the blocks.
    pub seconds_append: f64,
}

/// Whether every term of `kernel` couples a row to the other parity (by `l`), apart from
/// the centred term of the row's own moment: the structure parity elimination needs. CDA
/// (one moment) and collocated or user stencils may not have it.
pub fn has_parity_structure(kernel: &dyn StencilKernel) -> bool {
    let moments = kernel.moments();
    // A PDE's own boundary conditions (crate::robin) may couple equal parities at a face.
    kernel.boundary_conditions().is_none()
        && (0..moments.len()).all(|q| {
            kernel.pattern(q).iter().all(|t| {
                (t.moment == q && t.offset == [0, 0, 0])
                    || moments
                        .get(t.moment)
                        .is_some_and(|p| p.l % 2 != moments[q].l % 2)
            })
        })
}

/// One assembled chunk of rows, split.
struct SplitChunk {
    d_e: Vec<f64>,
    d_o: Vec<f64>,
    b_row_nnz: Vec<usize>,
    b_cols: Vec<u32>,
    b_vals: Vec<f64>,
    c_row_nnz: Vec<usize>,
    c_cols: Vec<u32>,
    c_vals: Vec<f64>,
    rhs: Vec<f64>,
    /// Stored diagonal entries (rows with a centred term of their own moment).
    diag_entries: usize,
    max_entry: f64,
}

/// Assembles `kernel` for `problem` on `layout` into parity blocks. The outer error is bad
/// input (as [`crate::assemble::assemble`]); the inner one says that the system lacks the
/// parity structure (a same-parity coupling, or a zero odd diagonal where σ_t = 0), in
/// which case the caller assembles `A` and takes another solver.
///
/// The kept parity is [`Retained::for_layout`] (odd l for even N); when the system cannot
/// be split that way (a zero absorption where the even moments would be eliminated), it
/// is assembled again with the even-l moments kept.
pub fn assemble_split(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
) -> anyhow::Result<Result<SplitSystem, ParityError>> {
    with_even_fallback(layout, |retained| {
        assemble_split_retaining(problem, kernel, layout, retained)
    })
}

/// [`assemble_split`] keeping the moments of the parity `retained` (the blocks' "even"
/// class), without a fallback.
pub fn assemble_split_retaining(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    retained: Retained,
) -> anyhow::Result<Result<SplitSystem, ParityError>> {
    let Prologue {
        marshak,
        even,
        classes: Classes {
            local,
            even: ev,
            odd: od,
        },
    } = match prologue(problem, kernel, layout, retained)? {
        Ok(p) => p,
        Err(e) => return Ok(Err(e)),
    };
    let n = layout.len();
    // Upper bounds of the off-diagonal entries of each block, from the pattern.
    let (mut b_cap, mut c_cap) = (0usize, 0usize);
    for (q, mp) in layout.moments.iter().enumerate() {
        let rows = layout.offsets[q + 1] - layout.offsets[q];
        let off = kernel
            .pattern(q)
            .iter()
            .filter(|t| !(t.moment == q && t.offset == [0, 0, 0]))
            .count()
            // A Marshak row may have more entries than the stencil's row it replaces.
            .max(marshak.as_ref().map_or(0, |m| m.max_row_len()));
        *(if retained.keeps(mp.l as usize) {
            &mut b_cap
        } else {
            &mut c_cap
        }) += rows * off;
    }
    let mut d_e = Vec::with_capacity(ev.len());
    let mut d_o = Vec::with_capacity(od.len());
    let mut b_ptr = Vec::with_capacity(ev.len() + 1);
    let mut c_ptr = Vec::with_capacity(od.len() + 1);
    b_ptr.push(0usize);
    c_ptr.push(0usize);
    // Zero-initialised at the bound: the allocator maps zero pages lazily, so the pages are
    // first touched by the parallel copies below, and the unused tail never is.
    let (mut b_idx, mut b_val) = (vec![0u32; b_cap], vec![0.0f64; b_cap]);
    let (mut c_idx, mut c_val) = (vec![0u32; c_cap], vec![0.0f64; c_cap]);
    let (mut b_len, mut c_len) = (0usize, 0usize);
    let mut rhs = Vec::with_capacity(n);
    let (mut max_entry, mut diag_entries) = (0.0f64, 0usize);
    let (mut seconds_rows, mut seconds_append) = (0.0, 0.0);
    for start in (0..n).step_by(ROWS_PER_BLOCK) {
        let t0 = std::time::Instant::now();
        let end = (start + ROWS_PER_BLOCK).min(n);
        let chunks: Vec<Result<SplitChunk, ParityError>> = (start..end)
            .step_by(CHUNK)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|r0| {
                let rows = r0..(r0 + CHUNK).min(end);
                let m = marshak.as_ref();
                assemble_and_split(problem, kernel, layout, m, rows, &even, &local)
            })
            .collect::<anyhow::Result<_>>()?;
        let t1 = std::time::Instant::now();
        seconds_rows += (t1 - t0).as_secs_f64();
        let chunks = match chunks.into_iter().collect::<Result<Vec<_>, _>>() {
            Ok(c) => c,
            Err(e) => return Ok(Err(e)),
        };
        // Each chunk's entries go to their own disjoint ranges of the blocks, in parallel.
        let nbs = chunks.iter().map(|c| c.b_cols.len());
        let ncs = chunks.iter().map(|c| c.c_cols.len());
        let (nb, nc): (usize, usize) = (nbs.clone().sum(), ncs.clone().sum());
        anyhow::ensure!(
            b_len + nb <= b_idx.len() && c_len + nc <= c_idx.len(),
            "internal error: the parity blocks outgrew the stencil-pattern bound"
        );
        let bis = split_runs(&mut b_idx[b_len..], nbs.clone());
        let bvs = split_runs(&mut b_val[b_len..], nbs);
        let cis = split_runs(&mut c_idx[c_len..], ncs.clone());
        let cvs = split_runs(&mut c_val[c_len..], ncs);
        let copies: Vec<_> = (chunks.iter().zip(bis.into_iter().zip(bvs)))
            .zip(cis.into_iter().zip(cvs))
            .map(|((chunk, (bi, bv)), (ci, cv))| (chunk, bi, bv, ci, cv))
            .collect();
        (b_len, c_len) = (b_len + nb, c_len + nc);
        copies.into_par_iter().for_each(|(chunk, bi, bv, ci, cv)| {
            bi.copy_from_slice(&chunk.b_cols);
            bv.copy_from_slice(&chunk.b_vals);
            ci.copy_from_slice(&chunk.c_cols);
            cv.copy_from_slice(&chunk.c_vals);
        });
        for chunk in &chunks {
            max_entry = max_entry.max(chunk.max_entry);
            diag_entries += chunk.diag_entries;
            extend_indptr(&mut b_ptr, &chunk.b_row_nnz);
            extend_indptr(&mut c_ptr, &chunk.c_row_nnz);
            d_e.extend_from_slice(&chunk.d_e);
            d_o.extend_from_slice(&chunk.d_o);
            rhs.extend_from_slice(&chunk.rhs);
        }
        seconds_append += t1.elapsed().as_secs_f64();
    }
    // Shrinking the length keeps the allocation (no copy); its untouched tail costs no memory.
    b_idx.truncate(b_len);
    b_val.truncate(b_len);
    c_idx.truncate(c_len);
    c_val.truncate(c_len);
    let nnz_a = b_len + c_len + diag_entries;
    let b = BlockMat::try_new((ev.len(), od.len()), b_ptr, b_idx, b_val)
        .map_err(|e| anyhow::anyhow!("internal error building the B block: {}", e.3))?;
    let c_scaled = BlockMat::try_new((od.len(), ev.len()), c_ptr, c_idx, c_val)
        .map_err(|e| anyhow::anyhow!("internal error building the C block: {}", e.3))?;
    Ok(Ok(SplitSystem {
        split: Split {
            even: ev,
            odd: od,
            d_e,
            d_o,
            b,
            c_scaled,
            nnz_a,
            stencil: None,
        },
        rhs,
        max_entry,
        seconds_rows,
        seconds_append,
    }))
}

/// [`assemble_split`] straight into the stencil form of the blocks
/// ([`crate::solver::parity::stencil_s`]): every row is assembled and split as there, then
/// compared with its moment's stencil (taken from the row nearest the middle of the
/// moment's grid), and only the diagonals, the right-hand side and the rows' corrections
/// are kept; `B` and `C̃` are never stored ([`Split::stencil`]; 2.6 GB at 80³ P_5). Where a
/// block is not stencil-like (more than
/// [`crate::solver::parity::stencil_s::MAX_CORRECTION_SHARE`] of its entries would be
/// corrections) the blocks are assembled instead, as [`assemble_split`] does.
pub fn assemble_split_stencil(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
) -> anyhow::Result<Result<SplitSystem, ParityError>> {
    with_even_fallback(layout, |retained| {
        stencil::assemble_stencil_retaining(problem, kernel, layout, retained)
    })
}

/// `assemble(Retained::for_layout(layout))`, and when that keeps the odd moments and the
/// system cannot be split so, `assemble(Retained::Even)`.
fn with_even_fallback(
    layout: &Layout,
    assemble: impl Fn(Retained) -> anyhow::Result<Result<SplitSystem, ParityError>>,
) -> anyhow::Result<Result<SplitSystem, ParityError>> {
    let retained = Retained::for_layout(layout);
    match assemble(retained)? {
        Err(_) if retained == Retained::Odd => assemble(Retained::Even),
        r => Ok(r),
    }
}

/// What both split assemblies check and set up first.
struct Prologue {
    marshak: Option<MarshakRows>,
    /// Whether each unknown is kept.
    even: Vec<bool>,
    classes: Classes,
}

/// The checks and the parity classes both split assemblies start from; the inner error
/// says that the mask cannot split the system.
fn prologue(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    retained: Retained,
) -> anyhow::Result<Result<Prologue, ParityError>> {
    check_kernel(problem, kernel, layout)?;
    let (robin, marshak) = face_closures(problem, kernel, layout)?;
    // Ghost eliminations add entries the pattern's bounds do not count, and such kernels
    // never have the parity structure ([`has_parity_structure`]).
    anyhow::ensure!(
        robin.is_none(),
        "the split assembly does not take a PDE's own boundary conditions; assemble A instead"
    );
    let even = retained_mask(layout, retained);
    Ok(classes(&even).map(|classes| Prologue {
        marshak,
        even,
        classes,
    }))
}

/// Appends row lengths to a CSR row pointer.
fn extend_indptr(ptr: &mut Vec<usize>, row_nnz: &[usize]) {
    let mut last = ptr.last().copied().unwrap_or(0);
    ptr.extend(row_nnz.iter().map(|k| {
        last += k;
        last
    }));
}

/// Assembles the rows `rows` ([`assemble_rows`], the split assemblies take no PDE's own
/// boundary conditions) and splits them by parity ([`split_chunk`]).
fn assemble_and_split(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    marshak: Option<&MarshakRows>,
    rows: impl ExactSizeIterator<Item = usize> + Clone,
    even: &[bool],
    local: &[u32],
) -> anyhow::Result<Result<SplitChunk, ParityError>> {
    let chunk = assemble_rows(problem, kernel, layout, marshak, None, rows.clone())?;
    Ok(split_chunk(&chunk, rows, even, local))
}

/// Splits the assembled rows of `chunk` (the global rows `rows`, in its order) by parity, as
/// [`crate::solver::parity::split::split`] does for a whole matrix (same checks, same
/// scaling `C̃ = D_o⁻¹ C`).
fn split_chunk(
    chunk: &Chunk,
    rows: impl Iterator<Item = usize>,
    even: &[bool],
    local: &[u32],
) -> Result<SplitChunk, ParityError> {
    let mut out = SplitChunk {
        d_e: Vec::new(),
        d_o: Vec::new(),
        b_row_nnz: Vec::new(),
        b_cols: Vec::new(),
        b_vals: Vec::new(),
        c_row_nnz: Vec::new(),
        c_cols: Vec::new(),
        c_vals: Vec::new(),
        rhs: chunk.rhs.clone(),
        diag_entries: 0,
        max_entry: 0.0,
    };
    let mut p = 0usize;
    for (row, &len) in rows.zip(&chunk.row_nnz) {
        let (cols, vals) = (&chunk.cols[p..p + len], &chunk.vals[p..p + len]);
        p += len;
        let row_even = even[row];
        let mut diag = 0.0;
        for (&col, &v) in cols.iter().zip(vals) {
            out.max_entry = out.max_entry.max(v.abs());
            if col == row {
                diag = v;
                out.diag_entries += 1;
            } else if even[col] == row_even {
                return Err(ParityError::SameParityCoupling {
                    row,
                    col,
                    parity: if row_even { "even" } else { "odd" },
                    value: v,
                });
            }
        }
        if !row_even && (diag == 0.0 || !diag.is_finite()) {
            return Err(ParityError::SingularOddDiagonal { row, value: diag });
        }
        let (row_nnz, out_cols, out_vals) = if row_even {
            out.d_e.push(diag);
            (&mut out.b_row_nnz, &mut out.b_cols, &mut out.b_vals)
        } else {
            out.d_o.push(diag);
            (&mut out.c_row_nnz, &mut out.c_cols, &mut out.c_vals)
        };
        let before = out_cols.len();
        for (&col, &v) in cols.iter().zip(vals) {
            if col != row {
                out_cols.push(local[col]);
                out_vals.push(if row_even { v } else { v / diag });
            }
        }
        row_nnz.push(out_cols.len() - before);
    }
    Ok(out)
}
