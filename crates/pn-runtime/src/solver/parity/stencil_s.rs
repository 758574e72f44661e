//! `S = D_e − B D_o⁻¹ C` applied from the **stencil structure** of its blocks (issue 19:
//! "constant transport weights once, per-cell σ terms, nothing per non-zero").
//!
//! On a staggered grid the off-diagonal blocks `B` (kept rows × eliminated columns) and
//! `C = D_o C̃` (eliminated rows × kept columns) are the transport terms of the stencil:
//! every row of one moment has the same weights `±c/h` at the same index shifts, whatever
//! the medium (the σ terms are all on the diagonals `D_e`, `D_o`; docs/design.md §3, §5).
//! [`StencilReduced::build`] recovers, for each moment, that stencil from one interior row
//! of the assembled blocks, and keeps as **corrections** only the entries where a row
//! differs from its moment's stencil restricted to the grid (the references the Neumann
//! closure clamped, a PDE's own boundary rows). Applying `S` then reads the vectors and the
//! two diagonals, not the blocks' 12 bytes per entry: about `8·(4 n_e + 3 n_o)` bytes per
//! application instead of `12·(nnz B + nnz C̃) + …` ([`StencilReduced::bytes`]).
//!
//! The recovered operator equals the blocks' up to rounding: a weight of `C` is taken as
//! its moment's when it agrees to [`SAME_WEIGHT`] relative (`C = D_o C̃` is recomputed from
//! the stored `C̃`), otherwise the difference is a correction. Blocks that are not
//! stencil-like — more than [`MAX_CORRECTION_SHARE`] of their entries would be corrections,
//! or the unknowns are not whole moment grids in the layout's order — are not compressed
//! ([`StencilReduced::build`] returns `None`) and `S` is applied from the blocks as before.
//! The residual that stops the solve is always computed from the blocks.

mod galerkin;
mod interior;

use super::block_mat::BlockMat;
use crate::matfree::{for_planes_across, range, shifted_lines};
use crate::solver::multigrid::Geometry;
use pn_krylov::linalg::Real;
use rayon::prelude::*;
use std::sync::Mutex;

/// Largest share of a block's stored entries that may become corrections; above it the
/// block is not stencil-like and `S` stays on the blocks. A correction moves 16 bytes per
/// application where the block moves 12 per entry, so at half the entries the stencil
/// route still moves less. (The Neumann-clamped references are 7.7 % of `C`'s entries on
/// the 14³ point source at P_1, 0.9–1.5 % on the 41² checkerboard at P_1; the zero
/// closure has none.)
pub const MAX_CORRECTION_SHARE: f64 = 0.5;

/// Rows per parallel task when the corrections are collected.
const FIX_CHUNK: usize = 4096;

/// Relative difference under which a row's weight counts as its moment's stencil weight
/// (`C = D_o C̃` recomputed from `C̃` differs from the stencil's weight by rounding).
pub const SAME_WEIGHT: f64 = 1e-12;

/// One stencil term: the referenced moment, the index shift and the weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Term {
    moment: usize,
    delta: [i64; 3],
    weight: f64,
}

/// One block as per-moment stencils plus corrections.
#[derive(Clone, Debug, Default)]
pub(crate) struct StencilBlock {
    /// Terms of each row moment (empty for moments not in the block's rows).
    terms: Vec<Vec<Term>>,
    /// Corrections `(row, column, value)` in local indices, sorted by row.
    fix_rows: Vec<u32>,
    fix_cols: Vec<u32>,
    fix_vals: Vec<f64>,
}

/// The moment grids: extents, and where each moment starts in its class's local vector.
#[derive(Clone, Debug)]
pub(crate) struct Moments {
    ext: Vec<[usize; 3]>,
    /// Whether each moment is kept (in `S`'s unknowns).
    kept: Vec<bool>,
    /// Start of each moment in the local vector of its class (kept or eliminated).
    local_off: Vec<usize>,
}

impl Moments {
    fn linear(&self, q: usize, idx: [usize; 3]) -> usize {
        let e = self.ext[q];
        (idx[0] * e[1] + idx[1]) * e[2] + idx[2]
    }

