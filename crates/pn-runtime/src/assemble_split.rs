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
use crate::context::RowContext;
use crate::layout::Layout;
use crate::marshak::MarshakRows;
use crate::problem::Problem;
use crate::solver::parity::split::{classes, BlockMat, Classes, ParityError, Split};
use crate::solver::pn_layout::{retained_mask, Retained};
use pn_krylov::linalg::split_runs;
use pn_stencil::{StencilKernel, TermPattern};
use rayon::prelude::*;

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
        assemble_stencil_retaining(problem, kernel, layout, retained)
    })
}

/// What one chunk of rows leaves in the stencil assembly besides its diagonals and
/// right-hand sides ([`RowOut`]).
#[derive(Default)]
struct StencilChunk {
    b_fixes: Vec<(u32, u32, f64)>,
    c_fixes: Vec<(u32, u32, f64)>,
    b_nnz: usize,
    c_nnz: usize,
    diag_entries: usize,
    max_entry: f64,
}

/// Where one chunk of rows writes its diagonals and right-hand sides: its ranges of the
/// system's `D_e`, `D_o` and right-hand side (no per-chunk vectors to gather afterwards).
struct RowOut<'a> {
    d_e: &'a mut [f64],
    d_o: &'a mut [f64],
    rhs: &'a mut [f64],
    /// The chunk's first row, and its first kept and first eliminated unknowns' indices
    /// within their classes.
    first: usize,
    first_kept: usize,
    first_eliminated: usize,
}

impl RowOut<'_> {
    /// Writes row `g`'s diagonal (at its index `local` in `D_o` when `eliminated`, else in
    /// `D_e`) and right-hand side.
    fn set(&mut self, g: usize, local: u32, eliminated: bool, diag: f64, rhs: f64) {
        if eliminated {
            self.d_o[local as usize - self.first_eliminated] = diag;
        } else {
            self.d_e[local as usize - self.first_kept] = diag;
        }
        self.rhs[g - self.first] = rhs;
    }
}

/// What [`FastRows::row`] did with a row.
enum FastRow {
    /// The row is its moment's stencil: only its diagonal and right-hand side are kept.
    Taken {
        /// The row's diagonal entry.
        diag: f64,
        /// The row's right-hand side.
        rhs: f64,
    },
    /// The row must be assembled (near the boundary, or a weight differs).
    NotTaken,
    /// An eliminated row with a zero or non-finite diagonal.
    Singular(ParityError),
}

/// The stencil assembly's fast path for interior rows: a row whose every stencil term lies
/// inside its moment's grid (no closure touches it) and whose evaluated weights equal its
/// moment's reference row's (the row nearest the middle of the grid, to
/// [`crate::solver::parity::stencil_s::SAME_WEIGHT`]) has no correction, so only its
/// diagonal and right-hand side are kept: no column is resolved, sorted or split.
struct FastRows<'a> {
    /// Per moment: the box of positions whose terms all lie inside the grid, `[lo, hi)`.
    boxes: Vec<([usize; 3], [usize; 3])>,
    /// Per moment: the reference row (its weights empty: no fast path for the moment).
    reference: Vec<ReferenceRow>,
    marshak: Option<&'a MarshakRows>,
}

/// A moment's reference row for [`FastRows`], with what a row equal to it needs.
struct ReferenceRow {
    /// The weights, in the pattern's order.
    weights: Vec<f64>,
    /// How far each weight of a row may differ from them: `SAME_WEIGHT · |w|`, and `∞`
    /// for the centred terms of the row's own moment (the diagonal, which varies).
    tolerance: Vec<f64>,
    /// The centred terms.
    centre: Vec<usize>,
    /// Non-zero weights off the centre (equal weights are non-zero at the same terms),
    /// and the largest of their magnitudes.
    off_nonzeros: usize,
    off_max: f64,
}

impl ReferenceRow {
    fn new(pattern: &[TermPattern], q: usize, weights: Vec<f64>) -> Self {
        use crate::solver::parity::stencil_s::SAME_WEIGHT;
        let is_centre = |t: &TermPattern| t.moment == q && t.offset == [0, 0, 0];
        let off = || {
            pattern
                .iter()
                .zip(&weights)
                .filter(|(t, _)| !is_centre(t))
                .map(|(_, &w)| w)
        };
        Self {
            tolerance: pattern
                .iter()
                .zip(&weights)
                .map(|(t, &w)| match is_centre(t) {
                    true => f64::INFINITY,
                    false => SAME_WEIGHT * w.abs(),
                })
                .collect(),
            centre: (0..pattern.len())
                .filter(|&k| is_centre(&pattern[k]))
                .collect(),
            off_nonzeros: off().filter(|&w| w != 0.0).count(),
            off_max: off().fold(0.0f64, |m, w| m.max(w.abs())),
            weights,
        }
    }
}

