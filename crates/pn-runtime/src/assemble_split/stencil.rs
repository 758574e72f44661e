//! The stencil form of the split assembly ([`super::assemble_split_stencil`]): the rows are
//! assembled chunk by chunk in parallel, an interior row equal to its moment's stencil by a
//! fast path that keeps only its diagonal and right-hand side ([`FastRows`]), the others
//! assembled, split and compared with their stencil, keeping their corrections.

use super::{
    assemble_and_split, assemble_split_retaining, prologue, Prologue, SplitChunk, SplitSystem,
};
use crate::assemble::CHUNK;
use crate::context::RowContext;
use crate::layout::Layout;
use crate::marshak::MarshakRows;
use crate::problem::Problem;
use crate::solver::parity::split::{BlockMat, Classes, ParityError, Split};
use crate::solver::parity::stencil_s::{
    row_fixes, stencil_terms, Moments, StencilBlock, StencilReduced, Term, MAX_CORRECTION_SHARE,
};
use crate::solver::pn_layout::Retained;
use pn_krylov::linalg::split_runs;
use pn_stencil::{StencilKernel, TermPattern};
use rayon::prelude::*;

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

/// A moment's reference row for the stencils of [`assemble_stencil_retaining`]: its
/// position, and its entries with their columns as (moment, position).
type MidRow = ([i64; 3], Vec<((usize, [i64; 3]), f64)>);

/// The rows of a split assembly, assembled and split on demand.
struct SplitRows<'a> {
    problem: &'a Problem,
    kernel: &'a dyn StencilKernel,
    layout: &'a Layout,
    marshak: Option<&'a MarshakRows>,
    /// Whether each unknown is kept, and its index within its class.
    even: &'a [bool],
    local: &'a [u32],
}

impl SplitRows<'_> {
    /// The rows `rows` split: their local entries, `C` (not `C̃`) for an eliminated row.
    fn split(&self, rows: &[usize]) -> anyhow::Result<Result<SplitChunk, ParityError>> {
        let (m, rows) = (self.marshak, rows.iter().copied());
        let (problem, kernel, layout) = (self.problem, self.kernel, self.layout);
        assemble_and_split(problem, kernel, layout, m, rows, self.even, self.local)
    }

    /// Row `g`'s moment and position on the moment's grid.
    fn pos(&self, g: usize) -> (usize, [i64; 3]) {
        let (q, idx) = self.layout.locate(g);
        (q, idx.map(|v| v as i64))
    }
}

/// Each moment's stencil from its row nearest the middle of its grid: the entries of `B`
/// for a kept moment (`kept`), of `C̃` for an eliminated one (`ev`, `od`: the classes).
fn mid_rows(
    rows: &SplitRows<'_>,
    kept: &[bool],
    ev: &[usize],
    od: &[usize],
) -> anyhow::Result<Result<Vec<MidRow>, ParityError>> {
    let layout = rows.layout;
    let mut mid = Vec::with_capacity(layout.moments.len());
    for (q, &kept_q) in kept.iter().enumerate() {
        let e = layout.extents[q];
        if e.iter().product::<usize>() == 0 {
            mid.push(([0i64; 3], Vec::new()));
            continue;
        }
        let g = layout.index(q, e.map(|v| v / 2));
        let sc = match rows.split(&[g])? {
            Ok(sc) => sc,
            Err(e) => return Ok(Err(e)),
        };
        let entries: Vec<((usize, [i64; 3]), f64)> = if kept_q {
            sc.b_cols
                .iter()
                .zip(&sc.b_vals)
                .map(|(&c, &v)| (rows.pos(od[c as usize]), v))
                .collect()
        } else {
            let d = sc.d_o[0];
            sc.c_cols
                .iter()
                .zip(&sc.c_vals)
                .map(|(&c, &v)| (rows.pos(ev[c as usize]), d * v))
                .collect()
        };
        mid.push((rows.pos(g).1, entries));
    }
    Ok(Ok(mid))
}

/// Each chunk's share of the outputs, with its first row: its rows of the right-hand side
/// `rhs`, and of `d_e` and `d_o` from the kept rows before it (`local` counts the rows of a
/// row's class before it; `even` says which rows are kept).
fn row_outs<'o>(
    d_e: &'o mut [f64],
    d_o: &'o mut [f64],
    rhs: &'o mut [f64],
    even: &[bool],
    local: &[u32],
) -> Vec<(usize, RowOut<'o>)> {
    let (n, ne) = (rhs.len(), d_e.len());
    let kept_before = |r: usize| match r {
        r if r >= n => ne,
        r if even[r] => local[r] as usize,
        r => r - local[r] as usize,
    };
    let starts: Vec<usize> = (0..n).step_by(CHUNK).collect();
    let kept = |r0: usize| kept_before((r0 + CHUNK).min(n)) - kept_before(r0);
    let eliminated = |r0: usize| (r0 + CHUNK).min(n) - r0 - kept(r0);
    let e_runs = split_runs(d_e, starts.iter().map(|&r0| kept(r0)));
    let o_runs = split_runs(d_o, starts.iter().map(|&r0| eliminated(r0)));
    (starts.iter().zip(rhs.chunks_mut(CHUNK)))
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
        .collect()
}