    /// The moment grids of `layout` (stored moment by moment, x slowest), with the moments
    /// `kept[q]` in the reduced system.
    pub(crate) fn from_layout(layout: &crate::layout::Layout, kept: Vec<bool>) -> Self {
        let nm = layout.moments.len();
        let ext = layout.extents.clone();
        let mut local_off = vec![0; nm];
        let (mut kept_at, mut elim_at) = (0, 0);
        for q in 0..nm {
            let at = if kept[q] { &mut kept_at } else { &mut elim_at };
            local_off[q] = *at;
            *at += ext[q].iter().product::<usize>();
        }
        Self {
            ext,
            kept,
            local_off,
        }
    }
}

/// `S` applied from per-moment stencils (see the module documentation).
#[derive(Debug)]
pub struct StencilReduced {
    moments: Moments,
    b: StencilBlock,
    c: StencilBlock,
    /// `t = D_o⁻¹ C x`, reused between applications.
    tmp: Mutex<Vec<f64>>,
}

impl StencilReduced {
    /// Recovers the stencils of the blocks `b` (rows `even`, columns `odd`: global indices)
    /// and `c_scaled` (`C̃ = D_o⁻¹ C`, rows `odd`, columns `even`), with `geometry` the class
    /// (moment) and grid position of every global unknown ([`Geometry::from_layout`]).
    /// `None` when the unknowns are not whole moment grids stored moment by moment, x
    /// slowest, or a block is not stencil-like (see the module documentation). The usual
    /// entry is [`StencilReduced::build`] (module `reduced`), from a
    /// [`super::split::Split`].
    pub fn from_blocks(
        b: &BlockMat,
        c_scaled: &BlockMat,
        even: &[usize],
        odd: &[usize],
        d_o: &[f64],
        geometry: &Geometry,
    ) -> Option<Self> {
        let n = even.len() + odd.len();
        if geometry.len() != n || n == 0 {
            return None;
        }
        let nm = *geometry.class.iter().max()? as usize + 1;
        let mut ext = vec![[0usize; 3]; nm];
        let mut count = vec![0usize; nm];
        for (&q, c) in geometry.class.iter().zip(&geometry.coords) {
            let e = &mut ext[q as usize];
            for d in 0..3 {
                e[d] = e[d].max(c[d] as usize + 1);
            }
            count[q as usize] += 1;
        }
        if (0..nm).any(|q| count[q] != ext[q].iter().product::<usize>()) {
            return None;
        }
        // Global order: moment by moment, x slowest.
        let mut global_off = vec![0usize; nm + 1];
        for q in 0..nm {
            global_off[q + 1] = global_off[q] + count[q];
        }
        let mut kept = vec![false; nm];
        for &g in even {
            kept[geometry.class[g] as usize] = true;
        }
        let mut moments = Moments {
            ext,
            kept,
            local_off: vec![0; nm],
        };
        let ordered = (0..n).into_par_iter().all(|g| {
            let q = geometry.class[g] as usize;
            let c = geometry.coords[g].map(|v| v as usize);
            g == global_off[q] + moments.linear(q, c)
        });
        let whole = odd
            .par_iter()
            .all(|&g| !moments.kept[geometry.class[g] as usize]);
        if !ordered || !whole {
            return None;
        }
        let (mut kept_at, mut elim_at) = (0, 0);
        for (q, &n_q) in count.iter().enumerate() {
            let at = if moments.kept[q] {
                &mut kept_at
            } else {
                &mut elim_at
            };
            moments.local_off[q] = *at;
            *at += n_q;
        }
        let b = block(b, even, odd, None, geometry, &moments)?;
        let c = block(c_scaled, odd, even, Some(d_o), geometry, &moments)?;
        Some(Self {
            moments,
            b,
            c,
            tmp: Mutex::new(vec![0.0; odd.len()]),
        })
    }

    /// The operator from its parts (the stencil assembly,
    /// [`crate::assemble_split::assemble_split_stencil`]), for `n_odd` eliminated unknowns.
    pub(crate) fn from_parts(
        moments: Moments,
        b: StencilBlock,
        c: StencilBlock,
        n_odd: usize,
    ) -> Self {
        Self {
            moments,
            b,
            c,
            tmp: Mutex::new(vec![0.0; n_odd]),
        }
    }

    /// `t = C̃ x = D_o⁻¹ C x` (kept-local `x`, eliminated-local `t`).
    pub fn apply_c_scaled(&self, d_o: &[f64], x: &[f64], t: &mut [f64]) {
        let m = &self.moments;
        for_slabs(m, false, t, |q, ix, start, ts| {
            stencil_slab(m, &self.c.terms[q], q, ix, x, ts);
            self.c.correct(start, ts, x);
            let d = &d_o[start..start + ts.len()];
            ts.iter_mut().zip(d).for_each(|(v, d)| *v /= d);
        });
    }