impl<'a> FastRows<'a> {
    fn new(
        problem: &Problem,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        marshak: Option<&'a MarshakRows>,
    ) -> Self {
        let nm = layout.moments.len();
        let (mut boxes, mut reference) = (Vec::new(), Vec::new());
        let mut ctx = RowContext::new(problem, [0; 3]);
        for q in 0..nm {
            let e = layout.extents[q];
            let pattern = kernel.pattern(q);
            let h0 = layout.half_coord(q, [0; 3]);
            let (mut lo, mut hi) = ([0i64; 3], e.map(|v| v as i64));
            for t in pattern {
                let sp = layout.moments[t.moment].shift;
                let ep = layout.extents[t.moment];
                for d in 0..3 {
                    let half = h0[d] + t.offset[d] as i64;
                    let delta = if sp[d] == 1 {
                        half.div_euclid(2)
                    } else {
                        (half - 1).div_euclid(2)
                    };
                    lo[d] = lo[d].max(-delta);
                    hi[d] = hi[d].min(ep[d] as i64 - delta);
                }
            }
            let bx = (lo.map(|v| v.max(0) as usize), hi.map(|v| v.max(0) as usize));
            let mid = e.map(|v| v / 2);
            // A pattern naming one (moment, offset) twice is merged by the assembly: no
            // fast path then (its entry count would differ).
            let mut keys: Vec<_> = pattern.iter().map(|t| (t.moment, t.offset)).collect();
            keys.sort_unstable();
            let distinct = keys.windows(2).all(|w| w[0] != w[1]);
            let inside = distinct && (0..3).all(|d| mid[d] >= bx.0[d] && mid[d] < bx.1[d]);
            let mut w = vec![0.0; pattern.len()];
            if inside {
                ctx.set_row(layout.half_coord(q, mid));
                kernel.eval_row(q, &ctx, &mut w);
                if ctx.take_error().is_some() || w.iter().any(|v| !v.is_finite()) {
                    w.clear();
                }
            } else {
                w.clear();
            }
            boxes.push(bx);
            reference.push(ReferenceRow::new(pattern, q, w));
        }
        Self {
            boxes,
            reference,
            marshak,
        }
    }

    /// Takes row `g` (at moment `q`, position `idx`: [`Layout::positions_from`]) if it can
    /// (see [`FastRows`]), adding its entry counts and largest entry to `out` (the caller
    /// writes its diagonal and right-hand side). The largest entry off the diagonal is the
    /// reference row's (equal to the row's to [`SAME_WEIGHT`](crate::solver::parity::stencil_s::SAME_WEIGHT), relatively): it only bounds the
    /// system's magnitudes.
    #[allow(clippy::too_many_arguments)]
    fn row(
        &self,
        kernel: &dyn StencilKernel,
        layout: &Layout,
        ctx: &mut RowContext<'_>,
        weights: &mut Vec<f64>,
        (g, (q, idx)): (usize, (usize, [usize; 3])),
        eliminated: bool,
        out: &mut StencilChunk,
    ) -> FastRow {
        let reference = &self.reference[q];
        let (lo, hi) = self.boxes[q];
        if reference.weights.is_empty()
            || (0..3).any(|d| idx[d] < lo[d] || idx[d] >= hi[d])
            || self.marshak.is_some_and(|m| m.face_of(q, idx).is_some())
        {
            return FastRow::NotTaken;
        }
        ctx.set_row(layout.half_coord(q, idx));
        weights.clear();
        weights.resize(reference.weights.len(), 0.0);
        let rhs = kernel.eval_row(q, ctx, weights);
        // Every weight off the centre within its tolerance (a NaN or infinite one is not),
        // tested without branching; the centre's through the diagonal's finiteness.
        let differs = weights
            .iter()
            .zip(&reference.weights)
            .zip(&reference.tolerance)
            .fold(false, |d, ((&w, &r), &tol)| {
                let within = (w - r).abs() <= tol;
                d | !within
            });
        let diag = reference.centre.iter().fold(0.0, |s, &k| s + weights[k]);
        if differs || !diag.is_finite() || !rhs.is_finite() || ctx.take_error().is_some() {
            // The assembly of the row reports an error with its position.
            return FastRow::NotTaken;
        }
        let (has_diag, off, max) = (
            !reference.centre.is_empty(),
            reference.off_nonzeros,
            reference.off_max,
        );
        if eliminated && (diag == 0.0 || !diag.is_finite()) {
            return FastRow::Singular(ParityError::SingularOddDiagonal {
                row: g,
                value: diag,
            });
        }
        out.max_entry = out.max_entry.max(max).max(diag.abs());
        out.diag_entries += usize::from(has_diag);
        if eliminated {
            out.c_nnz += off;
        } else {
            out.b_nnz += off;
        }
        FastRow::Taken { diag, rhs }
    }
}