/// What every chunk of rows of [`assemble_stencil_retaining`] reads: the rows, the moments'
/// stencils and the fast path.
struct StencilPass<'a> {
    rows: SplitRows<'a>,
    m: Moments,
    /// The stencils of the kept rows (`B`) and of the eliminated ones (`C̃`).
    b_terms: Vec<Vec<Term>>,
    c_terms: Vec<Vec<Term>>,
    fast: FastRows<'a>,
}

impl StencilPass<'_> {
    /// The chunk of rows from `r0` ([`CHUNK`] of them) into `w`: each row the fast path
    /// takes, then the others assembled together ([`Self::slow`]).
    fn chunk(
        &self,
        r0: usize,
        mut w: RowOut<'_>,
    ) -> anyhow::Result<Result<StencilChunk, ParityError>> {
        let (layout, even, local) = (self.rows.layout, self.rows.even, self.rows.local);
        let rows = r0..(r0 + CHUNK).min(layout.len());
        let mut out = StencilChunk::default();
        let mut ctx = RowContext::new(self.rows.problem, [0; 3]);
        let mut weights = Vec::new();
        let mut slow_rows = Vec::new();
        for (g, at) in rows.clone().zip(layout.positions_from(rows.start)) {
            let eliminated = !even[g];
            match self.fast.row(
                self.rows.kernel,
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
            if let Err(e) = self.slow(&slow_rows, &mut out, &mut w)? {
                return Ok(Err(e));
            }
        }
        Ok(Ok(out))
    }

    /// The rows `run` the fast path cannot take, assembled, split and compared with their
    /// stencil together, in row order: their corrections and counts into `out`, their
    /// diagonals and right-hand sides into `w`.
    fn slow(
        &self,
        run: &[usize],
        out: &mut StencilChunk,
        w: &mut RowOut<'_>,
    ) -> anyhow::Result<Result<(), ParityError>> {
        let (m, even, local) = (&self.m, self.rows.even, self.rows.local);
        let mut implied = Vec::new();
        let sc = match self.rows.split(run)? {
            Ok(sc) => sc,
            Err(e) => return Ok(Err(e)),
        };
        let (mut bp, mut cp, mut bk, mut ck) = (0usize, 0usize, 0usize, 0usize);
        for (&g, &rhs) in run.iter().zip(&sc.rhs) {
            let (q, ri) = self.rows.pos(g);
            let r = local[g] as usize;
            if even[g] {
                let len = sc.b_row_nnz[bk];
                let (cols, vals) = (&sc.b_cols[bp..bp + len], &sc.b_vals[bp..bp + len]);
                let entries = cols.iter().zip(vals).map(|(&c, &v)| (c as usize, v));
                let terms = &self.b_terms[q];
                row_fixes(m, terms, r, ri, entries, &mut implied, &mut out.b_fixes);
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
                let terms = &self.c_terms[q];
                row_fixes(m, terms, r, ri, entries, &mut implied, &mut out.c_fixes);
                w.set(g, local[g], true, d, rhs);
                cp += len;
                ck += 1;
            }
        }
        out.b_nnz += sc.b_cols.len();
        out.c_nnz += sc.c_cols.len();
        out.diag_entries += sc.diag_entries;
        out.max_entry = out.max_entry.max(sc.max_entry);
        Ok(Ok(()))
    }
}

/// [`super::assemble_split_stencil`] keeping the moments of the parity `retained`.
pub(super) fn assemble_stencil_retaining(
    problem: &Problem,
    kernel: &dyn StencilKernel,
    layout: &Layout,
    retained: Retained,
) -> anyhow::Result<Result<SplitSystem, ParityError>> {
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
    let rows = SplitRows {
        problem,
        kernel,
        layout,
        marshak: marshak.as_ref(),
        even: &even,
        local: &local,
    };
    let mid = match mid_rows(&rows, &kept, &ev, &od)? {
        Ok(mid) => mid,
        Err(e) => return Ok(Err(e)),
    };
    let b_terms = stencil_terms(&m, true, |q| mid[q].clone());
    let c_terms = stencil_terms(&m, false, |q| mid[q].clone());
    let fast = FastRows::new(problem, kernel, layout, marshak.as_ref());
    let pass = StencilPass {
        rows,
        m,
        b_terms,
        c_terms,
        fast,
    };
    let (ne, no) = (ev.len(), od.len());
    let (mut d_e, mut d_o, mut rhs) = (vec![0.0; ne], vec![0.0; no], vec![0.0; n]);
    let shares = row_outs(&mut d_e, &mut d_o, &mut rhs, &even, &local);
    let chunks: Vec<Result<StencilChunk, ParityError>> = shares
        .into_par_iter()
        .map(|(r0, w)| pass.chunk(r0, w))
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
    let StencilPass {
        m,
        b_terms,
        c_terms,
        ..
    } = pass;
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