    /// `y = B t` (eliminated-local `t`, kept-local `y`).
    pub fn apply_b(&self, t: &[f64], y: &mut [f64]) {
        let m = &self.moments;
        for_slabs(m, true, y, |q, ix, start, ys| {
            stencil_slab(m, &self.b.terms[q], q, ix, t, ys);
            self.b.correct(start, ys, t);
        });
    }

    /// Number of corrections (entries where a row differs from its moment's stencil).
    pub fn corrections(&self) -> usize {
        self.b.fix_vals.len() + self.c.fix_vals.len()
    }

    /// Bytes one application moves in the roofline model ([`crate::bandwidth`]): `x` read
    /// twice, `y` written, `D_e` read (`32·n_e`); `t` written and read and `D_o` read
    /// (`24·n_o`); each correction's row, column and value (16 bytes). The stencil tables
    /// are a few kilobytes and not counted; the shifted reads of `x` and `t` are assumed to
    /// hit cache after the first.
    pub fn bytes(&self, n_e: usize, n_o: usize) -> u64 {
        (32 * n_e + 24 * n_o + 16 * self.corrections()) as u64
    }

    /// `y = S x = D_e x − B D_o⁻¹ C x` (kept-local vectors; `d_e`, `d_o` the diagonals).
    pub fn apply(&self, d_e: &[f64], d_o: &[f64], x: &[f64], y: &mut [f64]) {
        let mut t = self.tmp.lock().unwrap_or_else(|e| e.into_inner());
        self.apply_with(d_e, d_o, x, y, &mut t);
    }

    /// [`StencilReduced::apply`] in any [`Real`] type (the single-precision finest level of
    /// the multigrid cycle), with `t` a work vector of the eliminated unknowns.
    pub fn apply_with<T: Real>(&self, d_e: &[T], d_o: &[T], x: &[T], y: &mut [T], t: &mut [T]) {
        let m = &self.moments;
        // t = D_o⁻¹ (C x), slab by slab.
        for_slabs(m, false, t, |q, ix, start, ts| {
            stencil_slab(m, &self.c.terms[q], q, ix, x, ts);
            self.c.correct(start, ts, x);
            let d = &d_o[start..start + ts.len()];
            ts.iter_mut().zip(d).for_each(|(v, &d)| *v = *v / d);
        });
        let t = &*t;
        // y = D_e x − B t.
        for_slabs(m, true, y, |q, ix, start, ys| {
            stencil_slab(m, &self.b.terms[q], q, ix, t, ys);
            self.b.correct(start, ys, t);
            let (xs, d) = (&x[start..start + ys.len()], &d_e[start..start + ys.len()]);
            ys.iter_mut()
                .zip(xs.iter().zip(d))
                .for_each(|(v, (&x, &d))| *v = d * x - *v);
        });
    }
}

impl StencilBlock {
    /// Adds the corrections of rows `start..start + out.len()` to `out`.
    fn correct<T: Real>(&self, start: usize, out: &mut [T], x: &[T]) {
        let lo = self.fix_rows.partition_point(|&r| (r as usize) < start);
        let hi = self
            .fix_rows
            .partition_point(|&r| (r as usize) < start + out.len());
        for k in lo..hi {
            out[self.fix_rows[k] as usize - start] +=
                T::of(self.fix_vals[k]) * x[self.fix_cols[k] as usize];
        }
    }
}

/// Runs `f(moment, x index, first local row, slab)` in parallel over the x-planes of the
/// moments of one class (`kept` or eliminated) of the local vector `v`, x-plane by x-plane
/// across the moments ([`for_planes_across`]). Moment by moment instead, every source plane
/// came from memory once per moment reading it (80³ P_5 point source: 52 → 36 ms per
/// application in f64, 25 → 19 ms in f32).
fn for_slabs<T: Real>(
    m: &Moments,
    kept: bool,
    v: &mut [T],
    f: impl Fn(usize, usize, usize, &mut [T]) + Sync,
) {
    let boxes = (0..m.ext.len())
        .filter(|&q| m.kept[q] == kept)
        .map(|q| (q, m.ext[q].iter().product(), m.ext[q][1] * m.ext[q][2]));
    for_planes_across(v, boxes, f);
}