/// [`assemble_split_stencil`] keeping the moments of the parity `retained`.
fn assemble_stencil_retaining(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    retained: Retained,
) -> anyhow::Result<Result<SplitSystem, ParityError>> {
    use crate::solver::parity::stencil_s::{
        row_fixes, stencil_terms, Moments, StencilBlock, StencilReduced, MAX_CORRECTION_SHARE,
    };
    let t0 = std::time::Instant::now();
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
    if ev.is_empty() || od.is_empty() {
        return assemble_split_retaining(problem, kernel, layout, retained);
    }
    let kept: Vec<bool> = layout
        .moments
        .iter()
        .map(|mp| retained.keeps(mp.l as usize))
        .collect();
    let m = Moments::from_layout(layout, kept.clone());
    let pos = |g: usize| {
        let (q, idx) = layout.locate(g);
        (q, idx.map(|v| v as i64))
    };
    // Split rows: their local entries, `C` (not `C̃`) for an eliminated row.
    let split_rows = |rows: &[usize]| {
        let (m, rows) = (marshak.as_ref(), rows.iter().copied());
        assemble_and_split(problem, kernel, layout, m, rows, &even, &local)
    };
    // Each moment's stencil from its row nearest the middle of its grid.
    let mut mid = Vec::with_capacity(layout.moments.len());
    for (q, &kept_q) in kept.iter().enumerate() {
        let e = layout.extents[q];
        if e.iter().product::<usize>() == 0 {
            mid.push(([0i64; 3], Vec::new()));
            continue;
        }
        let g = layout.index(q, e.map(|v| v / 2));
        let sc = match split_rows(&[g])? {
            Ok(sc) => sc,
            Err(e) => return Ok(Err(e)),
        };
        let entries: Vec<((usize, [i64; 3]), f64)> = if kept_q {
            sc.b_cols
                .iter()
                .zip(&sc.b_vals)
                .map(|(&c, &v)| (pos(od[c as usize]), v))
                .collect()
        } else {
            let d = sc.d_o[0];
            sc.c_cols
                .iter()
                .zip(&sc.c_vals)
                .map(|(&c, &v)| (pos(ev[c as usize]), d * v))
                .collect()
        };
        mid.push((pos(g).1, entries));
    }
    let b_terms = stencil_terms(&m, true, |q| mid[q].clone());
    let c_terms = stencil_terms(&m, false, |q| mid[q].clone());
    let fast = FastRows::new(problem, kernel, layout, marshak.as_ref());
    // Each chunk's share of the outputs: its rows of the right-hand side, and of `D_e` and
    // `D_o` from the kept rows before it (`local` counts the rows of a row's class before it).
    let (ne, no) = (ev.len(), od.len());
    let (mut d_e, mut d_o, mut rhs) = (vec![0.0; ne], vec![0.0; no], vec![0.0; n]);
    let kept_before = |r: usize| match r {
        r if r >= n => ne,
        r if even[r] => local[r] as usize,
        r => r - local[r] as usize,
    };
    let starts: Vec<usize> = (0..n).step_by(CHUNK).collect();
    let kept = |r0: usize| kept_before((r0 + CHUNK).min(n)) - kept_before(r0);
    let eliminated = |r0: usize| (r0 + CHUNK).min(n) - r0 - kept(r0);
    let e_runs = split_runs(&mut d_e, starts.iter().map(|&r0| kept(r0)));
    let o_runs = split_runs(&mut d_o, starts.iter().map(|&r0| eliminated(r0)));
    let shares: Vec<(usize, RowOut<'_>)> = (starts.iter().zip(rhs.chunks_mut(CHUNK)))
        .zip(e_runs.into_iter().zip(o_runs))
        .map(|((&r0, r), (e, o))| {
            let out = RowOut {
                d_e: e,
                d_o: o,
                rhs: r,
                first: r0,
                first_kept: kept_before(r0),
                first_eliminated: r0 - kept_before(r0),
            };
            (r0, out)
        })
        .collect();
    let chunks: Vec<Result<StencilChunk, ParityError>> = shares
        .into_par_iter()
        .map(|(r0, mut w)| {
            let rows = r0..(r0 + CHUNK).min(n);
            let mut out = StencilChunk::default();
            let mut implied = Vec::new();
            // The rows the fast path cannot take are assembled, split and compared with
            // their stencil together, in row order (`slow`).
            let mut slow = |run: &[usize], out: &mut StencilChunk, w: &mut RowOut<'_>| {
                let sc = match split_rows(run)? {
                    Ok(sc) => sc,
                    Err(e) => return Ok(Err(e)),
                };
                let (mut bp, mut cp, mut bk, mut ck) = (0usize, 0usize, 0usize, 0usize);
                for (&g, &rhs) in run.iter().zip(&sc.rhs) {
                    let (q, ri) = pos(g);
                    let r = local[g] as usize;
                    if even[g] {
                        let len = sc.b_row_nnz[bk];
                        let (cols, vals) = (&sc.b_cols[bp..bp + len], &sc.b_vals[bp..bp + len]);
                        let entries = cols.iter().zip(vals).map(|(&c, &v)| (c as usize, v));
                        row_fixes(
                            &m,
                            &b_terms[q],
                            r,
                            ri,
                            entries,
                            &mut implied,
                            &mut out.b_fixes,
                        );
                        w.set(g, local[g], false, sc.d_e[bk], rhs);
                        bp += len;
                        bk += 1;
                    } else {
                        let len = sc.c_row_nnz[ck];
                        let d = sc.d_o[ck];
                        let (cols, vals) = (&sc.c_cols[cp..cp + len], &sc.c_vals[cp..cp + len]);
                        let entries = cols
                            .iter()
                            .zip(vals)
                            .map(move |(&c, &v)| (c as usize, d * v));
                        row_fixes(
                            &m,
                            &c_terms[q],
                            r,
                            ri,
                            entries,
                            &mut implied,
                            &mut out.c_fixes,
                        );
                        w.set(g, local[g], true, d, rhs);
                        cp += len;
                        ck += 1;
                    }
                }
                out.b_nnz += sc.b_cols.len();
                out.c_nnz += sc.c_cols.len();
                out.diag_entries += sc.diag_entries;
                out.max_entry = out.max_entry.max(sc.max_entry);
                anyhow::Ok(Ok(()))
            };
            let mut ctx = RowContext::new(problem, [0; 3]);
            let mut weights = Vec::new();
            let mut slow_rows = Vec::new();
            for (g, at) in rows.clone().zip(layout.positions_from(rows.start)) {
                let eliminated = !even[g];
                match fast.row(
                    kernel,
                    layout,
                    &mut ctx,
                    &mut weights,
                    (g, at),
                    eliminated,
                    &mut out,
                ) {
                    FastRow::Taken { diag, rhs } => w.set(g, local[g], eliminated, diag, rhs),
                    FastRow::Singular(e) => return Ok(Err(e)),
                    FastRow::NotTaken => slow_rows.push(g),
                }
            }
            // One assembly for all of them: the rows with corrections come in row order,
            // so the corrections stay sorted by row.
            if !slow_rows.is_empty() {
                if let Err(e) = slow(&slow_rows, &mut out, &mut w)? {
                    return Ok(Err(e));
                }
            }
            Ok(Ok(out))
        })
        .collect::<anyhow::Result<_>>()?;
    let chunks = match chunks.into_iter().collect::<Result<Vec<_>, _>>() {
        Ok(c) => c,
        Err(e) => return Ok(Err(e)),
    };
    let (b_nnz, c_nnz) = chunks
        .iter()
        .fold((0, 0), |a, c| (a.0 + c.b_nnz, a.1 + c.c_nnz));
    let (b_fix, c_fix) = chunks.iter().fold((0, 0), |a, c| {
        (a.0 + c.b_fixes.len(), a.1 + c.c_fixes.len())
    });
    if b_fix as f64 > MAX_CORRECTION_SHARE * b_nnz.max(1) as f64
        || c_fix as f64 > MAX_CORRECTION_SHARE * c_nnz.max(1) as f64
    {
        return assemble_split_retaining(problem, kernel, layout, retained);
    }
    let (mut max_entry, mut diag_entries) = (0.0f64, 0usize);
    let (mut b_chunks, mut c_chunks) = (Vec::new(), Vec::new());
    for c in chunks {
        max_entry = max_entry.max(c.max_entry);
        diag_entries += c.diag_entries;
        b_chunks.push(c.b_fixes);
        c_chunks.push(c.c_fixes);
    }
    let stencil = StencilReduced::from_parts(
        m,
        StencilBlock::from_fixes(b_terms, b_chunks),
        StencilBlock::from_fixes(c_terms, c_chunks),
        od.len(),
    );
    Ok(Ok(SplitSystem {
        split: Split {
            even: ev,
            odd: od,
            d_e,
            d_o,
            // Empty blocks, never read (their row pointers are zero pages until touched).
            b: BlockMat::zero((ne, no)),
            c_scaled: BlockMat::zero((no, ne)),
            nnz_a: b_nnz + c_nnz + diag_entries,
            stencil: Some(std::sync::Arc::new(stencil)),
        },
        rhs,
        max_entry,
        seconds_rows: t0.elapsed().as_secs_f64(),
        seconds_append: 0.0,
    }))
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