/// `out = Σ_terms w · src[shifted]` over the in-grid references of x-plane `ix` of row
/// moment `q` (`src` is the other class's local vector).
///
/// In 2D, where every moment has one z position, the plane is one line along y, summed
/// over all its terms at once ([`fused_line`]): every output value is stored once instead
/// of being read and written again for each term (71² checkerboard P_5: cycles 0.141 s
/// against 0.146 s). In 3D the terms are added one by one.
fn stencil_slab<T: Real>(
    m: &Moments,
    terms: &[Term],
    q: usize,
    ix: usize,
    src: &[T],
    out: &mut [T],
) {
    let e = m.ext[q];
    let mut parts: Vec<LinePart<T>> = Vec::with_capacity(terms.len());
    // The x-plane of moment `p` shifted by `dx`, if it lies in `p`'s grid.
    let plane_of = |t: &Term| {
        let ep = m.ext[t.moment];
        let ixr = ix as i64 + t.delta[0];
        (ixr >= 0 && ixr < ep[0] as i64)
            .then(|| m.local_off[t.moment] + ixr as usize * ep[1] * ep[2])
    };
    let flat = e[2] == 1 && terms.iter().all(|t| m.ext[t.moment][2] == 1);
    if flat {
        // 2D: the plane is one line along y.
        for t in terms {
            let Some(plane) = plane_of(t) else { continue };
            let ys = range(e[1], m.ext[t.moment][1], t.delta[1]);
            if !ys.is_empty() {
                parts.push(LinePart {
                    weight: T::of(t.weight),
                    base: plane as i64 + t.delta[1],
                    valid: ys,
                });
            }
        }
        fused_line(out, &parts, src);
        return;
    }
    // 3D: the terms whose reference keeps the z positions (∂x, ∂y: one contiguous run of
    // the source plane each) are summed over the whole plane at once, as one line
    // ([`fused_line`]), so that the output plane is stored once for all of them instead of
    // being read and written again per term; the ∂z terms follow line by line. (Fusing all
    // terms line by line measured slower, the z-lines being short; tiling the plane into
    // cache-sized blocks of lines gained nothing.) 80³ P_5 point source, f64, median of
    // `cargo run --release -p pn-drivers --example stencil_apply -- 80 5`: 36 → 32 ms.
    let mut z_terms = Vec::new();
    for t in terms {
        let Some(plane) = plane_of(t) else { continue };
        let ep = m.ext[t.moment];
        let [_, dy, dz] = t.delta;
        if dz == 0 && ep[2] == e[2] {
            let ys = range(e[1], ep[1], dy);
            if !ys.is_empty() {
                parts.push(LinePart {
                    weight: T::of(t.weight),
                    base: plane as i64 + dy * e[2] as i64,
                    valid: ys.start * e[2]..ys.end * e[2],
                });
            }
        } else {
            z_terms.push((t, plane));
        }
    }
    fused_line(out, &parts, src);
    for (t, plane) in z_terms {
        let ep = m.ext[t.moment];
        let [_, dy, dz] = t.delta;
        let w = T::of(t.weight);
        for (at, first) in shifted_lines(e, ep, plane, dy, dz) {
            let xs = &src[first..first + at.len()];
            out[at].iter_mut().zip(xs).for_each(|(o, &x)| *o += w * x);
        }
    }
}

/// One term's contribution to a line of the output: `out[i] += weight · src[base + i]` for
/// `i` in `valid` (the positions whose reference lies in the source moment's grid).
struct LinePart<T> {
    weight: T,
    base: i64,
    valid: std::ops::Range<usize>,
}

/// `out[i] = Σ_parts w · src[base + i]` over the parts whose `valid` range holds `i`
/// (zero where none does). On the positions every part covers (all of an interior line)
/// the terms are summed in registers, eight values at a time, and each value is stored
/// once; the few positions at the ends, where a shifted reference leaves its grid, take
/// the terms one by one.
#[inline]
fn fused_line<T: Real>(out: &mut [T], parts: &[LinePart<T>], src: &[T]) {
    let len = out.len();
    let lo = parts
        .iter()
        .map(|p| p.valid.start)
        .max()
        .unwrap_or(len)
        .min(len);
    let hi = parts.iter().map(|p| p.valid.end).min().unwrap_or(0).max(lo);
    // The ends: term by term.
    out[..lo].fill(T::default());
    out[hi..].fill(T::default());
    for p in parts {
        for i in (p.valid.start..lo.min(p.valid.end)).chain(hi.max(p.valid.start)..p.valid.end) {
            out[i] += p.weight * src[(p.base + i as i64) as usize];
        }
    }
    // The common part: all terms at once, in blocks of 32 values (four to eight registers'
    // worth of independent sums, so that the additions of successive terms overlap instead
    // of waiting on one another), then of 8, then one by one. Every value's terms are
    // added in the same order whatever the block, so the result does not depend on it.
    let mut i = sum_blocks::<T, 32>(out, parts, src, lo, hi);
    i = sum_blocks::<T, 8>(out, parts, src, i, hi);
    for (k, o) in out[i..hi].iter_mut().enumerate() {
        *o = parts.iter().fold(T::default(), |a, p| {
            a + p.weight * src[(p.base + (i + k) as i64) as usize]
        });
    }
}

/// `out[i] = Σ_parts w · src[base + i]` for `i` from `from` in whole blocks of `B` below
/// `to`, the block's sums kept in registers; returns where the blocks stopped. With one
/// block of eight `f64` values (two registers), each term's additions waited for the
/// previous term's (80³ P_5 point source: 32 ms per `f64` application of `S`).
#[inline(always)]
fn sum_blocks<T: Real, const B: usize>(
    out: &mut [T],
    parts: &[LinePart<T>],
    src: &[T],
    from: usize,
    to: usize,
) -> usize {
    let mut i = from;
    while i + B <= to {
        let mut acc = [T::default(); B];
        for p in parts {
            let s0 = (p.base + i as i64) as usize;
            let xs = &src[s0..s0 + B];
            for k in 0..B {
                acc[k] += p.weight * xs[k];
            }
        }
        out[i..i + B].copy_from_slice(&acc);
        i += B;
    }
    i
}

/// The stencils and corrections of `mat` (rows `rows`, columns `cols`: global indices in
/// local order), each row scaled by `scale[row]` when given (`C = D_o C̃`).
fn block(
    mat: &BlockMat,
    rows: &[usize],
    cols: &[usize],
    scale: Option<&[f64]>,
    geometry: &Geometry,
    m: &Moments,
) -> Option<StencilBlock> {
    let pos = |g: usize| {
        (
            geometry.class[g] as usize,
            geometry.coords[g].map(|v| v as i64),
        )
    };
    let row_kept = rows.first().map(|&g| m.kept[geometry.class[g] as usize])?;
    let entries = |r: usize| {
        let range = mat.indptr().outer_inds_sz(r);
        let s = scale.map_or(1.0, |s| s[r]);
        range.map(move |j| (mat.indices()[j] as usize, s * mat.data()[j]))
    };
    let terms = stencil_terms(m, row_kept, |q| {
        let r = m.local_off[q] + m.linear(q, m.ext[q].map(|v| v / 2));
        (
            pos(rows[r]).1,
            entries(r).map(|(c, w)| (pos(cols[c]), w)).collect(),
        )
    });
    // Corrections: rows in chunks, so that nothing is allocated per row.
    let per_chunk: Vec<Vec<(u32, u32, f64)>> = (0..rows.len().div_ceil(FIX_CHUNK))
        .into_par_iter()
        .map(|k| {
            let mut fixes = Vec::new();
            let mut implied = Vec::new();
            let first = k * FIX_CHUNK;
            let chunk = &rows[first..(first + FIX_CHUNK).min(rows.len())];
            for (r, &g) in (first..).zip(chunk) {
                let (q, ri) = pos(g);
                row_fixes(m, &terms[q], r, ri, entries(r), &mut implied, &mut fixes);
            }
            fixes
        })
        .collect();
    let n_fix: usize = per_chunk.iter().map(Vec::len).sum();
    if n_fix as f64 > MAX_CORRECTION_SHARE * mat.nnz().max(1) as f64 {
        return None;
    }
    Some(StencilBlock::from_fixes(terms, per_chunk))
}

/// Each row moment's stencil (of the class `row_kept`) from one of its rows: `row_of(q)`
/// gives that row's position and its entries as `((column moment, column position),
/// weight)`.
pub(crate) fn stencil_terms(
    m: &Moments,
    row_kept: bool,
    row_of: impl Fn(usize) -> ([i64; 3], Vec<((usize, [i64; 3]), f64)>),
) -> Vec<Vec<Term>> {
    let nm = m.ext.len();
    let mut terms = vec![Vec::new(); nm];
    for q in (0..nm).filter(|&q| m.kept[q] == row_kept) {
        let (ri, entries) = row_of(q);
        terms[q] = entries
            .into_iter()
            .map(|((p, pi), w)| Term {
                moment: p,
                delta: [0, 1, 2].map(|d| pi[d] - ri[d]),
                weight: w,
            })
            .collect();
    }
    terms
}

/// Appends to `fixes` the corrections `(row, column, value)` of local row `r` (position
/// `ri`, entries `(local column, weight)`) against its moment's stencil `terms` restricted
/// to the grid. `implied` is scratch space.
pub(crate) fn row_fixes(
    m: &Moments,
    terms: &[Term],
    r: usize,
    ri: [i64; 3],
    entries: impl ExactSizeIterator<Item = (usize, f64)> + Clone,
    implied: &mut Vec<(usize, f64, bool)>,
    fixes: &mut Vec<(u32, u32, f64)>,
) {
    implied.clear();
    implied.extend(terms.iter().filter_map(|t| {
        let ep = m.ext[t.moment];
        let idx = [0, 1, 2].map(|d| ri[d] + t.delta[d]);
        let inside = (0..3).all(|d| idx[d] >= 0 && idx[d] < ep[d] as i64);
        inside.then(|| {
            let c = m.local_off[t.moment] + m.linear(t.moment, idx.map(|v| v as usize));
            (c, t.weight, false)
        })
    }));
    // Most rows hold exactly their stencil, in the stencil's order: one pass.
    let same = entries.len() == implied.len()
        && entries
            .clone()
            .zip(implied.iter())
            .all(|((c, w), &(ic, wt, _))| c == ic && (w - wt).abs() <= SAME_WEIGHT * wt.abs());
    if same {
        return;
    }
    for (c, w) in entries {
        match implied.iter_mut().find(|(ic, _, _)| *ic == c) {
            Some((_, wt, seen)) => {
                *seen = true;
                if (w - *wt).abs() > SAME_WEIGHT * wt.abs() {
                    fixes.push((r as u32, c as u32, w - *wt));
                }
            }
            None => fixes.push((r as u32, c as u32, w)),
        }
    }
    for &(c, wt, seen) in implied.iter() {
        if !seen {
            fixes.push((r as u32, c as u32, -wt));
        }
    }
}

impl StencilBlock {
    /// A block from its stencils and its corrections, given in row order (chunk by chunk).
    pub(crate) fn from_fixes(terms: Vec<Vec<Term>>, chunks: Vec<Vec<(u32, u32, f64)>>) -> Self {
        let n_fix: usize = chunks.iter().map(Vec::len).sum();
        let mut out = StencilBlock {
            terms,
            fix_rows: Vec::with_capacity(n_fix),
            fix_cols: Vec::with_capacity(n_fix),
            fix_vals: Vec::with_capacity(n_fix),
        };
        for (r, c, v) in chunks.into_iter().flatten() {
            out.fix_rows.push(r);
            out.fix_cols.push(c);
            out.fix_vals.push(v);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fused_line` against the term-by-term sum: parts covering the whole line, parts
    /// clipped at either end, a part disjoint from the others' common range, none at all.
    #[test]
    fn fused_line_equals_term_by_term_sum() {
        let src: Vec<f64> = (0..200).map(|i| ((i * 37 % 101) as f64) - 50.0).collect();
        let cases: Vec<Vec<LinePart<f64>>> = vec![
            vec![],
            vec![
                LinePart {
                    weight: 0.5,
                    base: 10,
                    valid: 0..29,
                },
                LinePart {
                    weight: -2.0,
                    base: 40,
                    valid: 0..29,
                },
            ],
            vec![
                LinePart {
                    weight: 1.5,
                    base: 3,
                    valid: 1..29,
                },
                LinePart {
                    weight: -0.25,
                    base: 60,
                    valid: 0..28,
                },
                LinePart {
                    weight: 3.0,
                    base: 100,
                    valid: 2..29,
                },
            ],
            vec![
                LinePart {
                    weight: 1.0,
                    base: 0,
                    valid: 0..5,
                },
                LinePart {
                    weight: 2.0,
                    base: 50,
                    valid: 20..29,
                },
            ],
        ];
        for parts in &cases {
            let mut want = vec![0.0; 29];
            for p in parts {
                for i in p.valid.clone() {
                    want[i] += p.weight * src[(p.base + i as i64) as usize];
                }
            }
            let mut out = vec![f64::NAN; 29];
            fused_line(&mut out, parts, &src);
            for (o, w) in out.iter().zip(&want) {
                assert!((o - w).abs() <= 1e-12 * (1.0 + w.abs()), "{o} vs {w}");
            }
        }
    }
}
